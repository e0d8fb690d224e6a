"""What a search found, read from its directory alone: per strategy, what it spent, its violated
assumptions (a high-fidelity failure whose ideal run passes) before and after de-duplication, and
its high-fidelity runs — computed here, drawn by `simgap.report.search_page`."""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from simgap.errors import InputError
from simgap.evaluate.run_metrics import RUN_METRICS
from simgap.experiment.search_spec import STRATEGIES, SearchSpec
from simgap.experiment.store import ResultsStore
from simgap.planning.registry import DEFAULT_PLANNER

META = "search.json"          # the search's spec and results hash, in its directory


@dataclass(frozen=True)
class Violation:
    """A distinct violated assumption: a candidate whose high-fidelity run failed and whose ideal
    run passed — its search dimensions, the run's row (metrics included) and where it lies."""

    strategy: str
    candidate: int
    parameters: dict[str, float]       # the logical scenario's parameters
    knobs: dict[str, float]            # the reality knobs
    vehicle: str
    planner: str
    reason: str                        # why the high-fidelity run failed, by the spec's failure rule
    row: dict[str, Any]                # the high-fidelity run's store row
    ideal_row: dict[str, Any]          # ... and the ideal run's, which passed
    run_dir: Path                      # the high-fidelity run's directory
    scenario_xml: Path | None          # the candidate's CommonRoad scenario

    def facts(self, spec: SearchSpec) -> dict[str, Any]:
        """What made it a violation, as plain data: the search dimensions (value and range), the
        driver, why the high-fidelity run failed, and both runs' outcome and metrics."""
        watched = list(RUN_METRICS) + [spec.objective, *spec.failure.above, *spec.failure.below] + [
            "goals_reached", "max_road_excursion_m", "min_distance_m", "peak_lateral_acceleration", "peak_jerk"]

        def run(row: dict[str, Any]) -> dict[str, Any]:
            return {"fidelity": row.get("fidelity"), "outcome": row.get("outcome"),
                    "metrics": {k: _plain(row[k]) for k in dict.fromkeys(watched) if k in row}}

        values = {"param": self.parameters, "knob": self.knobs}
        return {"search": spec.name, "logical": spec.logical, "strategy": self.strategy, "candidate": self.candidate,
                "dimensions": [{"kind": kind, "name": name, "value": values[kind][name], "range": [low, high]}
                               for kind, name, low, high in spec.dimensions if name in values[kind]],
                "vehicle": self.vehicle, "planner": self.planner, "failure": self.reason,
                "high_fidelity": run(self.row), "ideal": run(self.ideal_row)}


def _plain(value: Any) -> Any:
    """A store value as JSON has it (NaN as null)."""
    if isinstance(value, float) and math.isnan(value):
        return None
    return value.item() if hasattr(value, "item") else value


@dataclass
class StrategyResult:
    name: str
    runs: int = 0
    high_runs: int = 0
    high_failures: int = 0
    violations: int = 0
    distinct: int = 0
    scenarios: int = 0                # distinct scenarios (road, start, vehicle, planner) among the violations
    errors: int = 0
    wall_s: float = 0.0
    cpu_s: float = 0.0
    curve: list[tuple[float, int]] = field(default_factory=list)   # (elapsed s, distinct violations so far)
    found: list[Violation] = field(default_factory=list)            # the distinct violations, first found first

    @property
    def per_cpu_hour(self) -> float:
        return self.distinct / (self.cpu_s / 3600.0) if self.cpu_s > 0 else 0.0


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
    found: list[tuple[float, tuple[float, ...], str, int]] = []
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
        driver = f"{h['vehicle']}|{h.get('planner') or DEFAULT_PLANNER}"
        scenarios.add((driver,) + tuple(sorted((k, v) for k, v in h.items() if k.startswith("param_"))))
        when = max(float(h["elapsed_s"]), float(ideal["elapsed_s"]))
        unit = tuple(float(h[k]) for k in sorted((k for k in h if k.startswith("unit_")), key=lambda k: int(k[5:])))
        found.append((when, unit, driver, index))
    distinct: list[tuple[tuple[float, ...], str]] = []
    for when, unit, driver, index in sorted(found):
        if all(d != driver or math.dist(unit, u) >= radius for u, d in distinct):
            distinct.append((unit, driver))
            res.curve.append((when, len(distinct)))
            res.found.append(_violation(root, name, by_candidate[index][high], by_candidate[index][0]))
    res.distinct = len(distinct)
    res.scenarios = len(scenarios)
    return res


def _violation(root: Path, strategy: str, high: dict[str, Any], ideal: dict[str, Any]) -> Violation:
    return Violation(
        strategy, int(high["candidate"]), {k[6:]: float(v) for k, v in high.items() if k.startswith("param_")},
        {k[5:]: float(v) for k, v in high.items() if k.startswith("knob_")}, str(high["vehicle"]),
        str(high.get("planner") or DEFAULT_PLANNER), str(high.get("failure_reason") or ""), dict(high), dict(ideal),
        root / str(high["run_dir"]), next(iter(sorted((root / "scenarios" / str(high["scenario"])).glob("*.xml"))), None))


@dataclass
class SearchResults:
    """What a search directory holds: its spec, each strategy's summary and, per strategy, its
    high-fidelity runs (each row with ``violation``: it passed in the ideal world; and
    ``ideal_failed``: it failed there too)."""

    root: Path
    spec: SearchSpec
    strategies: list[StrategyResult]
    high_rows: dict[str, list[dict[str, Any]]]

def search_results(root: Path) -> SearchResults:
    """The spec, each strategy's summary and its high-fidelity runs, of a search directory."""
    root = Path(root)
    meta = root / META
    if not meta.exists():
        raise InputError("not a search directory (no search.json)", file=root, allowed="the --out of simgap search")
    spec = SearchSpec.model_validate(json.loads(meta.read_text())["spec"])
    names = [n for n in STRATEGIES if (root / n / "store" / "rows").exists()]
    high = len(spec.ladder) - 1
    return SearchResults(root, spec, [summarise(root / n, n, len(spec.ladder), spec.distinct_radius) for n in names],
                         {n: _high_rows(ResultsStore(root / n).rows(), high) for n in names})


def _high_rows(rows: list[dict[str, Any]], high: int) -> list[dict[str, Any]]:
    """The finished high-fidelity runs of a strategy, each marked with its ideal verdict."""
    ideal = {int(r["candidate"]): r for r in rows if int(r["rung"]) == 0}
    out = []
    for r in rows:
        if int(r["rung"]) == high and r.get("status") == "ok":
            i = ideal.get(int(r["candidate"]))
            ideal_ok = i is not None and i.get("status") == "ok"
            out.append(dict(r) | {"violation": bool(r.get("failed")) and ideal_ok and not i.get("failed"),
                                  "ideal_failed": ideal_ok and bool(i.get("failed"))})
    return out
