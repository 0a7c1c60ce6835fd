"""``run.plan``: the passes a run takes, each pass's plate, config and start, and what it logs.

Pure: the sequences are stand-ins holding only what the plan reads (their cameras and whether
each has background videos); the expected plans are the rules of ``docs/architecture.md``
("The plan of a run") written out case by case.
"""

import types

import pytest

from voxelmocap.config import TrackConfig, with_overrides
from voxelmocap.run.plan import (
    MASKS_CUES,
    MASKS_MAX_HULL,
    MIN_BODY_FRAMES,
    VOXEL_SWEEP_EVERY,
    PassPlan,
    RunPlan,
    carving_config,
    final_config,
    masks_defaults,
    plan_passes,
)

DEFAULT = TrackConfig()
#: a carving pass's config from the defaults: the periodic sweep without the silhouette cue, at
#: the period of a sweep of the voxels alone
CARVING = with_overrides(DEFAULT, **{"filter.limb_sweep_silhouette": 0.0,
                                     "filter.limb_sweep_every": VOXEL_SWEEP_EVERY})


def _sequence(with_videos=()):
    """Three cameras; those named in ``with_videos`` have a background video."""
    return types.SimpleNamespace(
        camera_names=["C1", "C2", "C3"],
        background_paths=lambda cam: [f"Background_({cam}).avi"] if cam in with_videos else [])


NO_VIDEOS = _sequence()
ALL_VIDEOS = _sequence(("C1", "C2", "C3"))


def _cues(config):
    return dict(config.cues.weights)


def test_background_videos_take_one_pass_with_the_config_as_given():
    plan = plan_passes(ALL_VIDEOS, DEFAULT, n_frames=200)
    assert plan == RunPlan((PassPlan(1, 1, DEFAULT, "videos"),))
    assert plan.describe() == []
    # MOG2 learns no plate either, videos or not
    mog2 = with_overrides(DEFAULT, **{"measurement.silhouette.method": "mog2"})
    assert plan_passes(NO_VIDEOS, mog2, n_frames=200).passes == (PassPlan(1, 1, mog2, "videos"),)


def test_one_camera_without_videos_learns_the_plate_in_passes():
    plan = plan_passes(_sequence(("C1", "C2")), DEFAULT, n_frames=MIN_BODY_FRAMES)
    assert [p.plate for p in plan.passes] == ["carving", "previous", "previous"]


def test_three_passes_carving_then_each_from_the_previous_body():
    """The default: 3 plate passes, pass 3 on starting from pass 2's body (previous_pass_start
    = 3); the first pass tracks with the config as given but for the periodic sweep's silhouette
    cue (its silhouettes lack the parts that stood still), the later ones with the silhouette cue
    added (a plate from a body), the gate untouched."""
    plan = plan_passes(NO_VIDEOS, DEFAULT, n_frames=MIN_BODY_FRAMES)
    later = with_overrides(DEFAULT, **{"cues.weights": {"voxel": 1.0, "silhouette": 10.0}})
    assert plan.passes == (PassPlan(1, 3, CARVING, "carving"),
                           PassPlan(2, 3, later, "previous"),
                           PassPlan(3, 3, later, "previous", continues=True))
    assert [p.folder for p in plan.passes] == ["pass1", "pass2", ""]
    assert [p.last for p in plan.passes] == [False, False, True]
    assert [p.needs_previous for p in plan.passes] == [False, True, True]
    assert later.filter.limb_sweep_max_hull == DEFAULT.filter.limb_sweep_max_hull
    assert plan.note == "a plate from a tracked body: cues voxel=1,silhouette=10 (docs/projects.md; " \
                        "--cues or the config file choose otherwise)"


@pytest.mark.parametrize("first, expected", [(3, [False, False, True, True]),
                                             (2, [False, True, True, True]),
                                             (0, [False, False, False, False])])
def test_which_passes_continue_the_previous_one(first, expected):
    """``[init] previous_pass_start``: pass k continues from this one on (0: never); the first
    pass has no previous pass to continue; every later pass learns its plate from the previous
    pass's body."""
    config = with_overrides(TrackConfig(), **{"init.previous_pass_start": first,
                                              "measurement.silhouette.plate_passes": 4})
    no_videos = types.SimpleNamespace(camera_names=["C1", "C2"], background_paths=lambda c: [])
    plan = plan_passes(no_videos, config, n_frames=20)
    assert [p.continues for p in plan.passes] == expected
    assert [p.plate for p in plan.passes] == ["carving", "previous", "previous", "previous"]
    assert [p.folder for p in plan.passes] == ["pass1", "pass2", "pass3", ""]
    # the plan is what the log says at the start
    assert plan.describe()[0].startswith("4 tracking passes")
    assert len(plan.describe()) == 5


