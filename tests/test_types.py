"""mypy on src/simgap, with the configuration in pyproject.toml (``[tool.mypy]``), as a test: it
runs alongside the rest of the suite (``make test`` runs pytest with xdist) instead of before it."""

from __future__ import annotations

import hashlib
import importlib.util
import subprocess
import sys
import tempfile
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


@pytest.mark.skipif(importlib.util.find_spec("mypy") is None,
                    reason="mypy is not installed in this environment (it comes with the test extras: make install)")
def test_mypy_finds_no_type_error_in_simgap():
    # a cache kept between runs (warm: a few seconds), one per checkout so that worktrees do not share it
    cache = Path(tempfile.gettempdir()) / f"simgap-mypy-cache-{hashlib.sha256(str(ROOT).encode()).hexdigest()[:12]}"
    done = subprocess.run([sys.executable, "-m", "mypy", "--cache-dir", str(cache)], cwd=ROOT,
                          capture_output=True, text=True, timeout=900)
    assert done.returncode == 0, f"mypy found type errors (or failed):\n{done.stdout}{done.stderr}"
