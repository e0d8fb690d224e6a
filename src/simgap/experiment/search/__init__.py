"""The search for violated planning assumptions, one module a part:

* `spec`: the search spec (`SearchSpec`, read and checked into a `Search`; `load_search_spec`);
* `space`: the search space (the normalised unit cube, `Candidate`) and the `Strategy` interface;
* `strategies` (grid, random, lhs, bo) and `multi_fidelity` (the cheap worlds screen, the
  promising candidates climb the ladder);
* `scheduler`: `run_search`, and `StrategyRun`, which schedules one strategy's runs, with
  `ladder` (a candidate's job in each rung, shared ideal runs), `ledger` (what a strategy has run
  and spent, resume) and `rows` (`SearchRow`, a run's row with the search's columns);
* `mode_probes` and `failure_modes`: which dimensions each violation needs;
* `results`: what a search found (`search_results`), read by the report and the CLI.

The names users start from are importable from here (``from simgap.experiment.search import
run_search, Budget``); each is imported on first use, so that reading a search's results does not
load the scheduler.
"""

from __future__ import annotations

import importlib
from typing import Any

_PUBLIC = {
    "Budget": "budget", "StrategyRun": "scheduler", "parse_budget": "budget", "run_search": "scheduler",
    "SearchSpec": "spec", "Search": "spec", "load_search_spec": "spec",
    "SearchResults": "results", "StrategyResult": "results", "search_results": "results",
}

__all__ = sorted(_PUBLIC)


def __getattr__(name: str) -> Any:
    if name in _PUBLIC:
        return getattr(importlib.import_module(f"{__name__}.{_PUBLIC[name]}"), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
