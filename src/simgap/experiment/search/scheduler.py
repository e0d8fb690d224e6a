"""A search for violated planning assumptions: each strategy of the spec in turn, on an equal
share of the search's budget, into ``OUT/<strategy>/``; resumable like an experiment.

Layout::

    search.json                     the spec and its results hash (a changed spec is refused)
    <strategy>/scenarios/cNNNNN/    each candidate's CommonRoad scenario
    <strategy>/runs/cNNNNN/<fid>/   each run's directory
    <strategy>/store/rows/          one row per finished run (the experiment's results store)
    <strategy>/budget.json          budget spent so far (wall-clock seconds, runs)
    report/index.html               the comparison of the strategies

Every run's row carries the candidate (``candidate``, ``param_*``, ``knob_*``, ``vehicle``, ``planner``), its
rung of the ladder (0 = ideal, last = high), whether it failed by the spec's rule and why, and
``elapsed_s``: the strategy's clock when it finished. A high-fidelity failure is checked in the
ideal world; if the ideal run passes, the candidate is a *violated assumption*. The ideal world
takes no reality knob, so candidates that differ only in their knobs share one ideal run: the
later ones get a copy of its row with ``ideal_of`` (the candidate that ran it) and no cost, and
are not counted as runs. Distinct
violations are counted after de-duplication: one closer than ``distinct_radius`` (in the
normalised space, same vehicle and planner) to an earlier one is the same failure.

The parts: `StrategyRun` schedules one strategy's runs (what to run next, what a result sets
off); `simgap.experiment.search.ledger` keeps its ledger (the typed rows: `rows`; the budget spent, resume);
`simgap.experiment.search.ladder` makes a candidate's job in each rung and shares ideal runs.
"""

from __future__ import annotations

import json
import math
import os
from collections.abc import Callable
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

from simgap.errors import InputError
from simgap.experiment.attribution import explain
from simgap.experiment.executors import make_executor
from simgap.experiment.job import Job, JobContext
from simgap.experiment.run_row import RunRow
from simgap.experiment.search.budget import Budget
from simgap.experiment.search.confirmation import CONFIRMATIONS, Confirmations
from simgap.experiment.search.failure_modes import PROBES
from simgap.experiment.search.follow_up import FollowUp, FollowUpReserve
from simgap.experiment.search.ladder import Ladder, SharedIdealRuns
from simgap.experiment.search.ledger import SearchLedger
from simgap.experiment.search.mode_probes import ModeProbes, probe_plan
from simgap.experiment.search.results import META, FollowUpLeft, SearchMeta, StrategyFindings, StrategyResult, summarise
from simgap.experiment.search.rows import SearchRow
from simgap.experiment.search.space import Candidate, SearchSpace, Strategy
from simgap.experiment.search.spec import STRATEGIES, Search, SearchSpec, load_search_spec
from simgap.experiment.search.strategies import make_strategy
from simgap.experiment.single_run import software_versions
from simgap.experiment.store import ResultsStore
from simgap.sim.registry import preflight


