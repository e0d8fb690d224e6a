"""The recorded-like scenarios of the co-simulation tests (`tests/cosim/real_like.py`) are used here
too; ASAM's Quality Checker, where it is installed (`make qc`)."""

import sys
from pathlib import Path

import pytest

from simgap.export import quality_checker

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "cosim"))


@pytest.fixture
def asam_qc():
    """ASAM's Quality Checker (``quality_checker.check``), or the test skips saying why it is missing."""
    try:
        quality_checker.checker_command(".xodr")
        quality_checker.checker_command(".xosc")
    except quality_checker.QualityCheckerMissing as missing:
        pytest.skip(str(missing))
    return quality_checker.check
