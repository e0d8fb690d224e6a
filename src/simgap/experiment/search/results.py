"""What a search found, read from its directory alone: per strategy, what it spent, its violated
assumptions (a high-fidelity failure whose ideal run passes) before and after de-duplication, and
its high-fidelity runs — computed here from its typed rows (`SearchRow`), drawn by
`simgap.report.search_page` and exported by ``simgap export --violations``."""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from pydantic import BaseModel, ConfigDict, Field

from simgap.errors import InputError, validated
from simgap.evaluate.odds import Rate
from simgap.evaluate.run_metrics import RUN_METRICS
from simgap.experiment.attribution import Attribution, read_explanation
from simgap.experiment.replay import reproduce_command
from simgap.experiment.search.budget import Budget
from simgap.experiment.search.confirmation import reproduction
from simgap.experiment.search.failure_modes import FailureMode, ProbePlan, group_modes, needed, read_probe_rows
from simgap.experiment.search.rows import SearchRow, read_search_rows
from simgap.experiment.search.spec import STRATEGIES, DimensionKind, SearchSpec
from simgap.files import atomic_write_text, read_json_model
from simgap.planning.registry import DEFAULT_PLANNER

META = "search.json"          # the search's spec and results hash, in its directory (`SearchMeta`)


class StrategyFindings(BaseModel):
    """What one strategy of a search found, as its directory keeps it beside the spec (None: a
    count an older simgap did not keep; ``reported`` since 2026-12-02)."""

    model_config = ConfigDict(frozen=True)
    runs: int | None = None
    violations: int | None = None
    distinct: int | None = None
    scenarios: int | None = None
    reported: int | None = None
    modes: tuple[dict[str, Any], ...] = ()      # each a `FailureMode`, dumped


class SearchMeta(BaseModel):
    """A search directory's record of its spec (`META`): the spec as dumped (validated as a
    `SearchSpec` where it is used again), its results hash, the versions that ran it and what each
    strategy found."""

    model_config = ConfigDict(frozen=True)
    spec: dict[str, Any]
    results_hash: str | None = None
    versions: dict[str, str] = Field(default_factory=dict)
    findings: dict[str, StrategyFindings] = Field(default_factory=dict)

    @classmethod
    def read(cls, root: Path) -> SearchMeta:
        """The meta of the search in ``root``, or an `InputError` naming the file and the field."""
        path = root / META
        if not path.exists():
            raise InputError("not a search directory (no search.json)", file=root, allowed="the --out of simgap search")
        return read_json_model(path, cls, "search's record of its spec")

    def write(self, root: Path) -> None:
        atomic_write_text(root / META, self.model_dump_json(indent=2))