def test_the_support_column_is_for_the_carving_pass_body_only():
    """``plate_body_support``: the plate of pass 2 (around the body tracked against the plate
    learnt by carving) covers the column; the passes after it, around bodies tracked against a
    plate learnt from a body, do not; the pass that carves keeps the config as given."""
    key = "measurement.silhouette.plate_body_support"
    config = with_overrides(TrackConfig(), **{key: 350.0,
                                              "measurement.silhouette.plate_passes": 4})
    plan = plan_passes(NO_VIDEOS, config, n_frames=20)
    support = [p.config.measurement.silhouette.plate_body_support for p in plan.passes]
    assert support == [350.0, 350.0, 0.0, 0.0]
    # nothing else differs between pass 2's settings and the later passes'
    later = with_overrides(plan.passes[1].config, **{key: 0.0})
    assert [p.config for p in plan.passes[2:]] == [later, later]
    # a plate from a given run: the column as set
    run = plan_passes(NO_VIDEOS, config, n_frames=20, plate_from="RUN")
    assert run.passes[0].config.measurement.silhouette.plate_body_support == 350.0


def test_too_few_frames_for_a_plate_from_a_body_take_one_pass_by_carving():
    """Fewer than MIN_BODY_FRAMES frames: one pass, the plate by carving, the config as given
    (no silhouette cue: there is no body to learn a plate from; none in the sweep either)."""
    plan = plan_passes(NO_VIDEOS, DEFAULT, n_frames=MIN_BODY_FRAMES - 1)
    assert plan == RunPlan((PassPlan(1, 1, CARVING, "carving"),))
    one = with_overrides(DEFAULT, **{"measurement.silhouette.plate_passes": 1})
    assert plan_passes(NO_VIDEOS, one, n_frames=500) == RunPlan((PassPlan(
        1, 1, with_overrides(one, **{"filter.limb_sweep_silhouette": 0.0,
                                     "filter.limb_sweep_every": VOXEL_SWEEP_EVERY}), "carving"),))


def test_a_sweep_silhouette_weight_set_in_the_config_is_kept_in_the_carving_pass():
    """Only the default weight is dropped for a carving pass; a weight the config chose stands,
    and passes whose silhouettes come from background videos keep the default."""
    chosen = with_overrides(DEFAULT, **{"filter.limb_sweep_silhouette": 4.0})
    assert plan_passes(NO_VIDEOS, chosen, n_frames=500).passes[0].config == with_overrides(
        chosen, **{"filter.limb_sweep_every": VOXEL_SWEEP_EVERY})
    assert DEFAULT.filter.limb_sweep_silhouette > 0
    assert plan_passes(ALL_VIDEOS, DEFAULT, n_frames=500).passes == \
        (PassPlan(1, 1, DEFAULT, "videos"),)


def test_the_carving_pass_sweeps_at_the_voxel_sweep_period_unless_the_config_chose():
    """The default period is the sweep scored with the silhouettes; a carving pass, whose sweep
    has the voxels alone, sweeps every VOXEL_SWEEP_EVERY frames; a period the config chose (0:
    never) stands there too, and the later passes keep the config's."""
    assert DEFAULT.filter.limb_sweep_every != VOXEL_SWEEP_EVERY
    plan = plan_passes(NO_VIDEOS, DEFAULT, n_frames=MIN_BODY_FRAMES)
    assert [p.config.filter.limb_sweep_every for p in plan.passes] == \
        [VOXEL_SWEEP_EVERY, DEFAULT.filter.limb_sweep_every, DEFAULT.filter.limb_sweep_every]
    for every in (0, 3):
        chosen = with_overrides(DEFAULT, **{"filter.limb_sweep_every": every})
        plan = plan_passes(NO_VIDEOS, chosen, n_frames=MIN_BODY_FRAMES)
        assert [p.config.filter.limb_sweep_every for p in plan.passes] == [every] * 3
    # both chosen: the carving pass's config is the config itself
    both = with_overrides(DEFAULT, **{"filter.limb_sweep_every": 3,
                                      "filter.limb_sweep_silhouette": 4.0})
    assert carving_config(both) is both


