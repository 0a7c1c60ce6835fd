"""HDF5 voxel dumps (round trip, atomicity, damaged files) and PLY export."""

from __future__ import annotations

import numpy as np
import pytest

from voxelmocap.camera import Camera
from voxelmocap.errors import InputError
from voxelmocap.grid import VoxelGrid
from voxelmocap.io.voxels import VoxelDump, VoxelDumpWriter, write_ply
from voxelmocap.measure.surface import smooth_surface, surface_voxels

GRID = VoxelGrid(origin=(-200.0, -100.0, 0.0), voxel_size=20.0, shape=(12, 10, 14))


def _cameras():
    return [Camera("C1", fc=(500, 510), cc=(15.5, 11.0), R=np.eye(3), T=(0, 0, 4000),
                   kc=(-0.1, 0.01, 1e-4, -2e-4, 0.0), size=(32, 24)),
            Camera("BW1", fc=(480, 480), cc=(16.0, 12.0), R=np.diag([1.0, -1.0, -1.0]),
                   T=(10, 20, 3000), alpha_c=0.001, size=(32, 24))]


def _frames(rng, n):
    out = []
    for _ in range(n):
        occ = rng.random(GRID.shape) < 0.2
        surf = surface_voxels(occ)
        out.append((occ, surf, smooth_surface(surf, 1.0), rng.random((2, 24, 32)) < 0.5))
    return out


def test_round_trip(tmp_path):
    rng = np.random.default_rng(0)
    data = _frames(rng, 3)
    numbers = [6, 7, 9]
    path = tmp_path / "vox.h5"
    with VoxelDumpWriter(path, GRID, cameras=_cameras(),
                         attrs={"subject": "S1", "config": {"min_views": 6}}) as out:
        for fr, (occ, surf, smooth, masks) in zip(numbers, data, strict=True):
            out.write(fr, occ, surface=surf, smoothed=smooth, masks=masks)
        assert not path.exists()  # only the temporary exists while writing
    assert path.exists() and not list(tmp_path.glob(".*partial*"))
    with VoxelDump(path) as dump:
        assert dump.grid == GRID
        assert dump.frames.tolist() == numbers
        assert dump.camera_names == ["C1", "BW1"]
        assert dump.attrs["subject"] == "S1"
        for fr, (occ, surf, smooth, masks) in zip(numbers, data, strict=True):
            assert np.array_equal(dump.occupancy(fr), occ)
            assert np.array_equal(dump.surface(fr), surf)
            np.testing.assert_array_equal(dump.smoothed(fr), smooth)
            assert np.array_equal(dump.masks(fr), masks)
        cams = dump.cameras()
        for a, b in zip(cams, _cameras(), strict=True):
            assert a.name == b.name and a.size == b.size and a.alpha_c == b.alpha_c
            for key in ("fc", "cc", "kc", "R", "T"):
                np.testing.assert_array_equal(getattr(a, key), getattr(b, key))
        with pytest.raises(InputError, match=r"frame 8 is not in vox\.h5"):
            dump.occupancy(8)


def test_masks_of_cameras_of_different_sizes(tmp_path):
    # a rig whose cameras differ in size (the Pose2Sim demo's cam04 is 1088 wide, the others
    # 1080): each camera's silhouettes come back at its own size, exactly as written
    rng = np.random.default_rng(3)
    small, large = _cameras()
    large = Camera(large.name, fc=large.fc, cc=large.cc, R=large.R, T=large.T, size=(36, 20))
    path = tmp_path / "sizes.h5"
    written = {}
    with VoxelDumpWriter(path, GRID, cameras=[small, large]) as out:
        for fr in (1, 2):
            masks = [rng.random((24, 32)) < 0.5, rng.random((20, 36)) < 0.5]
            out.write(fr, rng.random(GRID.shape) < 0.2, masks=masks)
            written[fr] = masks
        with pytest.raises(InputError, match="differ from earlier frames"):
            out.write(3, np.zeros(GRID.shape, bool),
                      masks=[np.zeros((24, 32), bool), np.zeros((24, 36), bool)])
        with pytest.raises(InputError, match=r"expected 2 \(H, W\) masks"):
            out.write(3, np.zeros(GRID.shape, bool), masks=[np.zeros((24, 32), bool)])
    with VoxelDump(path) as dump:
        for fr, masks in written.items():
            got = dump.masks(fr)
            assert [m.shape for m in got] == [(24, 32), (20, 36)]
            for a, b in zip(got, masks, strict=True):
                assert a.dtype == bool and np.array_equal(a, b)


