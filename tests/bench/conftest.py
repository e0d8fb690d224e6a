"""The bench scripts as modules, for their smoke tests: ``bench_module("vehicle_dynamics")``."""

from __future__ import annotations

import importlib
import sys
from pathlib import Path

import pytest

BENCH = Path(__file__).resolve().parents[2] / "bench"


@pytest.fixture(scope="module")
def bench_module():
    """Import a script of ``bench/`` by its name (the folder on sys.path only while the module's tests run)."""
    sys.path.insert(0, str(BENCH))
    try:
        yield importlib.import_module
    finally:
        sys.path.remove(str(BENCH))
