"""Where an experiment's time went: the seconds its runs spent in each phase, from its store.

Per fidelity (low: the ideal world; high: the physical ones): planning, physics, tyres, control,
the rest of the backend's step, monitoring, the loop's own bookkeeping, scoring, the criticality of
agent pairs, validity, writing the driven scenario, and the per-run overhead outside the loop (the scenario loaded, agents and
planners built, metrics, the run directory written) — a job's time in its worker less all of
these.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from simgap.experiment.store import ResultsStore

LOOP_PHASES = ("planning", "physics", "tyres", "control", "backend other", "monitoring", "loop other")
AFTER_LOOP = ("scoring", "criticality", "validation", "io")
PHASES = (*LOOP_PHASES, *AFTER_LOOP, "per-run overhead")


@dataclass(frozen=True)
class TimeBudget:
    """Seconds per phase summed over ``runs`` runs, and their jobs' total time in the workers."""

    runs: int
    job_s: float
    phases: dict[str, float]

    def per_run(self, phase: str) -> float:
        return self.phases[phase] / self.runs if self.runs else 0.0

    def share(self, phase: str) -> float:
        return self.phases[phase] / self.job_s if self.job_s else 0.0


def store_budget(root: Path) -> dict[str, TimeBudget]:
    """The budget of the finished runs in the store of ``root``, per fidelity ('low', 'high') and
    for 'all'."""
    store = ResultsStore(root)
    columns, _ = store.query("SELECT * FROM runs LIMIT 0")

    def total(column: str) -> str:        # a phase no run of the store had has no column
        return f"sum(coalesce({column}, 0))" if column in columns else "0"

    _, rows = store.query(
        "SELECT CASE WHEN backend = 'ideal' THEN 'low' ELSE 'high' END, count(*), sum(job_time_s), "
        f"sum(wall_time_s), sum(time_planning_s), {total('time_physics_s')}, {total('time_tyres_s')}, "
        f"{total('time_control_s')}, sum(time_execution_s), sum(time_monitoring_s), {total('time_scoring_s')}, "
        f"{total('time_criticality_s')}, {total('time_validation_s')}, {total('time_io_s')} "
        "FROM runs WHERE status = 'ok' GROUP BY 1 ORDER BY 1 DESC")
    budgets = {}
    for fid, n, job, wall, plan, phys, tyres, ctrl, execution, monitor, score, crit, valid, io in rows:
        phases = {"planning": plan, "physics": phys, "tyres": tyres, "control": ctrl,
                  "backend other": execution - phys - tyres - ctrl, "monitoring": monitor,
                  "loop other": wall - plan - execution - monitor, "scoring": score, "criticality": crit,
                  "validation": valid, "io": io, "per-run overhead": job - wall - score - crit - valid - io}
        budgets[fid] = TimeBudget(int(n), float(job), {k: float(v) for k, v in phases.items()})
    budgets["all"] = TimeBudget(sum(b.runs for b in budgets.values()), sum(b.job_s for b in budgets.values()),
                                {p: sum(b.phases[p] for b in budgets.values()) for p in PHASES})
    return budgets


def budget_lines(budgets: dict[str, TimeBudget], wall_s: float | None = None, workers: int = 1) -> list[str]:
    """The budget as a table: seconds and share per fidelity, seconds per run; with the
    experiment's wall time, the workers' time no run used."""
    fids = list(budgets)
    lines = [f"{'phase':<18}" + "".join(f"{f + ' [s]':>12}{'share':>7}" for f in fids) + f"{'per run [s]':>13}"]
    for p in PHASES:
        cells = "".join(f"{budgets[f].phases[p]:>12.1f}{100 * budgets[f].share(p):>6.1f}%" for f in fids)
        lines.append(f"{p:<18}{cells}{budgets['all'].per_run(p):>13.3f}")
    total = budgets["all"]
    lines.append(f"{'job':<18}" + "".join(f"{budgets[f].job_s:>12.1f}{100.0:>6.1f}%" for f in fids)
                 + f"{total.job_s / max(total.runs, 1):>13.3f}")
    lines.append("runs: " + ", ".join(f"{f} {budgets[f].runs}" for f in fids))
    if wall_s:
        idle = workers * wall_s - total.job_s
        lines.append(f"wall {wall_s:.1f} s x {workers} workers = {workers * wall_s:.1f} worker-s; the runs used "
                     f"{total.job_s:.1f}; set-up, dispatch, store and idle ends: {idle:.1f} "
                     f"({100 * idle / (workers * wall_s):.1f} %)")
    return lines
