import cv2
import numpy as np

from voxelmocap.camera import Camera
from voxelmocap.viz.overlay import cone_outline_points, draw_landmarks


def front_camera():
    # camera 4 m in front of the origin (at −Y), looking along +Y, image y down = world −Z
    R = np.array([[1.0, 0, 0], [0, 0, -1.0], [0, 1.0, 0]])
    return Camera("T", fc=(500, 500), cc=(320, 240), R=R, T=-R @ np.array([0, -4000.0, 1000.0]))


def test_cone_outline_lies_on_the_cone():
    base, axis = np.array([10.0, 20.0, 30.0]), np.array([0, 0, 1.0])
    u1, u2 = np.array([1.0, 0, 0]), np.array([0, 1.0, 0])
    lines = cone_outline_points(base, axis, u1, u2, H=50, W=30, L=200, R=0.5)
    base_ring, top_ring = lines[0], lines[1]
    d = base_ring - base
    np.testing.assert_allclose((d[:, 0] / 50) ** 2 + (d[:, 1] / 30) ** 2, 1.0)
    d = top_ring - (base + 200 * axis)
    np.testing.assert_allclose((d[:, 0] / 25) ** 2 + (d[:, 1] / 15) ** 2, 1.0)
    assert len(lines) == 6


def test_landmarks_land_on_their_projection():
    cam = front_camera()
    rng = np.random.default_rng(0)
    lm = rng.uniform([-400, -200, 200], [400, 200, 1700], size=(15, 3))
    image = np.zeros((480, 640, 3), np.uint8)
    draw_landmarks(image, cam, lm, (0, 0, 255), skeleton=False)
    pix = np.round(cam.project(lm)).astype(int)
    assert np.all(image[pix[:, 1], pix[:, 0], 2] == 255)
    assert image[..., 2].astype(bool).sum() < 15 * 80  # only small (anti-aliased) dots


def test_overlay_frame_draws_cones_truth_and_landmarks_on_a_copy():
    from voxelmocap.body import BodyModel
    from voxelmocap.viz.overlay import TRACKED_COLOUR, TRUTH_COLOUR, overlay_frame

    cam = front_camera()
    model = BodyModel()
    state = model.default_state()
    lm = model.landmarks(state[None])[0]
    gray = np.full((480, 640), 50, np.uint8)
    out = overlay_frame(gray, cam, model, state, lm, truth=lm + [150.0, 0, 0], caption="F=3")
    assert out.shape == (480, 640, 3) and out.dtype == np.uint8 and np.all(gray == 50)
    pix = np.round(cam.project(lm)).astype(int)
    assert np.all(out[pix[:, 1], pix[:, 0]] == TRACKED_COLOUR)
    tpix = np.round(cam.project(lm + [150.0, 0, 0])).astype(int)
    on_truth = (out[tpix[:, 1], tpix[:, 0]] == TRUTH_COLOUR).all(axis=1)
    assert on_truth.sum() >= 10  # the truth's dots, except where a tracked dot covers one
    changed = np.any(out != 50, axis=2)
    assert changed[:30, :80].any()  # the caption
    assert changed.sum() > 2000  # the cone outlines


def _tracked_run(root):
    """A tiny data set and a run folder whose result puts a standing body in front of C1."""
    from humaneva_fixture import make_tiny_dataset

    from voxelmocap.io.humaneva import Dataset
    from voxelmocap.io.results import TrackResult, write_result
    from voxelmocap.run.bodies import body_model_for

    data = make_tiny_dataset(root / "data", n_frames=5)
    seq = Dataset(data).sequence("S1", "Walking_1")
    model, _ = body_model_for(seq, seq.ground_truth())
    frames = np.array([2, 3, 4])
    state = np.repeat(model.default_state()[None], 3, axis=0)
    state[:, 0] = [-200.0, 0.0, 200.0]
    n = len(frames)
    result = TrackResult(
        frames=frames, state=state, landmarks=model.landmarks(state),
        endpoints=model.endpoints(state), part_scores=np.zeros((n, len(model.parts), 4)),
        ess=np.ones((n, 1)), betas=np.ones((n, 1)), seconds=np.ones(n),
        log_likelihood=np.zeros(n), map_state=state, state_names=list(model.state_names),
        part_names=[p.name for p in model.parts], attrs={"complete": True}, checkpoint=None)
    write_result(root / "run" / "S1" / "Walking_1.h5", result)
    return data, root / "run", seq.rig["C1"], result


