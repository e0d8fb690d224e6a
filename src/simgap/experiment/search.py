"""A search for violated planning assumptions: each strategy of the spec in turn, on its own
budget, into ``OUT/<strategy>/``; resumable like an experiment.

Layout::

    search.json                     the spec and its results hash (a changed spec is refused)
    <strategy>/scenarios/cNNNNN/    each candidate's CommonRoad scenario
    <strategy>/runs/cNNNNN/<fid>/   each run's directory
    <strategy>/store/rows/          one row per finished run (the experiment's results store)
    <strategy>/budget.json          budget spent so far (wall-clock seconds, runs)
    report/index.html               the comparison of the strategies

Every run's row carries the candidate (``candidate``, ``param_*``, ``knob_*``, ``vehicle``), its
rung of the ladder (0 = ideal, last = high), whether it failed by the spec's rule and why, and
``elapsed_s``: the strategy's clock when it finished. A high-fidelity failure is checked in the
ideal world; if the ideal run passes, the candidate is a *violated assumption*. The ideal world
takes no reality knob, so candidates that differ only in their knobs share one ideal run: the
later ones get a copy of its row with ``ideal_of`` (the candidate that ran it) and no cost, and
are not counted as runs. Distinct
violations are counted after de-duplication: one closer than ``distinct_radius`` (in the
normalised space, same vehicle) to an earlier one is the same failure.
"""

from __future__ import annotations

import json
import math
import os
import re
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable

from simgap.errors import InputError
from simgap.experiment.executors import make_executor
from simgap.experiment.knobs import apply_knobs
from simgap.experiment.search_spec import STRATEGIES, SearchSpec, load_search_spec
from simgap.experiment.spec import Job
from simgap.experiment.store import ResultsStore
from simgap.experiment.strategies import Candidate, SearchSpace, Strategy, make_strategy
from simgap.scenario import write_scenario
from simgap.sim.registry import preflight

META = "search.json"


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


@dataclass
class StrategyResult:
    name: str
    runs: int = 0
    high_runs: int = 0
    high_failures: int = 0
    violations: int = 0
    distinct: int = 0
    scenarios: int = 0                # distinct scenarios (road, start, vehicle) among the violations
    errors: int = 0
    wall_s: float = 0.0
    cpu_s: float = 0.0
    curve: list[tuple[float, int]] = field(default_factory=list)   # (elapsed s, distinct violations so far)

    @property
    def per_cpu_hour(self) -> float:
        return self.distinct / (self.cpu_s / 3600.0) if self.cpu_s > 0 else 0.0


def _rung_name(rung: int, ladder_len: int) -> str:
    return "ideal" if rung == 0 else "high" if rung == ladder_len - 1 else f"screen{rung}"