@dataclass(frozen=True)
class Violation:
    """A distinct violated assumption: a candidate whose high-fidelity run failed and whose ideal
    run passed — its search dimensions, both runs' rows (metrics included) and where it lies."""

    strategy: str
    row: SearchRow                     # the high-fidelity run
    ideal_row: SearchRow               # ... and the ideal run, which passed
    run_dir: Path                      # the high-fidelity run's directory
    scenario_xml: Path | None          # the candidate's CommonRoad scenario
    reproduces: Rate | None = None     # in how many of its seeds it failed in high fidelity (confirmation)
    explanation: Attribution | None = None   # which of the planner's assumptions it broke (simgap explain)

    @property
    def candidate(self) -> int:
        return self.row.candidate

    @property
    def scenario(self) -> str:
        return self.row.run.id.scenario

    @property
    def vehicle(self) -> str:
        return self.row.run.id.fidelity.vehicle

    @property
    def planner(self) -> str:
        return self.row.run.id.planner or DEFAULT_PLANNER

    @property
    def reproduce(self) -> str:
        """The command that runs its high-fidelity run again, bit for bit (`simgap replay`)."""
        return reproduce_command(self.run_dir)

    def facts(self, spec: SearchSpec) -> dict[str, Any]:
        """What made it a violation, as plain data: the search dimensions (value and range), the
        driver, why the high-fidelity run failed, and both runs' outcome and metrics."""
        watched = list(RUN_METRICS) + [spec.objective, *spec.failure.above, *spec.failure.below] + [
            "goals_reached", "max_road_excursion_m", "min_distance_m", "peak_lateral_acceleration", "peak_jerk"]

        def run(row: SearchRow) -> dict[str, Any]:
            r = row.run
            return {"fidelity": r.id.fidelity.label, "outcome": None if r.outcome is None else str(r.outcome),
                    "metrics": {k: _plain(r.metrics[k] if k in r.metrics else getattr(r, k))
                                for k in dict.fromkeys(watched) if k in r.metrics or hasattr(r, k)}}

        values = {DimensionKind.PARAMETER: self.row.run.parameters, DimensionKind.KNOB: self.row.knobs}
        return {"search": spec.name, "logical": spec.logical, "strategy": self.strategy, "candidate": self.candidate,
                "dimensions": [{"kind": d.kind.value, "name": d.name, "value": values[d.kind][d.name],
                                "range": [d.low, d.high]}
                               for d in spec.dimensions if d.name in values[d.kind]],
                "vehicle": self.vehicle, "planner": self.planner, "failure": self.row.failure_reason,
                "high_fidelity": run(self.row), "ideal": run(self.ideal_row), "reproduce": self.reproduce,
                "reproduces": None if self.reproduces is None else
                {"failed": self.reproduces.k, "seeds": self.reproduces.n, "low": self.reproduces.low,
                 "high": self.reproduces.high},
                "explanation": None if self.explanation is None else self.explanation.as_json()}


def _plain(value: Any) -> Any:
    """A store value as JSON has it (NaN as null)."""
    if isinstance(value, float) and math.isnan(value):
        return None
    return value.item() if hasattr(value, "item") else value


@dataclass(frozen=True)
class FollowUpLeft:
    """What a strategy's share left undone: distinct violations it found and did not probe (not
    reported), reported ones it did not explain, and what following each up would cost."""

    unprobed: int
    to_probe: Budget
    unexplained: int
    to_explain: Budget


@dataclass
class StrategyResult:
    name: str
    runs: int = 0
    high_runs: int = 0
    high_failures: int = 0
    violations: int = 0
    distinct: int = 0
    scenarios: int = 0                # distinct scenarios (road, start, vehicle, planner) among the violations:
                                      # two within the distinct radius of each other in the scenario's own
                                      # (normalised) parameters are one, as two such violations are
    errors: int = 0
    wall_s: float = 0.0
    cpu_s: float = 0.0
    curve: list[tuple[float, int]] = field(default_factory=list)   # (elapsed s, distinct violations so far)
    found: list[Violation] = field(default_factory=list)            # the distinct violations, first found first
    reported: list[Violation] = field(default_factory=list)         # ... those probed, the search's findings
    modes: list[FailureMode] = field(default_factory=list)          # ... grouped by what broke (`failure_modes`)
    left: FollowUpLeft | None = None    # what the share left undone (known to the search that just ran)

    @property
    def per_cpu_hour(self) -> float:
        return self.distinct / (self.cpu_s / 3600.0) if self.cpu_s > 0 else 0.0


def _new(point: tuple[float, ...], driver: str, kept: list[tuple[tuple[float, ...], str]], radius: float) -> bool:
    """Whether ``point`` lies at least ``radius`` from every point ``kept`` for the same ``driver``."""
    return all(d != driver or math.dist(point, p) >= radius for p, d in kept)


