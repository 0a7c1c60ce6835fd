"""``track --rerun``: the .rrd read back with the Rerun SDK holds every entity of every frame."""

from collections import defaultdict

import numpy as np
import pytest

rr = pytest.importorskip("rerun")
rrd = pytest.importorskip("rerun.chunk")

from voxelmocap.cli import main  # noqa: E402
from voxelmocap.config import TrackConfig, with_overrides  # noqa: E402
from voxelmocap.io.humaneva import Dataset  # noqa: E402
from voxelmocap.io.results import read_result  # noqa: E402
from voxelmocap.joints import LANDMARK_PARENTS  # noqa: E402
from voxelmocap.run.measurement import MeasurementRunner  # noqa: E402

CAMERAS = ["C1", "C2", "BW1"]
FRAMES = list(range(1, 11))


@pytest.fixture(scope="module")
def recorded(tmp_path_factory):
    """A 10-frame walk tracked with --rerun; the recording's rows by entity and frame."""
    from voxelmocap.synth import generate

    root = tmp_path_factory.mktemp("rerun")
    data = generate(root / "data", motion="walk", frames=10, cameras=CAMERAS, progress=False,
                    background_frames=10, seed=5)
    path = root / "out" / "walk.rrd"
    assert main(["track", str(data), "--subject", "S1", "--sequence", "Walking_1", "--out",
                 str(root / "run"), "--layers", "2", "--particles", "40", "--voxel-size", "40",
                 "--no-progress", "--rerun", str(path)]) == 0
    rows = defaultdict(dict)  # entity → {frame or "static": {column: value}}
    reader = rrd.RrdReader(path)
    (recording,) = reader.recordings()  # one recording, named after the sequence
    assert recording.recording_id == "S1/Walking_1"
    for chunk in reader.stream().to_chunks():
        batch = chunk.to_record_batch()
        columns = {n: batch.column(n).to_pylist() for n in batch.schema.names
                   if ":" in n}  # Archetype:component data columns
        frames = batch.column("frame").to_pylist() if "frame" in batch.schema.names else None
        for i in range(batch.num_rows):
            key = "static" if frames is None else frames[i]
            rows[chunk.entity_path].setdefault(key, {}).update(
                {n: values[i] for n, values in columns.items() if values[i] is not None})
    return data, root, path, rows


def test_every_frame_has_every_entity(recorded):
    _, _, path, rows = recorded
    assert sorted(p.name for p in path.parent.iterdir()) == ["walk.rrd"]  # no partial left
    per_frame = ["/world/voxels", "/world/skeleton", "/world/skeleton/landmarks",
                 "/world/particles/pelvis", "/world/particles/top"]
    for cam in CAMERAS:
        per_frame += [f"/world/cameras/{cam}/image", f"/world/cameras/{cam}/silhouette"]
        assert "Pinhole:image_from_camera" in rows[f"/world/cameras/{cam}"]["static"]
    for entity in per_frame:
        assert sorted(rows[entity]) == FRAMES, entity
    for frame in FRAMES:
        assert len(rows["/world/particles/pelvis"][frame]["Points3D:positions"]) == 40
        # 5 heaviest particles × 14 bones
        assert len(rows["/world/particles/top"][frame]["LineStrips3D:strips"]) == 5 * 14
        (blob,) = rows["/world/cameras/C1/image"][frame]["EncodedImage:blob"]
        assert len(blob) > 1000


def test_skeleton_is_the_result_files_landmarks(recorded):
    _, root, _, rows = recorded
    result = read_result(root / "run" / "S1" / "Walking_1.h5")
    assert list(result.frames) == FRAMES
    for frame, landmarks in zip(result.frames, result.landmarks, strict=True):
        points = np.array(rows["/world/skeleton/landmarks"][frame]["Points3D:positions"])
        np.testing.assert_allclose(points, landmarks, atol=1e-3)  # float32 in the file
        strips = np.array(rows["/world/skeleton"][frame]["LineStrips3D:strips"])  # (14, 2, 3)
        expected = [(landmarks[p], landmarks[c]) for c, p in enumerate(LANDMARK_PARENTS)
                    if p >= 0]
        np.testing.assert_allclose(strips, np.array(expected), atol=1e-3)