class StrategyRun:
    """One strategy's search in ``root``: proposes jobs, records results, keeps the budget."""

    def __init__(self, spec: SearchSpec, space: SearchSpace, strategy: Strategy, root: Path, budget: Budget):
        self.spec, self.space, self.strategy, self.root, self.budget = spec, space, strategy, root, budget
        self.store = ResultsStore(root)
        self.high = len(spec.ladder) - 1
        self.candidates: dict[int, Candidate] = {}
        self.rows: dict[tuple[int, int], dict[str, Any]] = {}
        self.queue: list[tuple[int, int]] = []        # (candidate, rung) follow-ups
        self.in_flight: set[tuple[int, int]] = set()
        self.next_index = 0
        self.missing: list[int] = []                  # candidates started earlier that never finished a run
        self.ideal_verdicts: dict[str, int] = {}      # what an ideal run depends on -> candidate that ran it
        self.ideal_running: dict[str, int] = {}
        self.ideal_waiting: dict[str, list[int]] = {}
        self.exhausted = False
        self.spent_before, self.runs_before = 0.0, 0
        self.started = time.monotonic()

    # --- state -----------------------------------------------------------------------------
    def elapsed(self) -> float:
        return self.spent_before + time.monotonic() - self.started

    def runs(self) -> int:
        return sum(1 for r in self.rows.values() if "ideal_of" not in r)

    def out_of_budget(self) -> bool:
        return self.budget.spent(self.elapsed(), self.runs() + len(self.in_flight))

    def _save_budget(self) -> None:
        path = self.root / "budget.json"
        tmp = path.with_suffix(".tmp")
        tmp.write_text(json.dumps({"spent_s": self.elapsed(), "runs": self.runs(), "budget": str(self.budget)}))
        os.replace(tmp, path)

    def resume(self) -> None:
        """Load what an earlier invocation finished and replay it into the strategy."""
        from simgap.experiment.runner import clean_partial_runs

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
            index, rung = int(r["candidate"]), int(r["rung"])
            self.rows[(index, rung)] = r
            if rung == 0 and r.get("status") == "ok":
                self.ideal_verdicts.setdefault(self._ideal_key(self.candidates[index]), index)
            failed = bool(r.get("failed"))
            self.strategy.restore(self.candidates[index], rung, r, failed)
            if rung == self.high and r.get("status") == "ok":
                self.strategy.confirmed(self.candidates[index], failed)
        # follow-ups that were due but never finished: first runs, ideal checks and promotions
        for index, c in self.candidates.items():
            high = self.rows.get((index, self.high))
            if high is not None and high.get("failed") and (index, 0) not in self.rows:
                self.queue.append((index, 0))
            done = [k for (i, k) in self.rows if i == index]
            top = max(done)
            if 0 < top < self.high and self.rows[(index, top)].get("promote"):
                self.queue.append((index, top + 1))
        # candidates that were started but never finished a run are proposed again
        self.next_index = (max(indices) + 1) if indices else 0
        if self.strategy.name in ("grid", "random", "lhs"):     # the same index gives the same candidate
            self.missing = [i for i in range(self.next_index) if i not in self.candidates]

    def _candidate_from_rows(self, index: int, rows: list[dict[str, Any]]) -> Candidate:
        r = rows[0]
        unit = [float(r[f"unit_{i}"]) for i in range(len(self.space.dims))]
        return self.space.candidate(index, unit, r["vehicle"])

    # --- jobs --------------------------------------------------------------------------------
    def _scenario(self, c: Candidate) -> str:
        folder = self.root / "scenarios" / f"c{c.index:05d}"
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
        name = f"c{c.index:05d}"
        key = f"{name}/{_rung_name(rung_index, len(self.spec.ladder))}"
        return Job(key=key, scenario=name, parameters=c.params, backend=self.spec.ladder[rung_index].backend,
                   vehicle=c.vehicle, controller=controller, backend_settings=settings, repeat=0,
                   seed=self.spec.seed + c.index, cosim=cosim, scenario_path=self._scenario(c))

    def _ideal_key(self, c: Candidate) -> str:
        """Everything an ideal run of ``c`` depends on: the scenario's parameters, the vehicle, the
        rung's settings, and the seed only if that rung observes with noise."""
        _, settings, cosim = self._run_settings(c, 0)
        noisy = any(v for v in (cosim.get("observation_noise") or {}).values())
        return json.dumps([c.params, c.vehicle, settings, cosim, self.spec.seed + c.index if noisy else None],
                          sort_keys=True, default=str)

    def _settle_ideal(self, index: int) -> bool:
        """Settle ``index``'s ideal check without running it, if its scenario's ideal verdict is
        known (copied now) or being run (copied when it comes); False if it has to run."""
        key = self._ideal_key(self.candidates[index])
        if key in self.ideal_verdicts:
            self._copy_ideal(index, self.ideal_verdicts[key])
            return True
        if key in self.ideal_running:
            self.ideal_waiting.setdefault(key, []).append(index)
            return True
        self.ideal_running[key] = index
        return False

    def _copy_ideal(self, index: int, source: int) -> None:
        c = self.candidates[index]
        row = dict(self.rows[(source, 0)]) | {"key": f"c{index:05d}/ideal", "scenario": f"c{index:05d}",
                                               "candidate": index, "ideal_of": source, "elapsed_s": self.elapsed()}
        row |= {k: 0.0 for k in row if k.startswith("time_") or k in ("job_time_s", "wall_time_s")}
        row |= _candidate_columns(c)
        self.strategy.observe(c, 0, row, bool(row.get("failed")))
        row["promote"] = False
        self.store.write_row(row)
        self.rows[(index, 0)] = row

    def next_job(self) -> Job | None:
        if self.out_of_budget():
            return None
        while self.queue:
            index, rung = self.queue.pop(0)
            if (index, rung) in self.rows or (index, rung) in self.in_flight:
                continue
            if rung == 0 and self._settle_ideal(index):
                continue
            return self._start(index, rung)
        if self.exhausted:
            return None
        if self.missing:
            c = self.strategy.propose(self.missing.pop(0))
            if c is not None:
                self.candidates[c.index] = c
                return self._start(c.index, self._first_rung(c))
        c = self.strategy.propose(self.next_index)
        if c is None:
            self.exhausted = True
            return None
        self.next_index += 1
        self.candidates[c.index] = c
        return self._start(c.index, self._first_rung(c))

    def _first_rung(self, c: Candidate) -> int:
        return (self.strategy.first_rung if c.start_rung is None else c.start_rung) % len(self.spec.ladder)

    def _start(self, index: int, rung: int) -> Job:
        self.in_flight.add((index, rung))
        return self.job(self.candidates[index], rung)

    def on_result(self, job: Job, row: dict[str, Any]) -> None:
        index = int(job.scenario[1:])
        rung = next(i for i in range(len(self.spec.ladder)) if job.key.endswith("/" + _rung_name(i, len(self.spec.ladder))))
        self.in_flight.discard((index, rung))
        c = self.candidates[index]
        reason = self.spec.failure.failed(row) if row.get("status") == "ok" else None
        row = dict(row) | {"strategy": self.strategy.name, "candidate": index, "rung": rung,
                           "rung_backend": job.backend, "failed": reason is not None, "failure_reason": reason or "",
                           "elapsed_s": self.elapsed()}
        row |= _candidate_columns(c)
        follow = self.strategy.observe(c, rung, row, reason is not None)
        row["promote"] = bool(follow)
        self.store.write_row(row)
        self.rows[(index, rung)] = row
        if rung == self.high and row.get("status") == "ok":
            self.strategy.confirmed(c, reason is not None)
            if reason is not None and (index, 0) not in self.rows:
                self.queue.insert(0, (index, 0))           # is it a violated assumption?
        for r in follow:
            self.queue.append((index, r))
        if rung == 0:
            key = self._ideal_key(c)
            self.ideal_running.pop(key, None)
            waiting = self.ideal_waiting.pop(key, [])
            if row.get("status") == "ok":
                self.ideal_verdicts.setdefault(key, index)
                for other in waiting:
                    self._copy_ideal(other, index)
            else:                                           # that run failed: each runs its own
                self.queue[:0] = [(other, 0) for other in waiting]
        self._save_budget()


