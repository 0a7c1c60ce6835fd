"""``run.request``: a run's request, and where its results go.

The paths are checked against the layout the rest of the package reads them from:
``RUN/<subject>/[<pass folder>/]<sequence name>.<ext>`` (``run.batch.BatchItem.result_path``
for a finished sequence, ``run.bodies.tracked_body`` for ``--plate-from``).
"""

import types
from pathlib import Path

import pytest

from voxelmocap.config import TrackConfig
from voxelmocap.run.batch import BatchItem
from voxelmocap.run.plan import pass_folder
from voxelmocap.run.request import TrackRequest


def _sequence(subject="S1", name="Walking_1"):
    return types.SimpleNamespace(subject=subject, name=name)


def test_the_results_of_the_last_pass_and_of_the_earlier_ones(tmp_path):
    request = TrackRequest(tmp_path / "data", "S1", "Walking_1", tmp_path / "RUN")
    h5, xml, bvh = request.result_paths(_sequence())
    assert (h5, xml, bvh) == (tmp_path / "RUN/S1/Walking_1.h5", tmp_path / "RUN/S1/Walking_1.xml",
                              tmp_path / "RUN/S1/Walking_1.bvh")
    assert h5 == BatchItem("S1", "Walking_1").result_path(tmp_path / "RUN")
    assert request.result_paths(_sequence(), pass_folder(2)) == tuple(
        tmp_path / "RUN/S1/pass2" / f"Walking_1.{ext}" for ext in ("h5", "xml", "bvh"))
    # a relative run folder stays relative (the messages name what the user typed)
    assert TrackRequest(None, None, None, "out").result_paths(_sequence())[0] == \
        Path("out/S1/Walking_1.h5")


@pytest.mark.parametrize("name", ["walk.2", "trial_1.5ms", "2024.05.01"])
def test_a_sequence_name_with_a_dot_keeps_it(tmp_path, name):
    """A project's trial is named after its folder, which may hold dots: its result is
    ``<name>.h5`` where ``--plate-from`` and a batch look for it, not the name cut at its last
    dot (two trials ``a.1`` and ``a.2`` would otherwise both be ``a``)."""
    request = TrackRequest(None, None, None, tmp_path)
    paths = request.result_paths(_sequence(name, name))
    assert [p.name for p in paths] == [f"{name}.h5", f"{name}.xml", f"{name}.bvh"]
    assert paths[0] == BatchItem(name, name).result_path(tmp_path)
    assert request.result_paths(_sequence("S1", name), "pass1")[0] == \
        tmp_path / "S1" / "pass1" / f"{name}.h5"


def test_the_request_is_a_frozen_value_with_the_defaults():
    request = TrackRequest("data", "S1", "Walking_1", "RUN", config=None)
    assert request.config == TrackConfig()              # None: the defaults
    assert (request.seed, request.resume, request.overwrite, request.progress) == \
        (0, False, False, True)
    assert (request.masks, request.plate_from, request.cues_given) == (None, None, False)
    with pytest.raises(AttributeError):
        request.seed = 3
