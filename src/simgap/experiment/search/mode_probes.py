"""The probes that tell which dimensions a strategy's violations need (see
`simgap.experiment.search.failure_modes`): for each distinct violation, a high-fidelity run per dimension
it is off nominal in, with that dimension alone moved back to nominal — the violation's own
candidate otherwise (its vehicle, planner and seed), through the search's ladder and executor.

Budgeted in runs per strategy and resumable: each probe's row goes to ``<strategy>/probes/store``
under its own key (``c00012-road_friction/high``), and a probe with a row is never run again.
Violations are probed whole, one after another, the clearest of each group that may be a mode
(vehicle, planner, what broke) before the second of any (`clearest_first`), so that a small budget
gives every group a probed member.
"""

from __future__ import annotations

from pathlib import Path

from simgap.experiment.job import Job
from simgap.experiment.knobs import KNOBS
from simgap.experiment.run_row import RunRow
from simgap.experiment.runner import clean_partial_runs
from simgap.experiment.search.failure_modes import PROBES, ProbeDimension, ProbePlan, ProbeRow, what_broke
from simgap.experiment.search.ladder import Ladder, scenario_name
from simgap.experiment.search.ledger import score_drop
from simgap.experiment.search.rows import SearchRow
from simgap.experiment.search.space import SearchSpace
from simgap.experiment.search.spec import SCORE_DROP, DimensionKind, Search
from simgap.experiment.store import ResultsStore
from simgap.planning.registry import DEFAULT_PLANNER


def probe_plan(search: Search) -> ProbePlan:
    """The dimensions of ``search`` and their nominal values: a knob's default, a parameter's."""
    dims = []
    for d in search.spec.dimensions:
        default = (KNOBS[d.name].nominal if d.kind is DimensionKind.KNOB
                   else float(search.logical.parameters[d.name].default))
        dims.append(ProbeDimension(kind=d.kind, name=d.name, low=d.low, high=d.high,
                                   nominal=min(max(default, d.low), d.high)))
    return ProbePlan(dims=dims)


def probe_name(candidate: int, dim: str) -> str:
    return f"{scenario_name(candidate)}-{dim}"


class ModeProbes:
    """The probes of one strategy's violations (``violations``: their high-fidelity rows, in the
    order found; ``ideal``: their ideal runs, by candidate), ``budget`` runs at most (those an
    earlier invocation made included): a job source for an executor, and what to do with each
    result. A probe is judged like its violation, its score drop measured against the violation's
    ideal run (for a parameter moved back, that is another road's: an approximation)."""

    def __init__(self, search: Search, space: SearchSpace, root: Path, violations: list[SearchRow], budget: int,
                 ideal: dict[int, SearchRow] | None = None):
        self.spec, self.space, self.budget, self.ideal = search.spec, space, budget, ideal or {}
        self.root = Path(root) / PROBES
        self.ladder = Ladder(search, self.root)
        self.plan = probe_plan(search)
        self.store = ResultsStore(self.root)
        self.store.prepare()
        clean_partial_runs(self.root)
        self.plan.save(Path(root))
        self.done = set(self.store.finished_keys()) if self.store.rows_dir.exists() else set()
        self.made = len(self.done)
        self.pending = [(v, i) for v in clearest_first(violations, self.plan) for i in self.plan.off_nominal(v.unit)]
        self.in_flight: dict[str, tuple[int, str]] = {}

    def next_job(self) -> Job | None:
        while self.pending and self.made < self.budget:
            row, i = self.pending.pop(0)
            dim = self.plan.dims[i].name
            job = self._job(row, i)
            if job.key in self.done:
                continue
            self.made += 1
            self.in_flight[job.key] = (row.candidate, dim)
            return job
        return None

    def _job(self, row: SearchRow, i: int) -> Job:
        unit = list(row.unit)
        unit[i] = self.plan.dims[i].nominal_unit
        c = self.space.candidate(row.candidate, unit, row.run.vehicle_ref, planner=row.run.id.planner or DEFAULT_PLANNER)
        return self.ladder.job(c, self.ladder.high, probe_name(row.candidate, self.plan.dims[i].name))

    def on_result(self, job: Job, result: RunRow) -> None:
        candidate, dim = self.in_flight.pop(job.key)
        drop = score_drop(self.ideal.get(candidate), result)
        judged = result if drop is None else result.with_columns(**{SCORE_DROP: drop})
        reason = self.spec.failure.failed(judged.columns()) if result.status == "ok" else None
        self.store.write_row(ProbeRow(result, candidate, dim, reason is not None, reason or "").as_run_row())
        self.done.add(job.key)


def clearest_first(violations: list[SearchRow], plan: ProbePlan) -> list[SearchRow]:
    """``violations`` in the order they are probed: the clearest of each group that may be a mode
    (vehicle, planner, what broke) first — the fewest dimensions off nominal, then the nearest to
    nominal: the cheapest to probe and the representative a mode would show — then the second
    clearest of each, and so on; so that a small budget gives every group a probed member."""
    def clarity(v: SearchRow) -> tuple[int, float, int]:
        return len(plan.off_nominal(v.unit)), float(plan.departure(v.unit).sum()), v.candidate

    groups: dict[tuple, list[SearchRow]] = {}
    for v in violations:
        key = (v.run.id.fidelity.vehicle, v.run.id.planner or DEFAULT_PLANNER, what_broke(v.failure_reason))
        groups.setdefault(key, []).append(v)
    ranked = [(rank, clarity(v), v) for members in groups.values()
              for rank, v in enumerate(sorted(members, key=clarity))]
    return [v for _, _, v in sorted(ranked, key=lambda t: t[:2])]
