// Independent check of the LAZ codec with npm's laz-perf (LASzip compiled to WASM).
//   node laz_perf_check.js MODULE_DIR FILE.laz FILE.las [--bench]
// Decodes every point of FILE.laz with laz-perf and compares its raw record, byte for byte, with the
// same record of the uncompressed FILE.las. Exits 0 when all are equal, 1 on a difference, 77 when
// laz-perf is not installed (ctest's skip code). --bench also prints laz-perf's decode rate.
'use strict';
const fs = require('fs');
const path = require('path');

async function main() {
  const [moduleDir, lazPath, lasPath] = process.argv.slice(2);
  const bench = process.argv.includes('--bench');
  let createLazPerf;
  try {
    createLazPerf = require(path.resolve(moduleDir, 'node_modules', 'laz-perf')).createLazPerf;
  } catch (e) {
    console.log('laz-perf is not installed under ' + moduleDir + ': skipped');
    process.exit(77);
  }
  const LazPerf = await createLazPerf();
  const laz = fs.readFileSync(lazPath);
  const las = fs.readFileSync(lasPath);
  const lasOffset = las.readUInt32LE(96);
  const lasLength = las.readUInt16LE(105);
  const lasFormat = las[104];
  const filePtr = LazPerf._malloc(laz.length);
  LazPerf.HEAPU8.set(laz, filePtr);
  const reader = new LazPerf.LASZip();
  reader.open(filePtr, laz.length);
  const count = reader.getCount();
  const length = reader.getPointLength();
  const format = reader.getPointFormat();
  if (length !== lasLength || (format & 0x3f) !== lasFormat) {
    console.log(`record layout differs: laz-perf ${format}/${length}, LAS ${lasFormat}/${lasLength}`);
    process.exit(1);
  }
  const lasCount = las[25] >= 4 && las.readUInt32LE(107) === 0 ? Number(las.readBigUInt64LE(247)) : las.readUInt32LE(107);
  if (count !== lasCount) {
    console.log(`point count differs: laz-perf ${count}, LAS ${lasCount}`);
    process.exit(1);
  }
  const pointPtr = LazPerf._malloc(length);
  let bad = 0;
  const t0 = process.hrtime.bigint();
  for (let i = 0; i < count; ++i) {
    reader.getPoint(pointPtr);
    if (bench) continue;
    const got = LazPerf.HEAPU8.subarray(pointPtr, pointPtr + length);
    const want = las.subarray(lasOffset + i * length, lasOffset + (i + 1) * length);
    if (Buffer.compare(Buffer.from(got), want) !== 0 && bad++ < 3) console.log(`point ${i} differs`);
  }
  const seconds = Number(process.hrtime.bigint() - t0) / 1e9;
  reader.delete();
  LazPerf._free(pointPtr);
  LazPerf._free(filePtr);
  if (bench) {
    console.log(`laz-perf: ${count} points in ${seconds.toFixed(3)} s = ${(count / seconds / 1e6).toFixed(2)} Mpoints/s`);
    return;
  }
  console.log(`${count} points, ${bad} differ (${path.basename(lazPath)} vs ${path.basename(lasPath)})`);
  process.exit(bad === 0 ? 0 : 1);
}
main().catch((e) => {
  console.log('error: ' + e);
  process.exit(1);
});