def test_overlay_command_writes_the_video(tmp_path, capsys):
    from voxelmocap.cli import main

    data, run, cam, result = _tracked_run(tmp_path)
    out = tmp_path / "videos" / "c1.avi"
    assert main(["overlay", str(run), "--dataset", str(data), "--out", str(out),
                 "--fps", "12"]) == 0
    assert f"overlay: {out}" in capsys.readouterr().out
    assert [p.name for p in out.parent.iterdir()] == ["c1.avi"]
    cap = cv2.VideoCapture(str(out))
    assert abs(cap.get(cv2.CAP_PROP_FPS) - 12.0) < 1e-6
    decoded = []
    while True:
        ok, img = cap.read()
        if not ok:
            break
        decoded.append(img)
    cap.release()
    assert len(decoded) == 3
    for img, lm in zip(decoded, result.landmarks, strict=True):
        pix = np.round(cam.project(lm)).astype(int)
        inside = (pix[:, 0] >= 3) & (pix[:, 0] < 637) & (pix[:, 1] >= 3) & (pix[:, 1] < 477)
        assert inside.sum() >= 10
        _, g, r = img[pix[inside, 1], pix[inside, 0]].astype(int).T
        # red dots (through JPEG) where the tracked landmarks project
        assert np.median(r) > 150 and np.median(r - g) > 80


def _listing(folder):
    return sorted(str(p.relative_to(folder)) for p in folder.rglob("*"))


def test_overlay_refusals_are_one_line_and_leave_nothing(tmp_path, capsys, monkeypatch):
    from voxelmocap.cli import main

    data, run, _, _ = _tracked_run(tmp_path)
    (tmp_path / "plain").write_text("x")
    before = _listing(tmp_path)

    def fails(extra, message):
        assert main(["overlay", str(run), "--dataset", str(data), *extra]) == 2
        err = capsys.readouterr().err.strip()
        assert len(err.splitlines()) == 1 and message in err, err
        assert _listing(tmp_path) == before

    fails(["--out", str(tmp_path / "x.gif")], "not a video file name")
    fails(["--out", str(tmp_path / "x.png")], "not a video file name")
    fails(["--out", str(tmp_path / "x.mp4"), "--fps", "0"], "frame rate must be a positive")
    fails(["--out", str(tmp_path / "plain" / "x.mp4")], "plain: exists and is not a folder")
    fails(["--out", str(tmp_path / ("n" * 300 + ".mp4"))], "cannot write here")
    # a failure half way through the frames leaves neither the video nor its temporary
    import voxelmocap.viz.overlay as overlay
    from voxelmocap.errors import InputError

    calls = {"n": 0}
    real = overlay.overlay_frame

    def breaks(*args, **kwargs):
        calls["n"] += 1
        if calls["n"] == 2:
            raise InputError("frame 3", "cannot decode")
        return real(*args, **kwargs)

    monkeypatch.setattr(overlay, "overlay_frame", breaks)
    fails(["--out", str(tmp_path / "x.mp4"), "--no-progress"], "cannot decode")
    assert calls["n"] == 2


def test_mosaic_has_one_panel_per_camera_in_order():
    from voxelmocap.viz.overlay import mosaic

    colours = [(255, 0, 0), (0, 255, 0), (0, 0, 255), (255, 255, 0), (0, 255, 255)]
    sizes = [(60, 40), (60, 40), (64, 48), (40, 80), (60, 40)]       # (W, H), mixed
    panels = [np.full((h, w, 3), c, np.uint8) for (w, h), c in zip(sizes, colours, strict=True)]
    out = mosaic(panels, max_width=10_000)
    h0 = 40                                                      # the smallest height
    w0 = max(round(w * h0 / h) for w, h in sizes)
    n_cols = out.shape[1] // w0
    assert out.shape[0] % 2 == 0 and out.shape[1] % 2 == 0
    assert n_cols * (-(-len(panels) // n_cols)) >= len(panels)
    for i, c in enumerate(colours):
        r, col = divmod(i, n_cols)
        centre = out[r * h0 + h0 // 2, col * w0 + 5]
        np.testing.assert_array_equal(centre, c)
    # shrunk to the width limit, even sides
    small = mosaic(panels, max_width=101)
    assert small.shape[1] <= 101 and small.shape[1] % 2 == 0 and small.shape[0] % 2 == 0


def test_overlay_all_cameras_draws_the_landmarks_in_every_panel(tmp_path, capsys):
    from voxelmocap.cli import main

    data, run, _, _ = _tracked_run(tmp_path)
    out = tmp_path / "all.avi"
    assert main(["overlay", str(run), "--dataset", str(data), "--camera", "all", "--out",
                 str(out), "--fps", "12"]) == 0
    assert f"overlay: {out}" in capsys.readouterr().out
    cap = cv2.VideoCapture(str(out))
    ok, img = cap.read()
    cap.release()
    assert ok
    from voxelmocap.io.humaneva import Dataset

    rig = Dataset(data).sequence("S1", "Walking_1").rig
    n = len(rig)
    w, h = rig[0].size
    red = (img[:, :, 2].astype(int) > 150) & (img[:, :, 2].astype(int) - img[:, :, 1] > 80)
    # every camera's panel has red landmark dots: split the image into its grid of panels
    from voxelmocap.viz.overlay import mosaic

    probe = mosaic([np.full((h, w, 3), i + 1, np.uint8) for i in range(n)], max_width=10_000)
    probe = cv2.resize(probe, (img.shape[1], img.shape[0]), interpolation=cv2.INTER_NEAREST)
    for i in range(n):
        assert red[probe[:, :, 0] == i + 1].sum() >= 5, f"no landmark drawn in panel {i + 1}"
