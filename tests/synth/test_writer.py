"""`generate` / `voxelmocap synth`: HumanEva layout, sync, ground truth on person pixels, bad input."""

from __future__ import annotations

import filecmp
from pathlib import Path

import cv2
import numpy as np
import pytest

from voxelmocap.cli import main
from voxelmocap.errors import InputError
from voxelmocap.io.body_file import read_body_file
from voxelmocap.io.calibration import read_rig
from voxelmocap.io.humaneva import Dataset, read_ofs, sync_starts
from voxelmocap.io.toml import read_toml
from voxelmocap.joints import endpoints_to_landmarks
from voxelmocap.synth import default_rig_path, generate
from voxelmocap.synth.writer import MIN_LEAD

REPO = Path(__file__).resolve().parents[2]
MOCAP = REPO / ".." / "shared" / "mocap"
N = 8


@pytest.fixture(scope="module")
def walk(tmp_path_factory):
    root = tmp_path_factory.mktemp("synth") / "data"
    generate(root, motion="walk", frames=N, subject="S2", seed=3, codec="FFV1",
             render_masks=True, background_frames=6, progress=False)
    return root


def test_layout_reads_back_through_the_humaneva_reader(walk):
    ds = Dataset(walk)
    assert ds.subjects == ["S2"] and ds.sequences("S2") == ["Walking_1"]
    seq = ds.sequence("S2", "Walking_1")
    assert seq.camera_names == ["C1", "C2", "C3", "BW1", "BW2", "BW3", "BW4"]
    assert seq.n_frames == N
    gt = seq.ground_truth()
    assert list(gt.frames) == list(range(1, N + 1))
    assert gt.endpoints.shape == (N, 20, 3) and gt.enabled.all()
    assert gt.attributes["SubjectName"] == "S2" and gt.attributes["ActionType"] == "Walking"
    for cam in seq.camera_names:
        assert len(seq.background_paths(cam)) == 1
    body = read_toml(seq.body_file)
    assert body["format"] == "voxelmocap-body-1" and body["subject"]["name"] == "S2"
    read_body_file(seq.body_file)  # the tracker's reader accepts it
    # the body file's lengths are those of the ground truth
    e = gt.endpoints
    thigh = np.linalg.norm(e[:, 10] - e[:, 11], axis=1).mean()
    assert body["lengths_mm"]["thigh"][0] == pytest.approx(thigh, abs=0.1)
    torso = np.linalg.norm(e[:, 0] - e[:, 1], axis=1).mean()
    assert body["lengths_mm"]["torso"] == pytest.approx(torso, abs=0.1)
    # feet on the floor, subject inside the capture area
    assert 0 < e[..., 2].min() < 150
    assert np.all(np.abs(e[:, 1, :2]) < [1500, 1000])


def test_sync_offsets_differ_per_camera_and_map_back(walk):
    sdir = walk / "S2"
    ofs = {}
    counts = {}
    for cam in ["C1", "C2", "C3", "BW1", "BW2", "BW3", "BW4"]:
        ofs[cam] = read_ofs(sdir / "Sync_Data" / f"Walking_1_({cam}).ofs")
        cap = cv2.VideoCapture(str(sdir / "Image_Data" / f"Walking_1_({cam}).avi"))
        n = 0
        while cap.read()[0]:
            n += 1
        counts[cam] = n
    starts, _, _ = sync_starts(ofs)
    leads = {cam: int(ofs[cam][0]) - 1 for cam in ofs}
    assert len(set(leads.values())) == len(leads) and min(leads.values()) >= MIN_LEAD
    assert starts == {cam: leads[cam] + 1 for cam in ofs}
    # each video holds exactly its lead plus the N synchronised frames
    assert counts == {cam: leads[cam] + N for cam in ofs}


