"""The bench scripts as modules, for their smoke tests: ``bench_module("vehicles/vehicle_dynamics")``."""

from __future__ import annotations

import importlib
import sys
from pathlib import Path

import pytest

BENCH = Path(__file__).resolve().parents[2] / "bench"


@pytest.fixture(scope="module")
def bench_module():
    """Import a script of ``bench/`` by its path there without ``.py``, e.g. ``"vehicles/vehicle_dynamics"``
    (its folder on sys.path only while the module's tests run)."""
    added: list[str] = []

    def load(name: str):
        folder, _, module = name.rpartition("/")
        path = str(BENCH / folder)
        if path not in sys.path:
            sys.path.insert(0, path)
            added.append(path)
        return importlib.import_module(module)

    try:
        yield load
    finally:
        for path in added:
            sys.path.remove(path)
