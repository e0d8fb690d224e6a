"""The probes that tell which dimensions a strategy's violations need (see
`simgap.experiment.search.failure_modes`): for each distinct violation, a high-fidelity run per dimension
it is off nominal in, with that dimension alone moved back to nominal — the violation's own
candidate otherwise (its vehicle, planner and seed), through the search's ladder and executor.

Resumable: each probe's row goes to ``<strategy>/probes/store`` under its own key
(``c00012-road_friction/high``), and a probe with a row is never run again. Violations are probed
whole, in the order `simgap.experiment.search.follow_up` plans within the search's budget.
"""

from __future__ import annotations

from pathlib import Path

from simgap.experiment.job import Job
from simgap.experiment.knobs import KNOBS
from simgap.experiment.run_row import RunRow
from simgap.experiment.runner import clean_partial_runs
from simgap.experiment.search.failure_modes import PROBES, ProbeDimension, ProbePlan, ProbeRow
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
    """The probes of one strategy's violations (``ideal``: their ideal runs, by candidate): the jobs
    of a violation's probes not run yet (`jobs`), and what to do with each result. A probe is
    judged like its violation, its score drop measured against the violation's ideal run (for a
    parameter moved back, that is another road's: an approximation)."""

    def __init__(self, search: Search, space: SearchSpace, root: Path, ideal: dict[int, SearchRow] | None = None):
        self.spec, self.space, self.ideal = search.spec, space, ideal or {}
        self.root = Path(root) / PROBES
        self.ladder = Ladder(search, self.root)
        self.plan = probe_plan(search)
        self.store = ResultsStore(self.root)
        self.store.prepare()
        clean_partial_runs(self.root)
        self.plan.save(Path(root))
        self.done = set(self.store.finished_keys()) if self.store.rows_dir.exists() else set()
        self.in_flight: dict[str, tuple[int, str]] = {}

    def jobs(self, row: SearchRow) -> list[Job]:
        """The probes of the violation ``row`` (its high-fidelity row) not run yet: one per
        dimension it is off nominal in."""
        out = []
        for i in self.plan.off_nominal(row.unit):
            job = self._job(row, i)
            if job.key not in self.done:
                self.in_flight[job.key] = (row.candidate, self.plan.dims[i].name)
                out.append(job)
        return out

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

