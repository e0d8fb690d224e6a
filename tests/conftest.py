"""Settings every test shares."""

from __future__ import annotations

import os

import pytest


@pytest.fixture(autouse=True, scope="session")
def _solution_check_cache(tmp_path_factory):
    """Solution-validity verdicts are cached in a folder of the test session, not the user's cache
    (the environment variable reaches the CLI's subprocesses too)."""
    before = os.environ.get("SIMGAP_CACHE_DIR")
    os.environ["SIMGAP_CACHE_DIR"] = str(tmp_path_factory.mktemp("simgap-cache"))
    yield
    if before is None:
        os.environ.pop("SIMGAP_CACHE_DIR", None)
    else:
        os.environ["SIMGAP_CACHE_DIR"] = before