def test_voxels_silhouettes_and_images_are_the_measurement(recorded):
    import cv2

    data, _, _, rows = recorded
    config = with_overrides(TrackConfig(), **{"measurement.voxel_size": 40.0})
    seq = Dataset(data).sequence("S1", "Walking_1")
    runner = MeasurementRunner(seq, config)
    grid = runner.grid
    for frame, obs in runner.observations(FRAMES):
        ijk = np.argwhere(obs.occupancy)
        centres = np.asarray(grid.origin) + (ijk + 0.5) * grid.voxel_size  # DESIGN.md §2
        got = np.array(rows["/world/voxels"][frame]["Points3D:positions"])
        assert len(ijk) > 50
        np.testing.assert_allclose(got[np.lexsort(got.T)], centres[np.lexsort(centres.T)],
                                   atol=1e-3)
        for index, cam in enumerate(runner.names):
            row = rows[f"/world/cameras/{cam}/silhouette"][frame]
            (fmt,) = row["SegmentationImage:format"]
            (buffer,) = row["SegmentationImage:buffer"]
            mask = np.array(buffer, dtype=np.uint8).reshape(
                fmt["height"], fmt["width"])
            np.testing.assert_array_equal(mask == 1, obs.masks[index])
    for frame, images in seq.frames([1, 10]):
        for cam in CAMERAS:
            (blob,) = rows[f"/world/cameras/{cam}/image"][frame]["EncodedImage:blob"]
            decoded = cv2.imdecode(np.array(blob, dtype=np.uint8), cv2.IMREAD_UNCHANGED)
            # A JPEG holds colours, and OpenCV decodes them in its BGR order: the frame as
            # voxelmocap read it (BGR), if the recorder handed Rerun RGB as it expects
            truth = images[cam].astype(float)
            assert decoded.shape == truth.shape
            assert np.abs(decoded - truth).mean() < 4.0  # JPEG at quality 75
            if cam.startswith("C"):  # colour cameras: the swapped order is far off
                assert np.abs(decoded[..., ::-1] - truth).mean() > 8.0


def test_cameras_are_placed_as_the_calibration_projects(recorded):
    data, _, _, rows = recorded
    rig = Dataset(data).sequence("S1", "Walking_1").rig
    points = np.array([[0.0, 0.0, 0.0], [300.0, -200.0, 900.0], [-500.0, 400.0, 1700.0]])
    for camera in rig:
        static = rows[f"/world/cameras/{camera.name}"]["static"]
        k = np.array(static["Pinhole:image_from_camera"]).reshape(3, 3).T  # column-major
        m = np.array(static["Transform3D:mat3x3"]).reshape(3, 3).T
        t = np.array(static["Transform3D:translation"]).reshape(3)
        assert static["Pinhole:resolution"] == [list(camera.size)]
        # Rerun: world = M · camera + t, pixel corner at (0, 0)
        xc = (points - t) @ m  # = Mᵀ (p − t) for each row
        pixels = (xc @ k.T)[:, :2] / xc[:, 2:] - 0.5
        # the .cal model without distortion: Xc = R·X + T, u = fc · x/z + cc
        cam = points @ camera.R.T + camera.T
        expected = camera.fc * cam[:, :2] / cam[:, 2:] + camera.cc
        np.testing.assert_allclose(pixels, expected, atol=0.05)


def test_nothing_tracked_writes_no_recording(recorded, capsys):
    data, root, _, _ = recorded
    path = root / "again" / "walk.rrd"
    assert main(["track", str(data), "--subject", "S1", "--sequence", "Walking_1", "--out",
                 str(root / "run"), "--layers", "2", "--particles", "40", "--voxel-size", "40",
                 "--no-progress", "--resume", "--rerun", str(path)]) == 0
    assert f"warning: no recording written to {path}" in capsys.readouterr().out
    assert not path.parent.exists() or not any(path.parent.iterdir())
