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


@pytest.hookimpl(tryfirst=True)
def pytest_collection_modifyitems(config, items):
    """Under ``--dist loadgroup`` (`make test`) a test file's tests run on one worker, so that its
    module fixtures are built once, as ``--dist loadfile`` would; a test marked with a group of its
    own (``xdist_group``: the tutorial pages) goes to whichever worker is free."""
    for item in items:
        if item.get_closest_marker("xdist_group") is None:
            item.add_marker(pytest.mark.xdist_group(item.nodeid.split("::")[0]))
