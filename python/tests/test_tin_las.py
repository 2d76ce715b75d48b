"""tin() against SciPy's Delaunay on points in general position; read_las() on real and corrupt files."""

import pathlib

import numpy as np
import pytest
from scipy.spatial import Delaunay

import pcl_delaunay_walk as dw
from conftest import SHARED


def canonical(tris):
    """Triangles as a set of rotation-normalised tuples (orientation kept)."""
    out = set()
    for t in np.asarray(tris).tolist():
        k = t.index(min(t))
        out.add(tuple(t[k:] + t[:k]))
    return out


def ccw(xy, tris):
    a, b, c = xy[tris[:, 0]], xy[tris[:, 1]], xy[tris[:, 2]]
    return (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0])


def test_tin_equals_scipy_delaunay():
    rng = np.random.default_rng(7)
    xyz = np.column_stack([rng.random((30000, 2)) * 100, rng.random(30000)])
    tris = dw.tin(xyz)
    assert tris.dtype == np.uint32 and tris.shape[1] == 3
    assert (ccw(xyz, tris.astype(np.int64)) > 0).all()
    ref = Delaunay(xyz[:, :2]).simplices
    ref = np.where((ccw(xyz, ref) > 0)[:, None], ref, ref[:, [0, 2, 1]])
    assert canonical(tris) == canonical(ref)


def test_tin_independent_of_threads_and_strips_and_layout():
    rng = np.random.default_rng(8)
    xy = rng.random((250000, 2)).astype(np.float32)
    a = dw.tin(xy, threads=1, strips=1)
    b = dw.tin(np.asfortranarray(xy), threads=2, strips=6)
    assert a.shape == b.shape and canonical(a) == canonical(b)  # the same triangles, listed in strip order


def test_tin_duplicates_nan_and_degenerate():
    pts = np.array([[0.0, 0], [1, 0], [0, 1], [1, 1], [1, 1], [np.nan, 0]])
    tris = dw.tin(pts)
    assert tris.shape == (2, 3) and 4 not in tris and 5 not in tris
    assert dw.tin(np.array([[0.0, 0], [1, 1], [2, 2]])).shape == (0, 3)
    with pytest.raises(ValueError):
        dw.tin(np.zeros((3, 4)))


def test_read_las_real_tile_and_tin():
    path = SHARED / "airborne" / "autzen_trim.las"
    if not path.exists():
        pytest.skip(f"{path} absent")
    cloud = dw.read_las(str(path))
    xyz = cloud["xyz"]
    assert xyz.shape == (cloud["point_count"], 3) and len(cloud["classification"]) == len(xyz)
    assert cloud["version"][0] == 1
    ground = dw.read_las(str(path), classification=2)["xyz"]
    assert len(ground) == int((cloud["classification"] == 2).sum())
    tris = dw.tin(xyz - xyz.mean(axis=0))
    assert len(tris) > len(xyz)  # a dense tile: about two triangles per distinct point


def test_laz_reads_as_its_las_twin():
    base = SHARED / "airborne" / "las_with_several_extra_byte_bloc"
    if not (base.with_suffix(".laz")).exists():
        pytest.skip("shared LAZ file absent")
    a = dw.read_las(str(base.with_suffix(".laz")))
    b = dw.read_las(str(base.with_suffix(".las")))
    assert len(a["xyz"]) == len(b["xyz"]) > 0
    np.testing.assert_array_equal(a["xyz"], b["xyz"])
    np.testing.assert_array_equal(a["classification"], b["classification"])


def test_corrupt_las_raises(tmp_path):
    bad = tmp_path / "bad.las"
    bad.write_bytes(b"LASF" + bytes(400))
    with pytest.raises(dw.LasError):
        dw.read_las(str(bad))
    with pytest.raises(dw.LasError):
        bad.write_bytes(b"junk")
        dw.read_las(str(bad))
    real = SHARED / "airborne" / "autzen_trim.las"
    if real.exists():
        cut = tmp_path / "cut.las"
        cut.write_bytes(real.read_bytes()[:5000])
        with pytest.raises(dw.LasError, match="cut.las"):
            dw.read_las(str(cut))
    laz = SHARED / "airborne" / "las_with_several_extra_byte_bloc.laz"
    if laz.exists():
        cut = tmp_path / "cut.laz"
        data = laz.read_bytes()
        cut.write_bytes(data[: len(data) // 2])
        with pytest.raises(dw.LasError):
            dw.read_las(str(cut))
    with pytest.raises(dw.Error):
        dw.read_las(str(tmp_path / "missing.las"))
