"""The histogram kernel of ``masked_median`` against the sorting it replaced, bit for bit."""

from __future__ import annotations

import numpy as np
import pytest

from voxelmocap.measure.plate import masked_median


def sorted_reference(frames, keep=None, quartiles=False):
    """The NumPy implementation before the kernel: each pixel's kept samples sorted (uint16, the
    dropped ones as 512 after every real value), quantiles linearly interpolated."""
    f, h, w, c = frames.shape
    count = np.full((h, w), f, int) if keep is None else keep.sum(axis=0)
    block = frames.astype(np.uint16)
    if keep is not None:
        block[~keep] = 512
    block.sort(axis=0)

    def at(q):
        pos = np.clip((count - 1) * q, 0, None)
        lo = np.floor(pos).astype(int)
        hi = np.ceil(pos).astype(int)
        a = np.take_along_axis(block, lo[None, :, :, None].repeat(c, 3), 0)[0]
        b = np.take_along_axis(block, hi[None, :, :, None].repeat(c, 3), 0)[0]
        t = (pos - lo)[:, :, None]
        return a * (1 - t) + b * t

    m = at(0.5)
    m[count == 0] = 0
    med = m.astype(np.float32)
    if not quartiles:
        return med, count
    s = np.sqrt((((at(0.75) - at(0.25)) / 1.349) ** 2).mean(axis=2))
    s[count < 4] = 0
    return med, count, s.astype(np.float32)


@pytest.mark.parametrize("channels", [1, 3])
@pytest.mark.parametrize("n_frames", [1, 2, 3, 4, 5, 13, 60])
def test_the_kernel_equals_the_sorting_bit_for_bit(channels, n_frames):
    rng = np.random.default_rng(100 + 7 * n_frames + channels)
    h, w = 9, 11
    # three kinds of pixel: uniform noise, a few grey levels (ties everywhere), the extremes
    frames = rng.integers(0, 256, size=(n_frames, h, w, channels), dtype=np.uint8)
    frames[:, :3] = rng.choice(np.array([0, 1, 17, 254], np.uint8), (n_frames, 3, w, channels))
    frames[:, 3, :4] = 255
    frames[:, 3, 4:8] = 0
    keep = rng.random((n_frames, h, w)) < 0.7
    keep[:, 0, 0] = False                               # never kept
    keep[:, 0, 1] = False
    keep[:1, 0, 1] = True                               # one sample
    keep[:, 0, 2] = False
    keep[:3, 0, 2] = True                               # three: no σ
    keep[:, 0, 3] = True                                # all
    for k in (None, keep):
        for quartiles in (False, True):
            got = masked_median(frames, k, quartiles=quartiles)
            want = sorted_reference(frames, k, quartiles)
            assert len(got) == len(want)
            for g, r in zip(got, want, strict=True):
                assert g.shape == r.shape
                assert np.asarray(g, float).tobytes() == np.asarray(r, float).tobytes()


def test_a_camera_sized_plate_equals_the_sorting():
    """Many pixels of realistic statistics: a background with noise, a person covering a band
    of the frames (the kept samples vary from pixel to pixel)."""
    rng = np.random.default_rng(5)
    f, h, w = 24, 40, 64
    plate = rng.integers(20, 230, size=(h, w, 3))
    frames = np.clip(plate + rng.normal(0, 3, (f, h, w, 3)), 0, 255).astype(np.uint8)
    keep = np.ones((f, h, w), bool)
    for k in range(f):
        x0 = (2 * k) % (w - 10)
        frames[k, :, x0:x0 + 10] = rng.integers(0, 256, (h, 10, 3))
        keep[k, :, x0:x0 + 10] = False
    got = masked_median(frames, keep, quartiles=True)
    want = sorted_reference(frames, keep, True)
    for g, r in zip(got, want, strict=True):
        assert np.asarray(g, float).tobytes() == np.asarray(r, float).tobytes()
    assert np.abs(got[0] - plate).max() < 10       # and it is the background


def test_frames_that_are_not_uint8_or_a_keep_of_another_shape_are_refused():
    from voxelmocap.errors import InputError

    frames = np.zeros((3, 4, 5, 3), np.uint8)
    with pytest.raises(InputError, match="uint8"):
        masked_median(frames.astype(np.float32))
    with pytest.raises(InputError, match="keep mask"):
        masked_median(frames, np.ones((3, 4, 4), bool))


def _scene(rng, h=48, w=64, channels=3):
    """A textured plate, a frame with a bright person, a cast shadow, a black patch (α = 0:
    no light at all) and noise, and a never-seen band."""
    plate = rng.integers(30, 220, size=(h, w, channels)).astype(np.float32)
    frame = np.clip(plate + rng.normal(0, 4, plate.shape), 0, 255)
    frame[10:40, 20:30] = rng.integers(0, 256, (30, 10, channels))     # the person
    frame[30:46, 30:50] = plate[30:46, 30:50] * 0.6                     # a shadow beside
    frame[2:6, 2:6] = 0                                                 # black
    plate[40:44, 50:54] = 0                                             # a black plate patch
    known = np.ones((h, w), bool)
    known[:, 60:] = False
    return plate, np.round(frame).astype(np.uint8), known


