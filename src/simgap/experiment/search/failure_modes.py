"""Failure modes: a search's distinct violated assumptions grouped by what broke.

A violation *needs* a dimension of the search if moving that one dimension back to its nominal
value — a reality knob's default (the ideal world's assumption), a scenario parameter's default,
each clipped to the searched range — makes its high-fidelity run stop failing *that way* (it
passes, or fails by another rule). The *probes* that find out are high-fidelity runs of the
violation with one dimension at nominal; `simgap.experiment.search.mode_probes` runs them, within
the search's budget (`simgap.experiment.search.follow_up`) and resumable, into ``<strategy>/probes/`` (a `ProbeRow` each, and the `ProbePlan`: the dimensions
and their nominal point).

A mode is a vehicle, a planner, what crossed the failure rule (`what_broke`: an outcome such as
``off_road``, ``collision``, or a metric's name) and the dimensions needed. Each is reported with
its count, the range of every dimension over its members and its representative: the clearest
member, the one closest to nominal in the knobs (then in every dimension) that still fails.
Only violations whose probes are all done are grouped (a search reports no other).
"""

from __future__ import annotations

import json
import re
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np
from pydantic import BaseModel

from simgap.experiment.run_row import RunRow
from simgap.experiment.search.rows import SearchRow
from simgap.experiment.search.spec import DimensionKind
from simgap.experiment.store import ResultsStore
from simgap.files import atomic_write_text
from simgap.planning.registry import DEFAULT_PLANNER

PROBES = "probes"              # the probes' directory in a strategy's
PLAN = "plan.json"             # ... and their plan in it
AT_NOMINAL = 1e-6              # a dimension this close to nominal (normalised) is not off it


class ProbeDimension(BaseModel):
    """A continuous dimension of the search (`Dimension`'s fields) and its nominal value."""

    kind: DimensionKind        # written as its value: param or knob
    name: str
    low: float
    high: float
    nominal: float             # in the dimension's unit, clipped to [low, high]

    @property
    def nominal_unit(self) -> float:
        return 0.0 if self.high == self.low else (self.nominal - self.low) / (self.high - self.low)


class ProbePlan(BaseModel):
    """The dimensions a strategy's violations are probed in (``probes/plan.json``)."""

    dims: list[ProbeDimension]

    def departure(self, unit: tuple[float, ...]) -> np.ndarray:
        """How far the point ``unit`` lies from nominal in each dimension (normalised)."""
        return np.abs(np.asarray(unit, dtype=float) - [d.nominal_unit for d in self.dims])

    def off_nominal(self, unit: tuple[float, ...]) -> list[int]:
        """The dimensions in which the point ``unit`` is not at nominal."""
        return [int(i) for i in np.flatnonzero(self.departure(unit) > AT_NOMINAL)]

    def save(self, root: Path) -> None:
        atomic_write_text(Path(root) / PROBES / PLAN, self.model_dump_json(indent=2))

    @classmethod
    def load(cls, root: Path) -> ProbePlan | None:
        path = Path(root) / PROBES / PLAN
        return cls.model_validate(json.loads(path.read_text())) if path.exists() else None


@dataclass(frozen=True)
class ProbeRow:
    """A probe's run: its store row, the violation it probes (``probe_of``: its candidate), the
    dimension moved to nominal, and whether it failed by the spec's rule and why."""

    run: RunRow
    probe_of: int
    dim: str
    failed: bool
    failure_reason: str

    @property
    def ok(self) -> bool:
        return self.run.status == "ok"

    def as_run_row(self) -> RunRow:
        return self.run.with_columns(probe_of=self.probe_of, probe_dim=self.dim, failed=self.failed,
                                     failure_reason=self.failure_reason)

    @classmethod
    def of(cls, row: RunRow) -> ProbeRow:
        extra = dict(row.extra)
        probe_of, dim = int(extra.pop("probe_of")), str(extra.pop("probe_dim"))
        failed, reason = bool(extra.pop("failed", False)), str(extra.pop("failure_reason", "") or "")
        return cls(replace(row, extra=extra), probe_of, dim, failed, reason)