def _candidate_columns(c: Candidate) -> dict[str, float]:
    return {f"unit_{i}": u for i, u in enumerate(c.unit)} | {f"knob_{k}": v for k, v in c.knobs.items()}


def summarise(root: Path, name: str, ladder_len: int, radius: float) -> StrategyResult:
    """What a strategy found, from its store alone."""
    store = ResultsStore(root)
    rows = sorted(store.rows(), key=lambda r: r.get("elapsed_s", 0.0)) if store.rows_dir.exists() else []
    high, res = ladder_len - 1, StrategyResult(name)
    budget = root / "budget.json"
    res.wall_s = json.loads(budget.read_text()).get("spent_s", 0.0) if budget.exists() else 0.0
    by_candidate: dict[int, dict[int, dict]] = {}
    for r in rows:
        by_candidate.setdefault(int(r["candidate"]), {})[int(r["rung"])] = r
        res.runs += "ideal_of" not in r
        res.cpu_s += float(r.get("job_time_s") or r.get("wall_time_s") or 0.0)
        res.errors += r.get("status") != "ok"
    found: list[tuple[float, tuple[float, ...], str]] = []
    scenarios: set[tuple] = set()
    for index, runs in by_candidate.items():
        h = runs.get(high)
        if h is None or h.get("status") != "ok":
            continue
        res.high_runs += 1
        if not h.get("failed"):
            continue
        res.high_failures += 1
        ideal = runs.get(0)
        if ideal is None or ideal.get("status") != "ok" or ideal.get("failed"):
            continue
        res.violations += 1
        scenarios.add((h["vehicle"],) + tuple(sorted((k, v) for k, v in h.items() if k.startswith("param_"))))
        when = max(float(h["elapsed_s"]), float(ideal["elapsed_s"]))
        unit = tuple(float(h[k]) for k in sorted((k for k in h if k.startswith("unit_")), key=lambda k: int(k[5:])))
        found.append((when, unit, h["vehicle"]))
    distinct: list[tuple[tuple[float, ...], str]] = []
    for when, unit, vehicle in sorted(found):
        if all(v != vehicle or math.dist(unit, u) >= radius for u, v in distinct):
            distinct.append((unit, vehicle))
            res.curve.append((when, len(distinct)))
    res.distinct = len(distinct)
    res.scenarios = len(scenarios)
    return res