@pytest.mark.parametrize("channels", [1, 3])
@pytest.mark.parametrize("shadows", [False, True])
def test_the_foreground_kernel_equals_numpy_bit_for_bit(channels, shadows):
    from voxelmocap.measure.plate import PlateBackground

    rng = np.random.default_rng(40 + channels + 2 * shadows)
    for trial in range(4):
        plate, frame, known = _scene(rng, channels=channels)
        sigma = rng.uniform(1.0, 6.0, plate.shape[:2])
        bg = PlateBackground(plate, sigma, known, false_alarm=10.0 ** -rng.uniform(2, 6),
                             shadows=shadows, shadow_brightness=(0.4, 0.95))
        if trial == 3:
            frame = np.clip(frame * 1.1, 0, 255).astype(np.uint8)     # an exposure step
        image = frame[:, :, 0] if channels == 1 else frame
        fast = bg.foreground(image)
        slow = bg._foreground_numpy(image)
        assert fast.dtype == bool and fast.shape == slow.shape
        assert (fast == slow).all(), np.argwhere(fast != slow)[:5]
        assert fast[~known].all()
        if channels == 3 or not shadows:     # (one grey level: any darker pixel may be one)
            assert fast[12:38, 22:28].mean() > 0.8         # the person is found
        if shadows and channels == 3:
            assert fast[32:44, 32:48].mean() < 0.2          # its shadow is not


def test_the_foreground_kernel_on_a_real_frame_equals_numpy():
    """A real video's frame 41 against its frame 1 as the plate (the person moved), e.g. a
    camera of Pose2Sim's demo: ``VOXELMOCAP_DEMO_VIDEO=.../videos/cam02.mp4``."""
    import os

    import cv2

    from voxelmocap.measure.plate import PlateBackground

    video = os.environ.get("VOXELMOCAP_DEMO_VIDEO")
    if not video:
        pytest.skip("no video named by VOXELMOCAP_DEMO_VIDEO")
    cap = cv2.VideoCapture(video)
    ok, first = cap.read()
    if not ok:
        pytest.skip("no demo video (VOXELMOCAP_DEMO_VIDEO)")
    for _ in range(40):
        ok, frame = cap.read()
    h, w = first.shape[:2]
    known = np.ones((h, w), bool)
    known[h // 4:, w // 2 - 150:w // 2 + 150] = False
    bg = PlateBackground(first, 3.0, known)
    assert (bg.foreground(frame) == bg._foreground_numpy(frame)).all()


def test_the_foreground_kernel_rounds_every_distance_as_numpy():
    """A mask compares distances with one threshold, so it hides rounding: set the threshold to
    a pixel's NumPy distance exactly, and to the float32 just below it, for many pixels."""
    from voxelmocap.measure.plate import PlateBackground

    rng = np.random.default_rng(12)
    for channels in (1, 3):
        plate, frame, known = _scene(rng, channels=channels)
        image = frame[:, :, 0] if channels == 1 else frame
        bg = PlateBackground(plate, rng.uniform(1.0, 6.0, plate.shape[:2]), known,
                             shadows=False)
        dist, _ = bg.distance(image)
        for ij in rng.choice(dist.size, 40, replace=False):
            d = dist.flat[ij]
            for t in (d, np.nextafter(d, np.float32(-np.inf))):
                bg.threshold = float(t)                  # the mask then hinges on this pixel
                assert bg.foreground(image).flat[ij] == bg._foreground_numpy(image).flat[ij]


def test_a_black_pixel_with_no_brightness_floor_is_foreground_as_in_numpy():
    """α = 0 (a black pixel) passes a brightness range starting at 0; its chromaticity
    distortion is 0/0 or x/0, which NumPy makes inf: not a shadow. The kernel must neither
    raise nor call it a shadow."""
    from voxelmocap.config import SilhouetteConfig
    from voxelmocap.measure.plate import PlateBackground

    plate = np.full((8, 8, 3), 100.0, np.float32)
    plate[5, 5] = (100.0, 50.0, 10.0)
    image = np.full((8, 8, 3), 100, np.uint8)
    image[3, 3] = 0                                      # 0/0
    image[5, 5] = 0
    for chroma in (0.08, np.inf):
        cfg = SilhouetteConfig(shadow_brightness=(0.0, 0.95))
        bg = PlateBackground(plate, 1.0, shadow_brightness=cfg.shadow_brightness,
                             shadow_chromaticity=chroma)
        with np.errstate(all="ignore"):
            want = bg._foreground_numpy(image)
        got = bg.foreground(image)
        assert (got == want).all()
    assert got[3, 3] == want[3, 3]


def test_four_channels_and_no_rows_take_the_numpy_path():
    from voxelmocap.measure.plate import PlateBackground

    rng = np.random.default_rng(2)
    plate = rng.uniform(0, 255, (6, 7, 4)).astype(np.float32)
    image = rng.integers(0, 256, (6, 7, 4), dtype=np.uint8)
    bg = PlateBackground(plate, 2.0, shadows=False)
    dist, _ = bg.distance(image)
    bg.threshold = float(np.median(dist))
    assert (bg.foreground(image) == (dist > np.float32(bg.threshold))).all()
    med, count, sigma = masked_median(np.zeros((5, 0, 4, 3), np.uint8), quartiles=True)
    assert med.shape == (0, 4, 3) and count.shape == sigma.shape == (0, 4)
