"""A search for violated planning assumptions: each strategy of the spec in turn, on its own
budget, into ``OUT/<strategy>/``; resumable like an experiment.

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
"""

from __future__ import annotations

import json
import math
import re
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable

from simgap.cosim import CosimSettings, Fidelity
from simgap.errors import InputError, validated
from simgap.experiment.executors import make_executor
from simgap.experiment.knobs import apply_knobs
from simgap.experiment.search_results import META, StrategyResult, summarise
from simgap.experiment.search_spec import SCORE_DROP, STRATEGIES, SearchSpec, load_search_spec
from simgap.experiment.records import Job, JobContext, JobId, RunRow
from simgap.experiment.runner import clean_partial_runs
from simgap.experiment.single_run import software_versions
from simgap.experiment.spec import planner_choices, vehicle_ref
from simgap.experiment.store import ResultsStore
from simgap.experiment.strategies import Candidate, SearchSpace, Strategy, make_strategy
from simgap.files import atomic_write_text
from simgap.scenario import write_scenario
from simgap.planning.registry import DEFAULT_PLANNER, PlannerChoice
from simgap.sim.registry import preflight
from simgap.vehicles import load_vehicle


@dataclass(frozen=True)
class Budget:
    seconds: float | None = None
    runs: int | None = None

    def spent(self, seconds: float, runs: int) -> bool:
        return (self.seconds is not None and seconds >= self.seconds) or (self.runs is not None and runs >= self.runs)

    def __str__(self) -> str:
        return f"{self.seconds:g} s" if self.seconds is not None else f"{self.runs} runs"


def parse_budget(text: str) -> Budget:
    """``20m``, ``90s``, ``1.5h`` (wall clock per strategy) or ``N`` (runs per strategy)."""
    m = re.fullmatch(r"\s*(\d+(?:\.\d+)?)\s*([smh]?)\s*", str(text))
    if not m or float(m.group(1)) <= 0:
        raise InputError(f"'{text}' is not a budget", field="budget", allowed="a duration like 20m, 90s, 1.5h, or a run count like 200")
    value, unit = float(m.group(1)), m.group(2)
    if not unit:
        if value != int(value):
            raise InputError(f"'{text}' is not a whole number of runs", field="budget", allowed="200, or 20m")
        return Budget(runs=int(value))
    return Budget(seconds=value * {"s": 1, "m": 60, "h": 3600}[unit])


def _rung_name(rung: int, ladder_len: int) -> str:
    return "ideal" if rung == 0 else "high" if rung == ladder_len - 1 else f"screen{rung}"


class SharedIdealRuns:
    """The ideal world takes no reality knob, so candidates that differ only in their knobs share
    one ideal run. Keyed by what an ideal run depends on: the verdicts known (the candidate that
    ran it), the runs in flight, and the candidates waiting for them."""

    def __init__(self) -> None:
        self.verdicts: dict[str, int] = {}
        self.running: dict[str, int] = {}
        self.waiting: dict[str, list[int]] = {}

    def known(self, key: str, index: int) -> None:
        """``index`` ran the ideal run ``key`` depends on, and it finished."""
        self.verdicts.setdefault(key, index)

    def join(self, key: str, index: int) -> bool:
        """True if ``index`` waits for a run already in flight; else it runs one itself."""
        if key in self.running:
            self.waiting.setdefault(key, []).append(index)
            return True
        self.running[key] = index
        return False

    def finished(self, key: str, index: int, ok: bool) -> list[int]:
        """``index``'s ideal run finished: the candidates that waited for it."""
        self.running.pop(key, None)
        if ok:
            self.known(key, index)
        return self.waiting.pop(key, [])


