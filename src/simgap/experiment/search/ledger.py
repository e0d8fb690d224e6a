"""The ledger of one strategy's search: its candidates, its rows (`SearchRow`), the runs and
wall-clock seconds it has spent, and all of it read back from its directory to resume."""

from __future__ import annotations

import json
import math
import time
from pathlib import Path
from typing import Any

from simgap.experiment.run_row import RunRow
from simgap.experiment.runner import clean_partial_runs
from simgap.experiment.search.rows import SearchRow, read_search_rows
from simgap.experiment.search.space import Candidate, SearchSpace
from simgap.experiment.store import ResultsStore
from simgap.files import atomic_write_text
from simgap.planning.registry import DEFAULT_PLANNER


class SearchLedger:
    """One strategy's search as its directory holds it: the candidates, a row per (candidate,
    rung) run, the runs and the wall-clock seconds spent (``budget.json``)."""

    def __init__(self, root: Path, space: SearchSpace):
        self.root, self.space = Path(root), space
        self.store = ResultsStore(root)
        self.candidates: dict[int, Candidate] = {}
        self.rows: dict[tuple[int, int], SearchRow] = {}
        self.order: list[tuple[int, int]] = []       # the rows' (candidate, rung), in the order recorded
        self.spent_before = 0.0
        self.started = time.monotonic()

    def elapsed(self) -> float:
        return self.spent_before + time.monotonic() - self.started

    def runs(self) -> int:
        """Runs made (copied ideal runs are none)."""
        return sum(1 for r in self.rows.values() if r.ideal_of is None)

    def record(self, row: SearchRow) -> None:
        """Write ``row`` to the store (atomically) and keep it."""
        self.store.write_row(row.as_run_row())
        self.rows[(row.candidate, row.rung)] = row
        self.order.append((row.candidate, row.rung))

    def score_drop(self, index: int, rung: int, run: RunRow) -> float | None:
        """The candidate's ideal score minus ``run``'s: 0 for its ideal run, None while the ideal
        run is not in (or failed, or either has no score)."""
        return 0.0 if rung == 0 else score_drop(self.rows.get((index, 0)), run)

    def save_budget(self, budget: Any) -> None:
        atomic_write_text(self.root / "budget.json",
                          json.dumps({"spent_s": self.elapsed(), "runs": self.runs(), "budget": str(budget)}))

    def load(self) -> list[SearchRow]:
        """What an earlier invocation finished: the candidates, the seconds spent, and its rows in
        the order they finished (to be replayed into the strategy). Half-written rows and run
        directories are removed first."""
        self.store.prepare()
        clean_partial_runs(self.root)
        path = self.root / "budget.json"
        if path.exists():
            self.spent_before = float(json.loads(path.read_text()).get("spent_s", 0.0))
        rows = read_search_rows(self.root)
        first: dict[int, SearchRow] = {}
        for r in rows:
            first.setdefault(r.candidate, r)
            self.rows[(r.candidate, r.rung)] = r
            self.order.append((r.candidate, r.rung))
        for index in sorted(first):
            r = first[index]
            self.candidates[index] = self.space.candidate(index, r.unit, r.run.vehicle_ref,
                                                          planner=r.run.id.planner or DEFAULT_PLANNER)
        return rows

    def unfinished(self, high: int) -> list[tuple[int, int]]:
        """Follow-ups that were due but never finished: ideal checks of high-fidelity failures,
        and promotions up the ladder."""
        out = []
        for index in self.candidates:
            top = self.rows.get((index, high))
            if top is not None and top.failed and (index, 0) not in self.rows:
                out.append((index, 0))
            last = max(k for (i, k) in self.rows if i == index)
            if 0 < last < high and self.rows[(index, last)].promote:
                out.append((index, last + 1))
        return out

    def high_failures(self, high: int) -> int:
        return sum(1 for (_, k), r in self.rows.items() if k == high and r.failed)


def score_drop(ideal: SearchRow | None, run: RunRow) -> float | None:
    """``ideal``'s score minus ``run``'s; None if the ideal run is not in, failed, or either has no score."""
    if ideal is None or not ideal.ok or ideal.run.score is None or run.score is None \
            or math.isnan(ideal.run.score) or math.isnan(run.score):
        return None
    return ideal.run.score - run.score