def test_ground_truth_projects_onto_person_pixels_that_differ_from_the_background(walk):
    seq = Dataset(walk).sequence("S2", "Walking_1")
    gt = seq.ground_truth()
    marks = endpoints_to_landmarks(gt.endpoints)  # (N, 15, 3)
    differs, total = 0, 0
    bgs = {cam: np.mean([f.astype(float) for f in seq.background_frames(cam)], axis=0)
           for cam in seq.camera_names}
    for F, images in seq.frames(frames=range(1, N + 1)):
        for cam in seq.camera_names:
            mask = cv2.imread(str(walk / "S2" / "Mask_Data" / f"Walking_1_({cam})" / f"{F:05d}.png"),
                              cv2.IMREAD_GRAYSCALE) > 0
            img, bg = images[cam].astype(float), bgs[cam]
            uv = np.round(seq.rig[cam].project(marks[F - 1])).astype(int)
            for u, v in uv:
                assert mask[v, u], (cam, F, u, v)
                diff = np.abs(img[v - 1:v + 2, u - 1:u + 2] - bg[v - 1:v + 2, u - 1:u + 2]).mean()
                differs += diff > 6.0  # 3 σ of the sensor noise
                total += 1
            # away from the person (outside the dilated mask) the frame is the background
            far = ~cv2.dilate(mask.astype(np.uint8), np.ones((25, 25), np.uint8)).astype(bool)
            assert np.abs(img - bg)[far].mean() < 4.0
    # a body colour may match the background at a few pixels by chance
    assert differs / total > 0.9


def test_same_seed_gives_identical_files_and_another_seed_does_not(tmp_path):
    kw = dict(motion="box", frames=3, cameras=["C2", "BW3"], background_frames=3,
              progress=False)
    a = generate(tmp_path / "a", seed=7, **kw)
    b = generate(tmp_path / "b", seed=7, **kw)
    c = generate(tmp_path / "c", seed=8, **kw)
    files = sorted(p.relative_to(a) for p in a.rglob("*") if p.is_file())
    assert len(files) == 3 + 2 + 2 + 2 + 2  # cal×2 + sizes, avi×2, ofs×2, bg×2, xml + toml
    for rel in files:
        assert filecmp.cmp(a / rel, b / rel, shallow=False), rel
    video = Path("S1") / "Image_Data" / "Box_1_(C2).avi"
    assert not filecmp.cmp(a / video, c / video, shallow=False)
    # the default codec (MJPG) reads back with exactly the frames written
    lead = int(read_ofs(a / "S1" / "Sync_Data" / "Box_1_(C2).ofs")[0]) - 1
    cap = cv2.VideoCapture(str(a / video))
    n = 0
    while cap.read()[0]:
        n += 1
    assert n == lead + 3 == int(cap.get(cv2.CAP_PROP_FRAME_COUNT))


def test_packaged_rig_is_the_calib_folder():
    src = REPO / "calib" / "humaneva_i_like"
    pkg = default_rig_path()
    names = sorted(p.name for p in src.iterdir())
    assert names == sorted(p.name for p in pkg.iterdir())
    for name in names:
        assert (src / name).read_bytes() == (pkg / name).read_bytes(), name
    assert read_rig(pkg).names == ["C1", "C2", "C3", "BW1", "BW2", "BW3", "BW4"]


def _nothing_written(out: Path) -> bool:
    return not out.exists() or not any(out.rglob("*"))


def _bad_bvh(tmp_path):
    path = tmp_path / "bad.bvh"
    path.write_text("HIERARCHY\nROOT a\n{\n OFFSET 0 0 0\n CHANNELS 3 Xposition Yposition "
                    "Zposition\n}\nMOTION\nFrames: 2\nFrame Time: 0.01\n1 2 3\n1 2\n")
    return path


@pytest.mark.parametrize("case", ["motion", "bvh", "rig", "frames", "cameras", "action"])
def test_bad_input_is_one_input_error_and_writes_nothing(tmp_path, case):
    out = tmp_path / "out"
    kw = dict(frames=2, cameras=["C1"], progress=False)
    if case == "motion":
        kw["motion"] = "moonwalk"
        match = "unknown motion"
    elif case == "bvh":
        kw["motion"] = str(_bad_bvh(tmp_path))
        match = "values, the hierarchy declares"
    elif case == "rig":
        (tmp_path / "empty").mkdir()
        kw["rig"] = tmp_path / "empty"
        match = "no .cal camera files"
    elif case == "frames":
        kw["frames"] = 0
        match = "--frames"
    elif case == "cameras":
        kw["cameras"] = ["C9"]
        match = "unknown camera"
    else:
        kw["action"] = "Walk_ing"
        match = "--action"
    with pytest.raises(InputError, match=match):
        generate(out, **kw)
    assert _nothing_written(out)


