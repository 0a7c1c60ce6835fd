import os
import sys
from pathlib import Path

import pytest
from hypothesis import settings

# The property tests run on a fixed set of examples (derandomize), on every machine: a result
# does not depend on the draw, and an example failing here fails the same way in CI (a CI run
# once hung on a draw no local run had made). To explore new inputs, run with
# VOXELMOCAP_EXPLORE=1 (random draws, printed blobs to replay a failure).
settings.register_profile("fixed", derandomize=True, print_blob=True)
settings.register_profile("explore", print_blob=True)
settings.load_profile("explore" if os.environ.get("VOXELMOCAP_EXPLORE") else "fixed")

TESTS = Path(__file__).resolve().parent
if str(TESTS) not in sys.path:
    sys.path.insert(0, str(TESTS))

#: Real motion-capture clips beside the project (absent in some checkouts: tests then skip).
MOCAP_DIR = TESTS.parent.parent / "shared" / "mocap"


@pytest.fixture
def mocap_dir() -> Path:
    if not MOCAP_DIR.is_dir():
        pytest.skip("real motion-capture clips not available (the CMU / Bandai Namco BVH files the "
                    "project develops with, expected in ../shared/mocap beside the checkout; "
                    "not shipped)")
    return MOCAP_DIR


@pytest.fixture
def tiny_dataset(tmp_path) -> Path:
    from humaneva_fixture import make_tiny_dataset

    return make_tiny_dataset(tmp_path / "data")


#: Cameras of the shared rendered walk (a subset keeps rendering and carving quick).
WALK_CAMERAS = ["C1", "C2", "C3", "BW1"]


@pytest.fixture(scope="session")
def walk_dataset(tmp_path_factory) -> Path:
    """An 8-frame procedural walk rendered into 4 cameras (HumanEva layout, with ground truth)."""
    from voxelmocap.synth import generate

    root = tmp_path_factory.mktemp("walk")
    return generate(root, motion="walk", frames=8, cameras=WALK_CAMERAS, progress=False,
                    background_frames=20, seed=3)


def _link_without_answer(source, root, leave_out=("Mocap_Data",)):
    """Link the data set ``source`` into ``root`` without ``Mocap_Data`` (no ground truth, no
    body file; ``leave_out``: these folders, e.g. also ``Background``); returns ``root``."""
    import os

    for path in source.rglob("*"):
        rel = path.relative_to(source)
        if set(leave_out) & set(rel.parts):
            continue
        if path.is_dir():
            (root / rel).mkdir(parents=True, exist_ok=True)
        else:
            (root / rel).parent.mkdir(parents=True, exist_ok=True)
            os.symlink(path, root / rel)
    return root


@pytest.fixture(scope="session")
def link_without_answer():
    """``link(source, root)``: a data set's links without ``Mocap_Data`` (see above)."""
    return _link_without_answer


@pytest.fixture(scope="session")
def walk_without_answer(walk_dataset, tmp_path_factory):
    """The rendered walk without ``Mocap_Data``: no ground truth, no body file (links, not copies)."""
    return _link_without_answer(walk_dataset, tmp_path_factory.mktemp("noanswer"))


@pytest.fixture
def interrupt_at_third_frame(monkeypatch):
    """``run(data, out, **kwargs)``: track ``S1/Walking_1`` of ``data`` into ``out``, interrupted
    (KeyboardInterrupt) when the third frame is written."""
    from voxelmocap.io.results import ResultWriter
    from voxelmocap.run.pipeline import track_sequence

    def run(data, out, **kwargs):
        real_append = ResultWriter.append
        calls = {"n": 0}

        def interrupted(self, *args, **kw):
            calls["n"] += 1
            if calls["n"] == 3:
                raise KeyboardInterrupt
            real_append(self, *args, **kw)

        monkeypatch.setattr(ResultWriter, "append", interrupted)
        with pytest.raises(KeyboardInterrupt):
            track_sequence(data, "S1", "Walking_1", out, **kwargs)
        monkeypatch.setattr(ResultWriter, "append", real_append)

    return run


@pytest.fixture
def interrupted_then_resumed(interrupt_at_third_frame):
    """``run(data, out, **kwargs)``: :func:`interrupt_at_third_frame`, then resumed; returns the
    resumed outcome."""
    from voxelmocap.run.pipeline import track_sequence

    def run(data, out, **kwargs):
        interrupt_at_third_frame(data, out, **kwargs)
        return track_sequence(data, "S1", "Walking_1", out, resume=True, **kwargs)

    return run