class StrategyRun:
    """One strategy's search in ``root``: proposes jobs, records results, keeps the budget."""

    def __init__(self, spec: SearchSpec, space: SearchSpace, strategy: Strategy, root: Path, budget: Budget,
                 planners: dict[str, PlannerChoice] | None = None):
        self.spec, self.space, self.strategy, self.root, self.budget = spec, space, strategy, root, budget
        self.planners = planners or {DEFAULT_PLANNER: PlannerChoice()}        # by name
        self.store = ResultsStore(root)
        self.high = len(spec.ladder) - 1
        self.candidates: dict[int, Candidate] = {}
        self.rows: dict[tuple[int, int], dict[str, Any]] = {}
        self.queue: list[tuple[int, int]] = []        # (candidate, rung) follow-ups
        self.in_flight: dict[str, tuple[int, int]] = {}    # job key -> (candidate, rung)
        self.next_index = 0
        self.missing: list[int] = []                  # candidates started earlier that never finished a run
        self.ideal = SharedIdealRuns()
        self.exhausted = False
        self.spent_before = 0.0
        self.started = time.monotonic()

    @property
    def ideal_verdicts(self) -> dict[str, int]:
        return self.ideal.verdicts

    # --- state -----------------------------------------------------------------------------
    def elapsed(self) -> float:
        return self.spent_before + time.monotonic() - self.started

    def runs(self) -> int:
        return sum(1 for r in self.rows.values() if "ideal_of" not in r)

    def out_of_budget(self) -> bool:
        return self.budget.spent(self.elapsed(), self.runs() + len(self.in_flight))

    def _save_budget(self) -> None:
        atomic_write_text(self.root / "budget.json",
                          json.dumps({"spent_s": self.elapsed(), "runs": self.runs(), "budget": str(self.budget)}))

    def resume(self) -> None:
        """Load what an earlier invocation finished and replay it into the strategy."""
        self.store.prepare()
        clean_partial_runs(self.root)
        path = self.root / "budget.json"
        if path.exists():
            saved = json.loads(path.read_text())
            self.spent_before = float(saved.get("spent_s", 0.0))
        rows = sorted(self.store.rows(), key=lambda r: r.get("elapsed_s", 0.0))
        indices = sorted({int(r["candidate"]) for r in rows})
        for index in indices:
            c = self._candidate_from_rows(index, [r for r in rows if int(r["candidate"]) == index])
            self.candidates[index] = c
        for r in rows:
            self._replay(r)
        self._queue_unfinished()
        # candidates that were started but never finished a run are proposed again
        self.next_index = (max(indices) + 1) if indices else 0
        if self.strategy.name in ("grid", "random", "lhs"):     # the same index gives the same candidate
            self.missing = [i for i in range(self.next_index) if i not in self.candidates]

    def _replay(self, r: dict[str, Any]) -> None:
        """A row an earlier invocation stored, told to the strategy as it was then."""
        index, rung = int(r["candidate"]), int(r["rung"])
        self.rows[(index, rung)] = r
        if rung == 0 and r.get("status") == "ok":
            self.ideal.known(self._ideal_key(self.candidates[index]), index)
        failed = bool(r.get("failed"))
        self.strategy.restore(self.candidates[index], rung, r, failed)
        if rung == self.high and r.get("status") == "ok":
            self.strategy.confirmed(self.candidates[index], failed)

    def _queue_unfinished(self) -> None:
        """Follow-ups that were due but never finished: ideal checks and promotions."""
        for index in self.candidates:
            high = self.rows.get((index, self.high))
            if high is not None and high.get("failed") and (index, 0) not in self.rows:
                self.queue.append((index, 0))
            done = [k for (i, k) in self.rows if i == index]
            top = max(done)
            if 0 < top < self.high and self.rows[(index, top)].get("promote"):
                self.queue.append((index, top + 1))

    def _candidate_from_rows(self, index: int, rows: list[dict[str, Any]]) -> Candidate:
        r = rows[0]
        unit = [float(r[f"unit_{i}"]) for i in range(len(self.space.dims))]
        return self.space.candidate(index, unit, r["vehicle"], planner=r.get("planner") or DEFAULT_PLANNER)

    # --- jobs --------------------------------------------------------------------------------
    def _scenario(self, c: Candidate) -> str:
        folder = self.root / "scenarios" / _scenario_name(c.index)
        existing = sorted(folder.glob("*.xml"))
        if existing:
            return str(existing[0])
        return str(write_scenario(self.space.logical.build(c.params), folder, preview=False))

    def _run_settings(self, c: Candidate, rung_index: int) -> tuple[str | None, dict[str, Any], dict[str, Any]]:
        """(controller, backend settings, cosim settings) of ``c`` in a rung."""
        rung = self.spec.ladder[rung_index]
        settings, cosim = apply_knobs(rung.backend, c.knobs)
        settings = dict(rung.settings) | settings
        controller = None
        if rung.backend != "ideal":
            controller = settings.pop("controller", self.spec.controller)
            settings["controller"] = controller
        merged = dict(rung.cosim)
        for key, value in cosim.items():
            merged[key] = dict(merged.get(key) or {}) | value
        return controller, settings, merged

    def job(self, c: Candidate, rung_index: int) -> Job:
        controller, settings, cosim = self._run_settings(c, rung_index)
        fidelity = Fidelity(self.spec.ladder[rung_index].backend, load_vehicle(c.vehicle).name, controller)
        job_id = JobId(_scenario_name(c.index), fidelity, seed=self.spec.seed + c.index, planner=c.planner,
                       stage=_rung_name(rung_index, len(self.spec.ladder)))
        return Job(job_id, c.params, c.vehicle, settings, cosim, self._scenario(c), self.planners[c.planner])

    def _ideal_key(self, c: Candidate) -> str:
        """Everything an ideal run of ``c`` depends on: the scenario's parameters, the vehicle, the
        planner, the rung's settings, and the seed only if that rung observes with noise."""
        _, settings, cosim = self._run_settings(c, 0)
        noisy = any(v for v in (cosim.get("observation_noise") or {}).values())
        driver = [c.vehicle] if c.planner == DEFAULT_PLANNER else [c.vehicle, c.planner]
        return json.dumps([c.params, *driver, settings, cosim, self.spec.seed + c.index if noisy else None],
                          sort_keys=True, default=str)

    def _settle_ideal(self, index: int) -> bool:
        """Settle ``index``'s ideal check without running it, if its scenario's ideal verdict is
        known (copied now) or being run (copied when it comes); False if it has to run."""
        key = self._ideal_key(self.candidates[index])
        if key in self.ideal.verdicts:
            self._copy_ideal(index, self.ideal.verdicts[key])
            return True
        return self.ideal.join(key, index)

    def _copy_ideal(self, index: int, source: int) -> None:
        c = self.candidates[index]
        name = _scenario_name(index)
        key = JobId(name, Fidelity("ideal", c.vehicle), planner=c.planner, stage=_rung_name(0, len(self.spec.ladder))).key
        row = dict(self.rows[(source, 0)]) | {"key": key,
                                               "scenario": name, "candidate": index, "ideal_of": source,
                                               "elapsed_s": self.elapsed()}
        row |= {k: 0.0 for k in row if k.startswith("time_") or k in ("job_time_s", "wall_time_s")}
        row |= _candidate_columns(c)
        self.strategy.observe(c, 0, row, bool(row.get("failed")))
        row["promote"] = False
        self.store.write_columns(row)
        self.rows[(index, 0)] = row

    def next_job(self) -> Job | None:
        if self.out_of_budget():
            return None
        waiting = []                     # follow-ups whose ideal run (for the score drop) is not in yet
        try:
            while self.queue:
                index, rung = self.queue.pop(0)
                if (index, rung) in self.rows or (index, rung) in self.in_flight.values():
                    continue
                if rung == 0 and self._settle_ideal(index):
                    continue
                if rung > 0 and self.spec.needs_ideal_first and (index, 0) not in self.rows:
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
                self.candidates[c.index] = c
                return self._begin(c)
        c = self.strategy.propose(self.next_index)
        if c is None:
            self.exhausted = True
            return None
        self.next_index += 1
        self.candidates[c.index] = c
        return self._begin(c)

    def _begin(self, c: Candidate) -> Job | None:
        """The first job of a new candidate: its first rung — after its ideal run when runs are judged
        by their score drop (None: it waits for a sibling's ideal run in flight)."""
        first = self._first_rung(c)
        if first == 0 or not self.spec.needs_ideal_first:
            return self._start(c.index, first)
        if not self._settle_ideal(c.index):
            self.queue.insert(0, (c.index, first))
            return self._start(c.index, 0)
        if (c.index, 0) in self.rows:                 # a sibling's ideal run, copied
            return self._start(c.index, first)
        self.queue.insert(0, (c.index, first))        # its ideal run is in flight: nothing to do until it is in
        return None

    def _first_rung(self, c: Candidate) -> int:
        return (self.strategy.first_rung if c.start_rung is None else c.start_rung) % len(self.spec.ladder)

    def _start(self, index: int, rung: int) -> Job:
        job = self.job(self.candidates[index], rung)
        self.in_flight[job.key] = (index, rung)
        return job

    def on_result(self, job: Job, result: RunRow) -> None:
        index, rung = self.in_flight.pop(job.key)
        c = self.candidates[index]
        result = result.with_columns(**score_drop_column(result.score, self.rows.get((index, 0)), rung == 0))
        reason = self.spec.failure.failed(result.columns()) if result.status == "ok" else None
        result = result.with_columns(strategy=self.strategy.name, candidate=index, rung=rung,
                                     rung_backend=job.backend, failed=reason is not None,
                                     failure_reason=reason or "", elapsed_s=self.elapsed(), **_candidate_columns(c))
        row = result.columns()
        follow = self.strategy.observe(c, rung, row, reason is not None)
        row["promote"] = bool(follow)
        self.store.write_row(result.with_columns(promote=bool(follow)))
        self.rows[(index, rung)] = row
        if rung == self.high and row.get("status") == "ok":
            self.strategy.confirmed(c, reason is not None)
            if reason is not None and (index, 0) not in self.rows:
                self.queue.insert(0, (index, 0))           # is it a violated assumption?
        for r in follow:
            self.queue.append((index, r))
        if rung == 0:
            ok = row.get("status") == "ok"
            waiting = self.ideal.finished(self._ideal_key(c), index, ok)
            if ok:
                for other in waiting:
                    self._copy_ideal(other, index)
            else:                                           # that run failed: each runs its own
                self.queue[:0] = [(other, 0) for other in waiting]
        self._save_budget()