def read_probe_rows(root: Path) -> list[ProbeRow]:
    """The probes a strategy's directory holds."""
    store = ResultsStore(Path(root) / PROBES)
    return [ProbeRow.of(r) for r in store.run_rows()] if store.rows_dir.exists() else []


def what_broke(reason: str) -> str:
    """What crossed the failure rule, from the reason a row gives: the outcome of a missed goal
    (``off_road``), ``collision``, or the metric's name (``max_lane_excursion_m 0.3 > 0.1``)."""
    missed = re.fullmatch(r"goal missed \((.+)\)", reason.strip())
    if missed:
        return missed.group(1)
    return reason.split(" ", 1)[0] if reason else "unknown"


class FailureMode(BaseModel):
    """Violations that broke the same way: the driver, what crossed the rule, the dimensions each
    needs."""

    vehicle: str
    planner: str
    broke: str
    needs: list[str]
    count: int
    candidates: list[int]
    ranges: dict[str, tuple[float, float]]       # every dimension: (least, most) over the members
    representative: int                          # the clearest member's candidate ...
    representative_run: str                      # ... its high-fidelity run directory (in the strategy's)
    representative_values: dict[str, float]      # ... and its point

    @property
    def label(self) -> str:
        return f"{self.broke} needing {' + '.join(self.needs) or 'no single dimension'} ({self.vehicle}, {self.planner})"


def values_of(row: SearchRow, plan: ProbePlan) -> dict[str, float]:
    """A violation's value in each dimension of ``plan``."""
    return {d.name: float((row.run.parameters if d.kind is DimensionKind.PARAMETER else row.knobs).get(d.name, d.nominal))
            for d in plan.dims}


def needed(row: SearchRow, probes: dict[tuple[int, str], ProbeRow], plan: ProbePlan) -> list[str] | None:
    """The dimensions ``row``'s violation needs, or None while a probe is missing or errored."""
    broke, out = what_broke(row.failure_reason), []
    for i in plan.off_nominal(row.unit):
        p = probes.get((row.candidate, plan.dims[i].name))
        if p is None or not p.ok:
            return None
        if not (p.failed and what_broke(p.failure_reason) == broke):
            out.append(plan.dims[i].name)
    return out


def group_modes(violations: list[SearchRow], probes: list[ProbeRow], plan: ProbePlan) -> list[FailureMode]:
    """The modes of ``violations`` (high-fidelity rows) whose probes are all done, the most common first."""
    by_probe = {(p.probe_of, p.dim): p for p in probes}
    groups: dict[tuple, list[SearchRow]] = {}
    for row in violations:
        needs = needed(row, by_probe, plan)
        if needs is None:
            continue
        key = (row.run.id.fidelity.vehicle, row.run.id.planner or DEFAULT_PLANNER, what_broke(row.failure_reason),
               tuple(needs))
        groups.setdefault(key, []).append(row)
    knob_dims = [i for i, d in enumerate(plan.dims) if d.kind is DimensionKind.KNOB]
    modes = []
    for (vehicle, planner, broke, needs), rows in groups.items():
        def departure(r: SearchRow) -> tuple[float, float, int]:
            off = plan.departure(r.unit)
            return float(off[knob_dims].sum()), float(off.sum()), r.candidate
        best = min(rows, key=departure)
        values = [values_of(r, plan) for r in rows]
        modes.append(FailureMode(
            vehicle=vehicle, planner=planner, broke=broke, needs=list(needs), count=len(rows),
            candidates=[r.candidate for r in rows],
            ranges={d.name: (min(v[d.name] for v in values), max(v[d.name] for v in values)) for d in plan.dims},
            representative=best.candidate, representative_run=str(best.run.run_dir or ""),
            representative_values=values_of(best, plan)))
    return sorted(modes, key=lambda m: (-m.count, m.vehicle, m.broke, m.needs))