def test_given_masks_take_one_pass_with_the_silhouette_cue_and_the_open_gate():
    plan = plan_passes(NO_VIDEOS, DEFAULT, masks="masks/", n_frames=500)
    (only,) = plan.passes
    assert (only.number, only.of, only.plate, only.continues) == (1, 1, "masks", False)
    assert _cues(only.config) == MASKS_CUES
    assert only.config.filter.limb_sweep_max_hull == MASKS_MAX_HULL
    assert only.config == with_overrides(DEFAULT, **{"cues.weights": MASKS_CUES,
                                                     "filter.limb_sweep_max_hull": MASKS_MAX_HULL})
    assert plan.note.startswith("given person masks: cues voxel=1,silhouette=10 and [filter] "
                                "limb_sweep_max_hull = 1000")
    assert plan.describe() == [f"note: {plan.note}"]
    # masks win over a plate from a run, and over background videos
    assert plan_passes(ALL_VIDEOS, DEFAULT, masks="m", plate_from="run", n_frames=5) == plan


def test_what_was_chosen_is_kept():
    """Cues chosen on the command line or in the config, and a gate set in the config, stay."""
    chosen = with_overrides(DEFAULT, **{"cues.weights": {"voxel": 1.0, "edges": 0.5}})
    config, note = masks_defaults(chosen, cues_given=False)
    assert _cues(config) == {"voxel": 1.0, "edges": 0.5}
    assert config.filter.limb_sweep_max_hull == MASKS_MAX_HULL
    assert note.startswith("given person masks: [filter] limb_sweep_max_hull = 1000")
    config, note = masks_defaults(DEFAULT, cues_given=True)
    assert _cues(config) == {"voxel": 1.0} and note.startswith("given person masks: [filter]")
    gated = with_overrides(chosen, **{"filter.limb_sweep_max_hull": 3.0})
    assert masks_defaults(gated, cues_given=False) == (gated, None)
    assert final_config(gated) == (gated, None)


def test_a_plate_from_a_run_takes_one_pass_with_the_silhouette_cue():
    plan = plan_passes(NO_VIDEOS, DEFAULT, plate_from="RUN", n_frames=500)
    config, note = final_config(DEFAULT)
    assert plan == RunPlan((PassPlan(1, 1, config, "run"),), note)
    assert _cues(config) == MASKS_CUES
    assert config.filter.limb_sweep_max_hull == DEFAULT.filter.limb_sweep_max_hull  # no gate
    assert plan_passes(NO_VIDEOS, DEFAULT, plate_from="RUN", n_frames=500,
                       cues_given=True) == RunPlan((PassPlan(1, 1, DEFAULT, "run"),))


def test_a_pass_repeated_as_the_last_keeps_its_plate_config_and_start():
    second = PassPlan(2, 4, DEFAULT, "previous", continues=True)
    last = second.as_last()
    assert last == PassPlan(4, 4, DEFAULT, "previous", continues=True)
    assert last.last and last.folder == "" and not second.last and second.folder == "pass2"
    assert second.as_last().as_last() == last


def test_the_log_names_every_pass_its_plate_and_start():
    config = with_overrides(DEFAULT, **{"init.previous_pass_start": 2})
    lines = plan_passes(NO_VIDEOS, config, n_frames=MIN_BODY_FRAMES).describe()
    assert lines == [
        "3 tracking passes (measurement.silhouette.plate_passes): the first learns the background "
        "plate by carving, each later one from the body the pass before tracked; from pass 2 on "
        "a pass starts from the previous pass's body and pose (init.previous_pass_start); a plate "
        "from a tracked body: cues voxel=1,silhouette=10 (docs/projects.md; --cues or the config "
        "file choose otherwise)",
        "pass 1 of 3: silhouettes from a plate learnt by carving; starts from the ground truth, "
        "else the voxels",
        "pass 2 of 3: silhouettes from a plate learnt around the previous pass's body; starts from "
        "the previous pass's body and first pose (arms searched again)",
        "pass 3 of 3: silhouettes from a plate learnt around the previous pass's body; starts from "
        "the previous pass's body and first pose (arms searched again)",
    ]
    never = with_overrides(DEFAULT, **{"init.previous_pass_start": 0, "cues.weights": {
        "voxel": 1.0, "silhouette": 2.0}})
    head = plan_passes(NO_VIDEOS, never, n_frames=MIN_BODY_FRAMES).describe()[0]
    assert head == ("3 tracking passes (measurement.silhouette.plate_passes): the first learns "
                    "the background plate by carving, each later one from the body the pass "
                    "before tracked")
    for plate, words in [("videos", "the background videos (or MOG2)"), ("masks", "the given masks"),
                         ("run", "a plate learnt around the body of --plate-from")]:
        assert PassPlan(1, 1, DEFAULT, plate).describe() == (
            f"pass 1 of 1: silhouettes from {words}; starts from the ground truth, else the voxels")