def score_drop_column(score: float | None, ideal: dict[str, Any] | None, is_ideal: bool) -> dict[str, float]:
    """``score_drop``: the candidate's ideal score minus this run's (0 for the ideal run itself; none
    while its ideal run is not in)."""
    if is_ideal:
        return {SCORE_DROP: 0.0}
    ideal_score = None if ideal is None or ideal.get("status") != "ok" else ideal.get("score")
    if score is None or ideal_score is None or math.isnan(ideal_score):
        return {}
    return {SCORE_DROP: float(ideal_score) - float(score)}


def _scenario_name(index: int) -> str:
    return f"c{index:05d}"


def _candidate_columns(c: Candidate) -> dict[str, float]:
    return {f"unit_{i}": float(u) for i, u in enumerate(c.unit)} | {f"knob_{k}": float(v) for k, v in c.knobs.items()}


def _claim(root: Path, spec: SearchSpec) -> None:
    meta = root / META
    if meta.exists():
        saved = json.loads(meta.read_text())
        if saved.get("results_hash") != spec.results_hash():
            raise InputError("this directory holds a search of a different spec; mixing them would make the "
                             "counts meaningless", file=root, allowed="the same spec, or a new --out directory")
        return
    root.mkdir(parents=True, exist_ok=True)
    atomic_write_text(meta, json.dumps({"spec": spec.model_dump(), "results_hash": spec.results_hash(),
                                        "versions": software_versions()}, indent=2, default=str))