class StrategyRun:
    """One strategy's search in ``root``: proposes jobs, sets off what a result calls for (the ideal
    check of a high-fidelity failure, a promotion up the ladder), keeps to the budget."""

    def __init__(self, search: Search, space: SearchSpace, strategy: Strategy, root: Path, budget: Budget,
                 reserve: FollowUpReserve | None = None):
        self.spec, self.strategy, self.budget, self.reserve = search.spec, strategy, budget, reserve
        self.ladder = Ladder(search, root)
        self.ledger = SearchLedger(root, space)
        self.ideal = SharedIdealRuns(self.ladder, self.ledger, strategy)
        self.high = self.ladder.high
        self.queue: list[tuple[int, int]] = []            # (candidate, rung) follow-ups
        self.in_flight: dict[str, tuple[int, int]] = {}    # job key -> (candidate, rung)
        self.next_index = 0
        self.missing: list[int] = []                      # candidates started earlier that never finished a run
        self.exhausted = False

    @property
    def root(self) -> Path:
        return self.ledger.root

    def runs(self) -> int:
        return self.ledger.runs()

    def out_of_budget(self) -> bool:
        """Whether the share is spent, what following up the violations found so far will cost
        (``reserve``) counted in."""
        seconds, runs = self.ledger.elapsed(), self.runs() + len(self.in_flight)
        if self.reserve is not None:
            self.reserve.update(self.ledger)
            seconds, runs = seconds + self.reserve.seconds(), runs + self.reserve.made + self.reserve.runs
        return self.budget.spent(seconds, runs)

    def resume(self) -> None:
        """Replay what an earlier invocation finished into the strategy, and queue what was due."""
        for r in self.ledger.load():
            c = self.ledger.candidates[r.candidate]
            if r.rung == 0 and r.ok:
                self.ideal.known(r.candidate)
            self.strategy.restore(c, r.rung, r.judged, r.failed)
            if r.rung == self.high and r.ok:
                self.strategy.confirmed(c, r.failed)
        self.queue += self.ledger.unfinished(self.high)
        self.next_index = max(self.ledger.candidates, default=-1) + 1
        if self.strategy.name in ("grid", "random", "lhs"):     # the same index gives the same candidate
            self.missing = [i for i in range(self.next_index) if i not in self.ledger.candidates]

    def next_job(self) -> Job | None:
        if self.out_of_budget():
            return None
        waiting = []                     # follow-ups whose ideal run (for the score drop) is not in yet
        try:
            while self.queue:
                index, rung = self.queue.pop(0)
                if (index, rung) in self.ledger.rows or (index, rung) in self.in_flight.values():
                    continue
                if rung == 0 and self.ideal.settle(index):
                    continue
                if rung > 0 and self.spec.needs_ideal_first and (index, 0) not in self.ledger.rows:
                    waiting.append((index, rung))
                    continue
                return self._start(index, rung)
        finally:
            self.queue[:0] = waiting
        if self.exhausted:
            return None
        if self.missing:
            c = self.strategy.propose(self.missing.pop(0))
            if c is not None:
                return self._start_new(c)
        c = self.strategy.propose(self.next_index)
        if c is None:
            self.exhausted = True
            return None
        self.next_index += 1
        return self._start_new(c)

    def _start_new(self, c: Candidate) -> Job | None:
        """The first job of a new candidate: its first rung — after its ideal run when runs are judged
        by their score drop (None: it waits for a sibling's ideal run in flight)."""
        self.ledger.candidates[c.index] = c
        first = (self.strategy.first_rung if c.start_rung is None else c.start_rung) % len(self.spec.ladder)
        if first == 0 or not self.spec.needs_ideal_first:
            return self._start(c.index, first)
        if not self.ideal.settle(c.index):
            self.queue.insert(0, (c.index, first))
            return self._start(c.index, 0)
        if (c.index, 0) in self.ledger.rows:          # a sibling's ideal run, copied
            return self._start(c.index, first)
        self.queue.insert(0, (c.index, first))        # its ideal run is in flight: nothing to do until it is in
        return None

    def _start(self, index: int, rung: int) -> Job:
        job = self.ladder.job(self.ledger.candidates[index], rung)
        self.in_flight[job.key] = (index, rung)
        return job

    def on_result(self, job: Job, result: RunRow) -> None:
        index, rung = self.in_flight.pop(job.key)
        c = self.ledger.candidates[index]
        row = SearchRow(result, self.strategy.name, index, rung, job.backend, False, "", self.ledger.elapsed(),
                        tuple(c.unit), dict(c.knobs), score_drop=self.ledger.score_drop(index, rung, result))
        reason = self.spec.failure.failed(row.judged.columns()) if row.ok else None
        row = replace(row, failed=reason is not None, failure_reason=reason or "")
        follow = self.strategy.observe(c, rung, row.judged, row.failed)
        row = replace(row, promote=bool(follow))
        self.ledger.record(row)
        if rung == self.high and row.ok:
            self.strategy.confirmed(c, row.failed)
            if row.failed and (index, 0) not in self.ledger.rows:
                self.queue.insert(0, (index, 0))           # is it a violated assumption?
        self.queue += [(index, r) for r in follow]
        if rung == 0:                                       # those that waited for it: a copy, or (it failed) a run
            self.queue[:0] = [(other, 0) for other in self.ideal.finished(index, row.ok)]
        self.ledger.save_budget(self.budget)


