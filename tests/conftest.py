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


#: the groups that take longest (each tens of seconds on two cores: searches, the tutorial pages
#: that run studies), handed out first, so that no worker is left alone with one of them at the end
#: while the other has nothing left to do. Not the Ray cluster's: beside the heaviest searches its
#: Ray Client session was once cleaned up under the driver (a reconnect refused), alone it passes
LONGEST_FIRST = (
    "tests/experiment/search/test_findings_reproduce.py",
    "tests/experiment/search/test_search_runs.py",
    "tutorial tutorials/scenarios-and-runs.md",
    "tutorial tutorials/search.md",
    "tutorial tutorials/experiments.md",
    "tests/cli/test_commands.py",
    "tests/experiment/test_attribution.py",
    "tests/docs/test_docs_site.py",
    "tests/test_types.py",
)


@pytest.hookimpl(tryfirst=True)
def pytest_collection_modifyitems(config, items):
    """Under ``--dist loadgroup`` (`make test`) a test file's tests run on one worker, so that its
    module fixtures are built once, as ``--dist loadfile`` would; a test marked with a group of its
    own (``xdist_group``: the tutorial pages) goes to whichever worker is free. The longest groups
    come first (`LONGEST_FIRST`), the others in their files' order."""
    for item in items:
        if item.get_closest_marker("xdist_group") is None:
            item.add_marker(pytest.mark.xdist_group(item.nodeid.split("::")[0]))
    rank = {group: k for k, group in enumerate(LONGEST_FIRST)}
    items.sort(key=lambda item: rank.get(item.get_closest_marker("xdist_group").args[0], len(rank)))
