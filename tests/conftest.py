"""Settings every test shares."""

from __future__ import annotations

import os

import pytest
from xdist.scheduler import LoadScopeScheduling


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


#: tests each of which may run on any worker, not with the rest of their file: the tutorial pages,
#: each a study of its own (tens of seconds)
SPREAD = ("tests/docs/test_docs_site.py::test_the_tutorials_print_what_the_page_shows",)

#: the work units that take longest (each tens of seconds on two cores: searches, the tutorial pages
#: that run studies), handed out first, so that no worker is left alone with one of them at the end
#: while the other has nothing left to do; a prefix of a unit's name
LONGEST_FIRST = (
    "tests/experiment/search/test_findings_reproduce.py",
    "tests/experiment/search/test_search_runs.py",
    f"{SPREAD[0]}[tutorials/scenarios-and-runs.md]",
    f"{SPREAD[0]}[tutorials/search.md]",
    f"{SPREAD[0]}[tutorials/experiments.md]",
    "tests/cli/test_commands.py",
    "tests/experiment/test_attribution.py",
    "tests/docs/test_docs_site.py",
    "tests/test_types.py",
)


def work_unit(nodeid: str) -> str:
    """What runs on one worker under ``--dist loadfile`` (`make test`): a test file, so that its
    module fixtures (a Ray cluster, a study) are built once, on one worker; a test of `SPREAD` alone."""
    return nodeid if nodeid.split("[", 1)[0] in SPREAD else nodeid.split("::", 1)[0]


def _rank(nodeid: str) -> int:
    unit = work_unit(nodeid)
    return next((k for k, longest in enumerate(LONGEST_FIRST) if unit.startswith(longest)), len(LONGEST_FIRST))


@pytest.hookimpl(tryfirst=True)
def pytest_collection_modifyitems(config, items):
    """The longest work units first (`LONGEST_FIRST`), the others in their files' order."""
    items.sort(key=lambda item: _rank(item.nodeid))


class _FileScheduling(LoadScopeScheduling):
    """xdist's ``loadfile`` with `work_unit` as the unit (xdist's ``loadgroup`` marks units by a
    suffix of the test's id, which pytest 9.2 no longer lets a plugin change)."""

    def _split_scope(self, nodeid: str) -> str:
        return work_unit(nodeid)


def pytest_xdist_make_scheduler(config, log):
    if config.getvalue("dist") != "loadfile":
        return None
    config.option.loadscopereorder = False      # the units in the order above, not the largest files first
    return _FileScheduling(config, log)