def test_occupancy_only_and_consistency(tmp_path):
    path = tmp_path / "occ.h5"
    occ = np.zeros(GRID.shape, bool)
    occ[3, 4, 5] = True
    with VoxelDumpWriter(path, GRID) as out:
        out.write(1, occ)
        with pytest.raises(InputError, match="same volumes"):
            out.write(2, occ, surface=occ)
        with pytest.raises(InputError, match="does not match the grid"):
            out.write(2, occ[:-1])
    with VoxelDump(path) as dump:
        assert dump.has("occupancy") and not dump.has("masks") and not dump.has("surface")
        assert dump.cameras() == []
        with pytest.raises(InputError, match="holds no 'masks'"):
            dump.masks(1)


def test_failed_write_leaves_nothing(tmp_path):
    path = tmp_path / "bad.h5"
    with pytest.raises(RuntimeError), VoxelDumpWriter(path, GRID) as out:
        out.write(1, np.zeros(GRID.shape, bool))
        raise RuntimeError("interrupted")
    assert list(tmp_path.iterdir()) == []


def test_damaged_files(tmp_path):
    import h5py

    with pytest.raises(InputError, match="not found"):
        VoxelDump(tmp_path / "missing.h5")
    junk = tmp_path / "junk.h5"
    junk.write_bytes(b"this is not HDF5" * 100)
    with pytest.raises(InputError, match="not a readable HDF5"):
        VoxelDump(junk)
    other = tmp_path / "other.h5"
    with h5py.File(other, "w") as f:
        f["x"] = np.arange(3)
    with pytest.raises(InputError, match="not a voxelmocap voxel dump"):
        VoxelDump(other)
    # a real dump cut in half
    good = tmp_path / "good.h5"
    rng = np.random.default_rng(1)
    with VoxelDumpWriter(good, GRID) as out:
        for i, (occ, surf, smooth, _) in enumerate(_frames(rng, 4)):
            out.write(i + 1, occ, surface=surf, smoothed=smooth)
    cut = tmp_path / "cut.h5"
    cut.write_bytes(good.read_bytes()[: good.stat().st_size // 2])
    with pytest.raises(InputError, match=r"cut\.h5"):
        with VoxelDump(cut) as dump:
            for fr in dump.frames:
                dump.smoothed(fr)
    # inconsistent shapes
    bad = tmp_path / "shape.h5"
    good_bytes = good.read_bytes()
    bad.write_bytes(good_bytes)
    with h5py.File(bad, "a") as f:
        f.attrs["grid_shape"] = np.array([5, 5, 5])
    with pytest.raises(InputError, match="expected"):
        VoxelDump(bad)


def test_ply_voxels_and_points(tmp_path):
    import open3d as o3d

    occ = np.zeros(GRID.shape, bool)
    cells = [(0, 0, 0), (3, 4, 5), (11, 9, 13)]
    for c in cells:
        occ[c] = True
    n = write_ply(tmp_path / "v.ply", GRID, occ)
    assert n == 3
    vg = o3d.io.read_voxel_grid(str(tmp_path / "v.ply"))
    assert vg.voxel_size == GRID.voxel_size
    np.testing.assert_allclose(vg.origin, GRID.low)
    assert sorted(tuple(int(i) for i in v.grid_index) for v in vg.get_voxels()) == sorted(cells)
    write_ply(tmp_path / "p.ply", GRID, occ, values=occ.astype(float), points=True)
    pc = o3d.io.read_point_cloud(str(tmp_path / "p.ply"))
    got = np.asarray(pc.points)
    np.testing.assert_allclose(got[np.lexsort(got.T[::-1])],
                               GRID.centre_of(np.array(sorted(cells))))
    assert write_ply(tmp_path / "empty.ply", GRID, np.zeros(GRID.shape, bool), points=True) == 0
