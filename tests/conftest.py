from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
REFERENCE = REPO.parent / "shared" / "reference"


@pytest.fixture
def reference_dir() -> Path:
    if not REFERENCE.is_dir():
        pytest.skip("../shared/reference is absent: reference data not available")
    return REFERENCE


@pytest.fixture
def assets_dir() -> Path:
    return REPO / "assets"