def _claim(root: Path, spec: SearchSpec) -> None:
    if (root / META).exists():
        if SearchMeta.read(root).results_hash != spec.results_hash():
            raise InputError("this directory holds a search of a different spec; mixing them would make the "
                             "counts meaningless", file=root, allowed="the same spec, or a new --out directory")
        return
    root.mkdir(parents=True, exist_ok=True)
    SearchMeta(spec=json.loads(spec.model_dump_json()), results_hash=spec.results_hash(),
               versions=software_versions()).write(root)


@dataclass
class SearchProgress:
    strategy: str
    elapsed_s: float
    budget: Budget
    runs: int
    high_failures: int


def run_search(spec_ref: str | Path, root: Path, budget: Budget, workers: int | None, executor: str = "local",
               address: str | None = None, strategies: list[str] | None = None,
               on_progress: Callable[[SearchProgress], None] | None = None, validate: bool = False,
               follow_up: FollowUp | None = None) -> list[StrategyResult]:
    """Run (or resume) every strategy of the spec (or ``strategies``), ``budget`` shared evenly among
    them (`Budget.shares`); ``validate`` checks each run's solution (slow: `simgap search` asks for
    it unless --no-validate). Each share pays for the strategy's search and for following up the
    distinct violations it reports (`simgap.experiment.search.follow_up`: probed, confirmed over
    ``follow_up.repeats`` seeds, explained); ``follow_up`` None: the search spends its whole share
    and reports nothing (a comparison of the strategies' yield). What each found goes to
    ``search.json``."""
    search = load_search_spec(spec_ref)
    spec = search.spec
    if not validate and spec.failure.solution_invalid:
        raise InputError("the failure rule asks whether solutions are valid: that needs the validity check, which "
                         "--no-validate skips",
                         file=search.file, field="failure.solution_invalid", allowed="false, or validation on")
    for rung in search.rungs:
        preflight(rung.backend, rung.settings)
    names = strategies or list(spec.strategies)
    for n in names:
        if n not in STRATEGIES:
            raise InputError(f"unknown strategy '{n}'", field="strategy", allowed=", ".join(STRATEGIES))
    shares = budget.shares(names)
    root = Path(root)
    runner = make_executor(executor, workers, spec.run_timeout_s, address)
    runs_at_once = getattr(runner, "workers", None) or workers or os.cpu_count() or 1
    _claim(root, spec)
    space = SearchSpace(spec, search.logical, search.vehicles, list(search.planners))
    results = []
    for name in names:
        sroot = root / name
        sroot.mkdir(parents=True, exist_ok=True)
        share = shares[name]
        reserve = None if follow_up is None else _reserve(search, sroot, name, follow_up, share, runs_at_once)
        run = StrategyRun(search, space, make_strategy(name, space, spec), sroot, share, reserve)
        run.resume()
        context = JobContext(sroot, planner_vehicle=search.planner_vehicle, validate=validate, criticality=False)

        def on_result(job: Job, row: RunRow, run: StrategyRun = run, name: str = name, share: Budget = share) -> None:
            run.on_result(job, row)
            if on_progress:
                on_progress(SearchProgress(name, run.ledger.elapsed(), share, run.runs(),
                                           run.ledger.high_failures(run.high)))

        runner.run(run.next_job, context, on_result)
        run.ledger.save_budget(share)
        found = summarise(sroot, name, len(spec.ladder), spec.distinct_radius)
        if reserve is not None:
            _follow_up(search, space, run, reserve, runner, validate, max(2, runs_at_once))
            run.ledger.save_budget(share)
            found = summarise(sroot, name, len(spec.ladder), spec.distinct_radius)
            found.left = _left(found, reserve)
        results.append(found)
        _record_findings(root, results[-1])
    return results