@dataclass
class SearchProgress:
    strategy: str
    elapsed_s: float
    budget: Budget
    runs: int
    high_failures: int


def run_search(spec_ref: str | Path, root: Path, budget: Budget, workers: int | None, executor: str = "local",
               address: str | None = None, strategies: list[str] | None = None,
               on_progress: Callable[[SearchProgress], None] | None = None, validate: bool = True) -> list[StrategyResult]:
    """Run (or resume) every strategy of the spec (or ``strategies``) on ``budget`` each; ``validate``
    False skips the check of each run's solution."""
    spec, logical, path = load_search_spec(spec_ref)
    if not validate and spec.failure.solution_invalid:
        raise InputError("the failure rule asks whether solutions are valid, which --no-validate skips", file=path,
                         field="failure.solution_invalid", allowed="false, or validation on")
    for rung in spec.ladder:
        preflight(rung.backend, dict(rung.settings))
    names = strategies or list(spec.strategies)
    for n in names:
        if n not in STRATEGIES:
            raise InputError(f"unknown strategy '{n}'", field="strategy", allowed=", ".join(STRATEGIES))
    root = Path(root)
    runner = make_executor(executor, workers, spec.run_timeout_s, address)
    _claim(root, spec)
    planners = {c.name: c for c in planner_choices(spec, path)}
    space = SearchSpace(spec, logical, [vehicle_ref(v, path) for v in spec.vehicles], list(planners))
    cosim = validated(CosimSettings, spec.cosim)
    results = []
    for name in names:
        sroot = root / name
        sroot.mkdir(parents=True, exist_ok=True)
        run = StrategyRun(spec, space, make_strategy(name, space, spec), sroot, budget, planners)
        run.resume()
        context = JobContext(sroot, cosim, planner_vehicle=vehicle_ref(spec.planner_vehicle, path), validate=validate)

        def on_result(job: Job, row: RunRow, run: StrategyRun = run, name: str = name) -> None:
            run.on_result(job, row)
            if on_progress:
                fails = sum(1 for (i, k), r in run.rows.items() if k == run.high and r.get("failed"))
                on_progress(SearchProgress(name, run.elapsed(), budget, run.runs(), fails))

        runner.run(run.next_job, context, on_result)
        run._save_budget()
        results.append(summarise(sroot, name, len(spec.ladder), spec.distinct_radius))
    return results
