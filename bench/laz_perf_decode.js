// laz-perf's single-thread decode rate, for dw_laz_bench (bench/dw_laz_bench.cpp):
//   node laz_perf_decode.js MODULE_DIR FILE.laz [REPEATS]
// Reads FILE.laz into the WASM heap, then decodes every point REPEATS times (default 3) with
// LASZip.getPoint, timing only the decode loop. Prints one line per pass and, last,
//   laz-perf best: N points in S s = R Mpoints/s cpu T s checksum C
// where T is the best pass's process CPU time and C sums the records' bytes (a decode that skipped work would change it). Exits 77 when
// laz-perf is not installed under MODULE_DIR.
'use strict';
const fs = require('fs');
const path = require('path');

async function main() {
  const [moduleDir, lazPath, repeatsArg] = process.argv.slice(2);
  const repeats = Math.max(1, parseInt(repeatsArg || '3', 10));
  let createLazPerf;
  try {
    createLazPerf = require(path.resolve(moduleDir, 'node_modules', 'laz-perf')).createLazPerf;
  } catch (e) {
    console.log('laz-perf is not installed under ' + moduleDir);
    process.exit(77);
  }
  const LazPerf = await createLazPerf();
  const laz = fs.readFileSync(lazPath);
  const filePtr = LazPerf._malloc(laz.length);
  LazPerf.HEAPU8.set(laz, filePtr);
  let best = Infinity, bestCpu = Infinity, count = 0, checksum = 0;
  for (let pass = 0; pass < repeats; ++pass) {
    const reader = new LazPerf.LASZip();
    reader.open(filePtr, laz.length);
    count = reader.getCount();
    const length = reader.getPointLength();
    const pointPtr = LazPerf._malloc(length);
    let sum = 0;
    const c0 = process.cpuUsage();
    const t0 = process.hrtime.bigint();
    for (let i = 0; i < count; ++i) {
      reader.getPoint(pointPtr);
      sum = (sum + LazPerf.HEAPU8[pointPtr] + LazPerf.HEAPU8[pointPtr + 4] + LazPerf.HEAPU8[pointPtr + 8]) >>> 0;
    }
    const seconds = Number(process.hrtime.bigint() - t0) / 1e9;
    const c = process.cpuUsage(c0);
    bestCpu = Math.min(bestCpu, (c.user + c.system) / 1e6);
    reader.delete();
    LazPerf._free(pointPtr);
    console.log(`laz-perf pass ${pass + 1}: ${count} points in ${seconds.toFixed(3)} s`);
    best = Math.min(best, seconds);
    checksum = sum;
  }
  LazPerf._free(filePtr);
  console.log(`laz-perf best: ${count} points in ${best.toFixed(4)} s = ${(count / best / 1e6).toFixed(3)} Mpoints/s ` +
              `cpu ${bestCpu.toFixed(4)} s checksum ${checksum}`);
}
main().catch((e) => {
  console.log('error: ' + e);
  process.exit(1);
});