def _reserve(search: Search, root: Path, name: str, follow_up: FollowUp, share: Budget,
             workers: int) -> FollowUpReserve:
    """The follow-up reserve of the strategy in ``root``, with what an earlier invocation followed up."""
    before = summarise(root, name, len(search.spec.ladder), search.spec.distinct_radius)
    made = sum(len(ResultsStore(root / d).finished_keys()) for d in (PROBES, CONFIRMATIONS)
               if (root / d / "store" / "rows").exists())
    made += sum(v.explanation.runs for v in before.found if v.explanation is not None)
    return FollowUpReserve(probe_plan(search), follow_up, share, len(search.spec.ladder) - 1,
                           search.spec.distinct_radius, workers, done={v.candidate for v in before.reported}, made=made)


def _follow_up(search: Search, space: SearchSpace, run: StrategyRun, reserve: FollowUpReserve, runner: Any,
               validate: bool, explain_workers: int) -> None:
    """Follow up the strategy's distinct violations, worst first, as far as its share goes
    (`FollowUpReserve.planned`): their probes, then their confirmations, then their explanations."""
    spec, root = search.spec, run.root
    found = summarise(root, run.strategy.name, len(spec.ladder), spec.distinct_radius)
    worst = sorted(found.found, key=lambda v: -_finite(v.row.run.value(spec.objective)))
    planned = reserve.planned(worst, run.ledger.elapsed(), run.runs() + reserve.made)
    ideal = {v.candidate: v.ideal_row for v in planned}

    def counted(on_result: Callable[[Job, RunRow], None]) -> Callable[[Job, RunRow], None]:
        def made(job: Job, row: RunRow) -> None:
            on_result(job, row)
            reserve.made += 1
        return made

    probes = ModeProbes(search, space, root, ideal)
    runner.run([job for v in planned for job in probes.jobs(v.row)],
               JobContext(probes.root, planner_vehicle=search.planner_vehicle, validate=validate, criticality=False),
               counted(probes.on_result))
    confirmations = Confirmations(search, space, root, reserve.follow_up.repeats, ideal)
    runner.run([job for v in planned for job in confirmations.jobs(v.row)],
               JobContext(confirmations.root, planner_vehicle=search.planner_vehicle, validate=validate,
                          criticality=False),
               counted(confirmations.on_result))
    for v in planned:
        if v.explanation is None and reserve.explains(reserve.explanation(v.run_dir)):
            reserve.made += explain(v.run_dir, explain_workers).runs


def _left(found: StrategyResult, reserve: FollowUpReserve) -> FollowUpLeft:
    """What the share left undone, and what doing it would cost (in the budget's unit)."""
    reported = {v.candidate for v in found.reported}
    unprobed = [v for v in found.found if v.candidate not in reported]
    to_probe = sum(reserve.runs_of(v.row, v.run_dir) for v in unprobed)
    unexplained = [v for v in found.reported if v.explanation is None] if reserve.follow_up.explain else []
    to_explain = sum(reserve.explanation(v.run_dir) for v in unexplained)

    def cost(runs: int) -> Budget:
        return Budget(seconds=reserve.seconds(runs)) if reserve.share.seconds is not None else Budget(runs=runs)

    return FollowUpLeft(len(unprobed), cost(to_probe), len(unexplained), cost(to_explain))


def _finite(value: float) -> float:
    return value if math.isfinite(value) else -math.inf


def _record_findings(root: Path, found: StrategyResult) -> None:
    """Keep what a strategy found in ``search.json`` beside the spec: its counts (the distinct
    violations, those reported) and failure modes."""
    saved = SearchMeta.read(root)
    findings = StrategyFindings(runs=found.runs, violations=found.violations, distinct=found.distinct,
                                scenarios=found.scenarios, reported=len(found.reported),
                                modes=tuple(m.model_dump(mode="json") for m in found.modes))
    saved.model_copy(update={"findings": saved.findings | {found.name: findings}}).write(root)
