import sys
from pathlib import Path

import pytest

TESTS = Path(__file__).resolve().parent
if str(TESTS) not in sys.path:
    sys.path.insert(0, str(TESTS))

#: Real motion-capture clips beside the project (absent in some checkouts: tests then skip).
MOCAP_DIR = TESTS.parent.parent / "shared" / "mocap"


@pytest.fixture
def mocap_dir() -> Path:
    if not MOCAP_DIR.is_dir():
        pytest.skip("../shared/mocap is not available")
    return MOCAP_DIR


@pytest.fixture
def tiny_dataset(tmp_path) -> Path:
    from humaneva_fixture import make_tiny_dataset

    return make_tiny_dataset(tmp_path / "data")