def test_clip_too_short_for_the_frames(tmp_path):
    path = MOCAP / "02_03.bvh"
    if not path.exists():
        pytest.skip("real motion-capture clips not available (the CMU / Bandai Namco BVH files the "
                    "project develops with, expected in ../shared/mocap beside the checkout; "
                    "not shipped)")
    with pytest.raises(InputError, match="supplies at most"):
        generate(tmp_path / "out", motion=str(path), frames=1000, cameras=["C1"], progress=False)
    assert _nothing_written(tmp_path / "out")


def test_failure_while_rendering_leaves_nothing_half_written(tmp_path, monkeypatch):
    from voxelmocap.synth import render

    calls = {"n": 0}
    original = render.Renderer.render

    def flaky(self, *args, **kwargs):
        calls["n"] += 1
        if calls["n"] > 4:
            raise RuntimeError("disk full")
        return original(self, *args, **kwargs)

    monkeypatch.setattr(render.Renderer, "render", flaky)
    out = tmp_path / "out"
    with pytest.raises(RuntimeError, match="disk full"):
        generate(out, frames=3, cameras=["C1"], progress=False)
    assert not out.exists()


def test_command_exit_codes(tmp_path, capsys):
    out = tmp_path / "cmd"
    assert main(["synth", str(out), "--motion", "nope", "--no-progress"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "unknown motion" in err[0]
    assert main(["synth", str(out), "--frames", "2", "--cameras", "BW2", "--no-progress"]) == 0
    assert (out / "S1" / "Image_Data" / "Walking_1_(BW2).avi").exists()
    # an existing sequence is kept unless --overwrite
    assert main(["synth", str(out), "--frames", "2", "--cameras", "BW2", "--no-progress"]) == 2
    assert "exists already" in capsys.readouterr().err
    assert main(["synth", str(out), "--frames", "2", "--cameras", "C1", "--no-progress",
                 "--overwrite"]) == 0
    # the replaced sequence has no stale camera left
    assert sorted(p.name for p in (out / "S1" / "Image_Data").iterdir()) == ["Walking_1_(C1).avi"]


def test_bvh_clip_renders_with_its_truth_on_the_person(tmp_path):
    path = MOCAP / "dataset-1_punch_normal_002.bvh"
    if not path.exists():
        pytest.skip("real motion-capture clips not available (the CMU / Bandai Namco BVH files the "
                    "project develops with, expected in ../shared/mocap beside the checkout; "
                    "not shipped)")
    root = generate(tmp_path / "d", motion=str(path), frames=4, cameras=["C1", "BW2"],
                    action="Box", codec="FFV1", render_masks=True, background_frames=3,
                    progress=False)
    seq = Dataset(root).sequence("S1", "Box_1")
    gt = seq.ground_truth()
    marks = endpoints_to_landmarks(gt.endpoints)
    for cam in ["C1", "BW2"]:
        for F in range(1, 5):
            mask = cv2.imread(str(root / "S1" / "Mask_Data" / f"Box_1_({cam})" / f"{F:05d}.png"),
                              cv2.IMREAD_GRAYSCALE) > 0
            uv = np.round(seq.rig[cam].project(marks[F - 1])).astype(int)
            assert all(mask[v, u] for u, v in uv)


def test_one_body_per_subject(tmp_path):
    kw = dict(frames=2, cameras=["C1"], background_frames=2, progress=False)
    root = generate(tmp_path / "d", motion="walk", subject="S3", seed=1, **kw)
    first = read_toml(root / "S3" / "Mocap_Data" / "S3_body.toml")
    generate(root, motion="jog", subject="S3", seed=9, **kw)  # same subject, other motion/seed
    second = read_toml(root / "S3" / "Mocap_Data" / "S3_body.toml")
    assert second["subject"] == first["subject"] and second["widths_mm"] == first["widths_mm"]
    for key in ("upper_arm", "forearm", "thigh", "shin"):  # rigid bones: identical
        assert second["lengths_mm"][key] == first["lengths_mm"][key]
    for key, value in first["lengths_mm"].items():  # the rest: means over frames, ~equal
        np.testing.assert_allclose(second["lengths_mm"][key], value, atol=2.0)
    path = MOCAP / "dataset-1_punch_normal_002.bvh"
    if path.exists():  # a clip of another person cannot join S3
        with pytest.raises(InputError, match="another body"):
            generate(root, motion=str(path), subject="S3", action="Box", **kw)
        assert not (root / "S3" / "Image_Data" / "Box_1_(C1).avi").exists()