def summarise(root: Path, name: str, ladder_len: int, radius: float) -> StrategyResult:
    """What a strategy found, from its store alone."""
    rows = read_search_rows(root)
    high, res = ladder_len - 1, StrategyResult(name)
    budget = root / "budget.json"
    res.wall_s = json.loads(budget.read_text()).get("spent_s", 0.0) if budget.exists() else 0.0
    by_candidate: dict[int, dict[int, SearchRow]] = {}
    for r in rows:
        by_candidate.setdefault(r.candidate, {})[r.rung] = r
        res.runs += r.ideal_of is None
        res.cpu_s += float(r.run.job_time_s or r.run.wall_time_s or 0.0)
        res.errors += not r.ok
    found: list[tuple[float, tuple[float, ...], str, int]] = []
    for index, runs in by_candidate.items():
        h = runs.get(high)
        if h is None or not h.ok:
            continue
        res.high_runs += 1
        if not h.failed:
            continue
        res.high_failures += 1
        ideal = runs.get(0)
        if ideal is None or not ideal.ok or ideal.failed:
            continue
        res.violations += 1
        driver = f"{h.run.id.fidelity.vehicle}|{h.run.id.planner or DEFAULT_PLANNER}"
        found.append((max(h.elapsed_s, ideal.elapsed_s), h.unit, driver, index))
    distinct: list[tuple[tuple[float, ...], str]] = []
    scenarios: list[tuple[tuple[float, ...], str]] = []
    for when, unit, driver, index in sorted(found):
        if _new(unit, driver, distinct, radius):
            distinct.append((unit, driver))
            res.curve.append((when, len(distinct)))
            res.found.append(_violation(root, name, by_candidate[index][high], by_candidate[index][0]))
        # the scenario's parameters lead the point, its knobs follow (`SearchSpace`)
        scenario = unit[:len(unit) - len(by_candidate[index][high].knobs)]
        if _new(scenario, driver, scenarios, radius):
            scenarios.append((scenario, driver))
    res.distinct = len(distinct)
    res.scenarios = len(scenarios)
    plan = ProbePlan.load(root)
    if plan is not None:
        probes = read_probe_rows(root)
        by_probe = {(p.probe_of, p.dim): p for p in probes}
        res.reported = [v for v in res.found if needed(v.row, by_probe, plan) is not None]
        res.modes = group_modes([v.row for v in res.reported], probes, plan)
    return res


def _violation(root: Path, strategy: str, high: SearchRow, ideal: SearchRow) -> Violation:
    scenario = root / "scenarios" / high.run.id.scenario
    run_dir = root / str(high.run.run_dir)
    return Violation(strategy, high, ideal, run_dir, next(iter(sorted(scenario.glob("*.xml"))), None),
                     reproduction(root, high), read_explanation(run_dir))


@dataclass(frozen=True)
class HighRun:
    """A finished high-fidelity run of a search, with its ideal verdict: ``violation`` — it failed
    and its ideal run passed; ``ideal_failed`` — its ideal run failed too."""

    row: SearchRow
    violation: bool
    ideal_failed: bool


@dataclass
class SearchResults:
    """What a search directory holds: its spec, each strategy's summary and, per strategy, its
    high-fidelity runs with their ideal verdicts."""

    root: Path
    spec: SearchSpec
    strategies: list[StrategyResult]
    high_rows: dict[str, list[HighRun]]


def search_results(root: Path) -> SearchResults:
    """The spec, each strategy's summary and its high-fidelity runs, of a search directory."""
    root = Path(root)
    spec = validated(SearchSpec, SearchMeta.read(root).spec, file=root / META, prefix="spec")
    names = [n for n in STRATEGIES if (root / n / "store" / "rows").exists()]
    high = len(spec.ladder) - 1
    return SearchResults(root, spec, [summarise(root / n, n, len(spec.ladder), spec.distinct_radius) for n in names],
                         {n: _high_runs(read_search_rows(root / n), high) for n in names})


def _high_runs(rows: list[SearchRow], high: int) -> list[HighRun]:
    """The finished high-fidelity runs of a strategy, each with its ideal verdict."""
    ideal = {r.candidate: r for r in rows if r.rung == 0}
    out = []
    for r in rows:
        if r.rung == high and r.ok:
            i = ideal.get(r.candidate)
            ideal_ok = i is not None and i.ok
            ideal_failed = i is not None and i.ok and i.failed
            out.append(HighRun(r, r.failed and ideal_ok and not ideal_failed, ideal_failed))
    return out