def _claim(root: Path, spec: SearchSpec) -> None:
    meta = root / META
    if meta.exists():
        saved = json.loads(meta.read_text())
        if saved.get("results_hash") != spec.results_hash():
            raise InputError("this directory holds a search of a different spec; mixing them would make the "
                             "counts meaningless", file=root, allowed="the same spec, or a new --out directory")
        return
    from simgap.experiment.single_run import software_versions

    root.mkdir(parents=True, exist_ok=True)
    tmp = meta.with_suffix(".tmp")
    tmp.write_text(json.dumps({"spec": spec.model_dump(), "results_hash": spec.results_hash(),
                               "versions": software_versions()}, indent=2, default=str))
    os.replace(tmp, meta)


@dataclass
class SearchProgress:
    strategy: str
    elapsed_s: float
    budget: Budget
    runs: int
    high_failures: int


def run_search(spec_ref: str | Path, root: Path, budget: Budget, workers: int | None, executor: str = "local",
               address: str | None = None, strategies: list[str] | None = None,
               on_progress: Callable[[SearchProgress], None] | None = None,
               report: bool = True) -> list[StrategyResult]:
    """Run (or resume) every strategy of the spec (or ``strategies``) on ``budget`` each."""
    spec, logical, _ = load_search_spec(spec_ref)
    for rung in spec.ladder:
        preflight(rung.backend, dict(rung.settings))
    names = strategies or list(spec.strategies)
    for n in names:
        if n not in STRATEGIES:
            raise InputError(f"unknown strategy '{n}'", field="strategy", allowed=", ".join(STRATEGIES))
    root = Path(root)
    runner = make_executor(executor, workers, spec.run_timeout_s, address)
    _claim(root, spec)
    space = SearchSpace(spec, logical)
    results = []
    for name in names:
        sroot = root / name
        sroot.mkdir(parents=True, exist_ok=True)
        run = StrategyRun(spec, space, make_strategy(name, space, spec), sroot, budget)
        run.resume()
        context = {"root": str(sroot), "planner": spec.planner, "cosim": spec.cosim}

        def on_result(job: Job, row: dict[str, Any], run: StrategyRun = run, name: str = name) -> None:
            run.on_result(job, row)
            if on_progress:
                fails = sum(1 for (i, k), r in run.rows.items() if k == run.high and r.get("failed"))
                on_progress(SearchProgress(name, run.elapsed(), budget, run.runs(), fails))

        runner.run(run.next_job, context, on_result)
        run._save_budget()
        results.append(summarise(sroot, name, len(spec.ladder), spec.distinct_radius))
    if report:
        from simgap.report.search_page import build_search_report

        build_search_report(root)
    return results


def search_results(root: Path) -> tuple[SearchSpec, list[StrategyResult]]:
    """The spec and each strategy's summary of a search directory."""
    root = Path(root)
    meta = root / META
    if not meta.exists():
        raise InputError("not a search directory (no search.json)", file=root, allowed="the --out of simgap search")
    spec = SearchSpec.model_validate(json.loads(meta.read_text())["spec"])
    out = [summarise(root / n, n, len(spec.ladder), spec.distinct_radius)
           for n in STRATEGIES if (root / n / "store" / "rows").exists()]
    return spec, out
