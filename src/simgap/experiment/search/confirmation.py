"""The confirmation of a search's violations over seeds: is a violation the physical world's, or
one seed's bad luck?

A violation's high-fidelity run is one seed of the localisation's noise (and, with ``measured``
latency, one machine's load). Each distinct violation is run again in the high-fidelity world
with ``repeats - 1`` more seeds (its own seed + 1, + 2, ...: repeats 1 to N - 1 of its job), judged
by the search's failure rule, so that it says in how many of N seeds it reproduces, with a Wilson
95 % interval (`simgap.evaluate.odds`). Resumable: each run's row goes to
``<strategy>/confirmations/store`` under its own key (``c00012/high/r1``), and a run with a row is
never run again.
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

from simgap.evaluate.odds import Rate, wilson
from simgap.experiment.job import Job
from simgap.experiment.run_row import RunRow
from simgap.experiment.runner import clean_partial_runs
from simgap.experiment.search.ladder import Ladder
from simgap.experiment.search.ledger import score_drop
from simgap.experiment.search.rows import SearchRow
from simgap.experiment.search.space import SearchSpace
from simgap.experiment.search.spec import SCORE_DROP, Search
from simgap.experiment.store import ResultsStore
from simgap.planning.registry import DEFAULT_PLANNER

CONFIRMATIONS = "confirmations"       # the confirmation runs' directory in a strategy's
FAILED = "confirmed_failed"           # the column that says whether a confirmation run failed the rule


class Confirmations:
    """The confirmation runs of one strategy's violations (``ideal``: their ideal runs, by
    candidate), each over ``repeats`` seeds: the jobs of a violation's runs not made yet (`jobs`),
    and what to do with each result."""

    def __init__(self, search: Search, space: SearchSpace, root: Path, repeats: int,
                 ideal: dict[int, SearchRow] | None = None):
        self.spec, self.space, self.ideal, self.repeats = search.spec, space, ideal or {}, repeats
        self.root = Path(root) / CONFIRMATIONS
        self.ladder = Ladder(search, Path(root))
        self.store = ResultsStore(self.root)
        self.store.prepare()
        clean_partial_runs(self.root)
        self.done = set(self.store.finished_keys()) if self.store.rows_dir.exists() else set()
        self.in_flight: dict[str, int] = {}

    def jobs(self, row: SearchRow) -> list[Job]:
        """The confirmation runs of the violation ``row`` (its high-fidelity row) not made yet."""
        out = []
        for k in range(1, self.repeats):
            job = self._job(row, k)
            if job.key not in self.done:
                self.in_flight[job.key] = row.candidate
                out.append(job)
        return out

    def _job(self, row: SearchRow, k: int) -> Job:
        c = self.space.candidate(row.candidate, list(row.unit), row.run.vehicle_ref,
                                 planner=row.run.id.planner or DEFAULT_PLANNER)
        job = self.ladder.job(c, self.ladder.high)
        return replace(job, id=replace(job.id, repeat=k, seed=row.run.id.seed + k))

    def on_result(self, job: Job, result: RunRow) -> None:
        candidate = self.in_flight.pop(job.key)
        drop = score_drop(self.ideal.get(candidate), result)
        judged = result if drop is None else result.with_columns(**{SCORE_DROP: drop})
        failed = result.status == "ok" and self.spec.failure.failed(judged.columns()) is not None
        self.store.write_row(judged.with_columns(**{FAILED: failed}))
        self.done.add(job.key)


def reproduction(root: Path, violation: SearchRow) -> Rate:
    """In how many of its seeds ``violation`` (a high-fidelity row of the strategy in ``root``)
    fails the rule: itself, and its confirmation runs that finished."""
    store = ResultsStore(Path(root) / CONFIRMATIONS)
    rows = store.rows() if store.rows_dir.exists() else []
    mine = [r for r in rows if r["scenario"] == violation.run.id.scenario and r.get("stage") == violation.run.id.stage
            and (r.get("planner") or DEFAULT_PLANNER) == (violation.run.id.planner or DEFAULT_PLANNER)
            and r.get("vehicle") == violation.run.id.fidelity.vehicle]
    failed = 1 + sum(bool(r.get(FAILED)) for r in mine)
    return wilson(failed, 1 + len(mine))
