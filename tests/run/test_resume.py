"""``run.resume``: which existing result a run may continue, and each refusal.

The results are written here (seeded states, the attributes a run records) and opened by a real
:class:`~voxelmocap.io.results.ResultWriter`, as a run opens its own; the config's TOML without
``[export]`` is checked with the standard library's TOML reader.
"""

import sys

import numpy as np
import pytest

if sys.version_info >= (3, 11):
    import tomllib
else:  # the package's own dependency there
    import tomli as tomllib

from voxelmocap.config import TrackConfig, config_to_toml, with_overrides
from voxelmocap.errors import InputError
from voxelmocap.io.results import ResultWriter, TrackResult, write_result
from voxelmocap.run.resume import RESUME_KEYS, previous_run, tracking_config

CONFIG = with_overrides(TrackConfig(), **{"filter.layers": 2, "filter.particles": 40})

META = {"config": config_to_toml(CONFIG), "seed": 4, "subject": "S1", "action": "Walking",
        "trial": 1, "cameras": "C1,C2,C3", "frames_requested": "1,2,3,4,5", "person_masks": "",
        "plate_from": "", "frame_rate": 60.0}


def _result(n=3, *, checkpoint=True, observed=None, drop=(), **changed):
    rng = np.random.default_rng(n)
    attrs = {k: v for k, v in {**META, **changed}.items() if k not in drop}
    return TrackResult(
        frames=np.arange(1, n + 1), state=rng.normal(size=(n, 27)),
        landmarks=rng.normal(size=(n, 15, 3)), endpoints=rng.normal(size=(n, 20, 3)),
        part_scores=rng.random((n, 10, 4)), ess=rng.random((n, 2)), betas=rng.random((n, 2)),
        seconds=rng.random(n), log_likelihood=rng.normal(size=n),
        map_state=rng.normal(size=(n, 27)), state_names=[f"s{i}" for i in range(27)],
        part_names=[f"p{i}" for i in range(10)], attrs={**attrs, "complete": False},
        checkpoint={"particles": rng.normal(size=(4, 27)), "frame": n} if checkpoint else None,
        observed=observed)


def _previous(path, meta=META, *, resume=True, overwrite=False):
    with ResultWriter(path) as writer:
        return previous_run(writer, meta, resume, overwrite)


def test_no_result_starts_afresh(tmp_path):
    for resume, overwrite in [(False, False), (True, False), (False, True)]:
        assert _previous(tmp_path / "r.h5", resume=resume, overwrite=overwrite) is None


def test_a_result_is_continued_only_when_asked(tmp_path):
    path = tmp_path / "r.h5"
    written = _result()
    write_result(path, written)
    with pytest.raises(InputError) as info:
        _previous(path, resume=False)
    assert str(info.value) == (f"{path}: result exists; use --resume to continue it or "
                               "--overwrite to replace it")
    assert _previous(path, resume=False, overwrite=True) is None       # replaced
    back = _previous(path)
    np.testing.assert_array_equal(back.state, written.state)
    np.testing.assert_array_equal(back.checkpoint["particles"], written.checkpoint["particles"])
    assert path.is_file() and sorted(p.name for p in tmp_path.iterdir()) == ["r.h5"]


@pytest.mark.parametrize("key", RESUME_KEYS)
def test_another_runs_result_is_refused(tmp_path, key):
    """Every attribute of RESUME_KEYS must match; the message names the one that differs."""
    other = {"config": config_to_toml(with_overrides(CONFIG, **{"filter.layers": 3})),
             "seed": 5, "subject": "S2", "action": "Jog", "trial": 2, "cameras": "C1,C2",
             "frames_requested": "1,2,3", "person_masks": "/masks", "plate_from": "/run/r.h5",
             "frame_rate": 30.0}   # the filter's noise is scaled to the frame rate
    assert set(other) == set(RESUME_KEYS)
    path = tmp_path / "r.h5"
    write_result(path, _result(**{key: other[key]}))
    with pytest.raises(InputError) as info:
        _previous(path)
    assert info.value.problem == (f"cannot resume: its {key} differs from this run's (use "
                                  "--overwrite to start again)")
    assert _previous(path, resume=False, overwrite=True) is None


def test_exports_may_change_and_older_results_had_no_masks_or_plate(tmp_path):
    path = tmp_path / "r.h5"
    write_result(path, _result(drop=("person_masks", "plate_from")))
    exports = with_overrides(CONFIG, **{"export.formats": ["trc", "csv"], "export.cutoff_hz": 6.0})
    assert config_to_toml(exports) != META["config"]
    assert len(_previous(path, {**META, "config": config_to_toml(exports)})) == 3
    with pytest.raises(InputError, match="its person_masks differs"):
        _previous(path, {**META, "person_masks": "/masks"})


def test_frames_without_a_checkpoint(tmp_path):
    """Frames but no checkpoint cannot be continued, unless none saw the person (nothing was
    started yet: start again); a file killed before its first frame starts afresh."""
    path = tmp_path / "r.h5"
    write_result(path, _result(checkpoint=False))
    with pytest.raises(InputError, match="cannot resume: the file has no checkpoint"):
        _previous(path)
    write_result(path, _result(checkpoint=False, observed=np.zeros(3, bool)))
    assert _previous(path) is None
    write_result(path, _result(checkpoint=False, observed=np.array([False, True, False])))
    with pytest.raises(InputError, match="no checkpoint"):
        _previous(path)
    write_result(path, _result(n=0, checkpoint=False))
    assert _previous(path) is None


def test_the_tracking_config_is_the_toml_without_its_export_table():
    text = config_to_toml(with_overrides(CONFIG, **{"export.formats": ["c3d"]}))
    full = tomllib.loads(text)
    assert "export" in full
    kept = tomllib.loads(tracking_config(text))
    assert kept == {k: v for k, v in full.items() if k != "export"}
    assert tracking_config(text) == tracking_config(config_to_toml(CONFIG))
    assert tracking_config(config_to_toml(with_overrides(CONFIG, **{"filter.layers": 3}))) \
        != tracking_config(text)
    for unparsable in ("[filter\nlayers = ", "None"):    # e.g. a result with no config: as is
        assert tracking_config(unparsable) == unparsable
