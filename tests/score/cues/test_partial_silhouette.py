"""The silhouette cue re-scored on a limb's parts only (``score.cues.partial``): the drawing
kernel against the cue's counting kernel and a brute-force reference, the partial cue against the
whole cue bit for bit, and the periodic sweep finding the same limbs either way."""

import numpy as np
import pytest
from test_cues import _camera
from test_silhouette_cue import _drawn, _observation

from voxelmocap.body import BodyModel
from voxelmocap.config import CuesConfig
from voxelmocap.measure import _silhouette_kernels as sk
from voxelmocap.pose.hierarchy import LIMBS
from voxelmocap.score.cues import CueSet
from voxelmocap.score.cues.partial import PartialSilhouette

MODEL = BodyModel()


@pytest.mark.parametrize("seed", range(6))
def test_drawn_parts_are_the_pixels_the_cover_kernel_counts(seed):
    """Random outlines, partly outside the picture, some parts invalid: the drawn union holds
    exactly the pixels ``cover_counts`` counts inside and outside the mask, and those of the
    brute-force reference (pixel centres inside each part's convex hull, scipy)."""
    rng = np.random.default_rng(seed)
    n_p, n_parts, k, h, w = 5, 5, 16, 50, 70
    mask = rng.random((h, w)) < 0.4
    points = rng.uniform([-15, -15], [w + 15, h + 15], (n_p, n_parts, 1, 2)) \
        + rng.normal(0, 10, (n_p, n_parts, k, 2))
    valid = rng.random((n_p, n_parts)) < 0.8
    hit, extra = np.empty(n_p, np.int64), np.empty(n_p, np.int64)
    sk.cover_counts(points, valid, mask, hit, extra)
    for p in range(n_p):
        drawn = np.zeros((h, w), bool)
        sk.draw_parts(points[p], valid[p], drawn)
        assert (drawn & mask).sum() == hit[p] and (drawn & ~mask).sum() == extra[p]
        np.testing.assert_array_equal(drawn, _drawn(points[p], valid[p], h, w))


@pytest.fixture(scope="module")
def scene():
    """Two cameras, silhouettes of a pose with both arms raised and a knee bent; the default
    pose as the limb searches' reference; a third camera whose silhouette is empty."""
    truth = MODEL.default_state()
    truth[[11, 15, 18, 25]] = (1.2, 0.9, 0.7, 0.8)
    cams = [_camera(size=(320, 240)), _camera("D", eye=(3000.0, -3000.0, 1500.0), size=(320, 240)),
            _camera("E", eye=(-3500.0, 1500.0, 1200.0), size=(320, 240))]
    obs = _observation(MODEL, truth, cams, 320)
    obs.masks[2][:] = False
    return obs


@pytest.mark.parametrize("limb", list(LIMBS))
def test_the_partial_cue_is_the_whole_cue_to_the_bit(scene, limb):
    """States moving one limb of the reference (uniform over its legal box): the same values as
    the cue on whole states, for each limb."""
    dims, parts = LIMBS[limb]
    config = CuesConfig(weights={"silhouette": 1.0})
    cues = CueSet(MODEL, config)
    reference = MODEL.default_state()
    rng = np.random.default_rng(len(limb))
    states = np.repeat(reference[None], 40, axis=0)
    lo, hi = MODEL.low[list(dims)], MODEL.high[list(dims)]
    states[:, list(dims)] = lo + rng.random((40, len(dims))) * (hi - lo)
    partial = PartialSilhouette(cues.prepare(scene), MODEL, config, reference, parts)
    whole = cues.evaluate(scene, states)["silhouette"]
    assert np.ptp(whole) > 0.5
    np.testing.assert_array_equal(partial(states), whole)
    assert len(partial.views) == 2                      # the empty silhouette adds nothing


def test_the_partial_cue_refuses_ignored_pixels(scene):
    config = CuesConfig(weights={"silhouette": 1.0}, silhouette_unseen="ignore")
    with pytest.raises(ValueError, match="silhouette_unseen"):
        PartialSilhouette(CueSet(MODEL, config).prepare(scene), MODEL, config,
                          MODEL.default_state(), LIMBS["l_arm"][1])


def test_the_sweep_finds_the_same_limbs_with_the_partial_cue(scene):
    """The periodic sweep scored with the silhouette cue on whole states (``others``) and
    re-scored on each limb's parts (``partial``): the same pose to the bit."""
    from voxelmocap.pose.limb_search import LimbScoring, sweep_limbs
    from voxelmocap.score.cues.partial import WeightedPartialSilhouette

    cues = CueSet(MODEL, CuesConfig(weights={"silhouette": 10.0}))
    whole = LimbScoring(others=cues.frame(scene))
    part = LimbScoring(partial=WeightedPartialSilhouette(cues, scene, 10.0))
    start = MODEL.default_state()
    a, gains = sweep_limbs(scene, MODEL, start, scoring=whole, sweeps=1, samples=64)
    b, _ = sweep_limbs(scene, MODEL, start, scoring=part, sweeps=1, samples=64)
    assert sum(gains.values()) > 0
    np.testing.assert_array_equal(a, b)


@pytest.mark.parametrize("n_states", [3, 40])
def test_the_one_thread_kernels_give_the_parallel_ones_values(scene, monkeypatch, n_states):
    """``cover_counts_prefixed`` and ``outline_points`` and their ``_serial`` twins (a batch of
    fewer than ``SERIAL_BELOW`` poses): the same outline points, counts and cue values to the
    bit, whole or partial, whichever the batch's size would pick."""
    from voxelmocap import thread_waits
    from voxelmocap.score.cues.contours import outline_pixels
    from voxelmocap.score.cues.partial import _geometry

    dims, parts = LIMBS["r_arm"]
    config = CuesConfig(weights={"silhouette": 1.0})
    cues = CueSet(MODEL, config)
    reference = MODEL.default_state()
    rng = np.random.default_rng(n_states)
    states = np.repeat(reference[None], n_states, axis=0)
    lo, hi = MODEL.low[list(dims)], MODEL.high[list(dims)]
    states[:, list(dims)] = lo + rng.random((n_states, len(dims))) * (hi - lo)
    geo = _geometry(MODEL, states)
    camera = scene.cameras[1]
    mask = scene.masks[1]
    assert thread_waits.serial(thread_waits.SERIAL_BELOW - 1)
    assert not thread_waits.serial(thread_waits.SERIAL_BELOW)
    got = {}
    for below in (0, 10 ** 6):                          # every batch parallel, every one serial
        monkeypatch.setattr(thread_waits, "SERIAL_BELOW", below)
        points, valid = outline_pixels(geo, camera, (1.0, 1.0))
        count = sk.cover_counts_prefixed_serial if thread_waits.serial(n_states) \
            else sk.cover_counts_prefixed
        hit, extra = np.empty(n_states, np.int64), np.empty(n_states, np.int64)
        count(points, valid, sk.row_prefix(mask), hit, extra)
        partial = PartialSilhouette(cues.prepare(scene), MODEL, config, reference, parts)
        got[below] = (points, valid, hit, extra, cues.evaluate(scene, states)["silhouette"],
                      partial(states))
    for a, b in zip(got[0], got[10 ** 6], strict=True):
        np.testing.assert_array_equal(a, b)
    assert got[0][2].sum() > 0                           # the arm's cones cover silhouette pixels
    # the counts against the brute-force reference (pixel centres inside each part's hull)
    for k in range(n_states):
        drawn = _drawn(got[0][0][k], got[0][1][k], *mask.shape)
        assert (drawn & mask).sum() == got[0][2][k] and (drawn & ~mask).sum() == got[0][3][k]
