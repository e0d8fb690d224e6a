"""One run of an experiment, as a worker executes it, and the store row it becomes."""

from __future__ import annotations

import math
import time
from pathlib import Path
from typing import Any

from simgap.cosim import CosimSettings, Run
from simgap.experiment.single_run import RunRequest, execute
from simgap.experiment.spec import Job
from simgap.planning.frenet import FrenetSettings


def run_dir_of(root: Path, job: Job) -> Path:
    path = Path(root) / "runs" / job.scenario / job.fidelity.replace("/", "-")
    return path / f"r{job.repeat}" if job.key.endswith(f"/r{job.repeat}") else path


def job_columns(job: Job) -> dict[str, Any]:
    cols: dict[str, Any] = {"key": job.key, "scenario": job.scenario, "fidelity": job.fidelity,
                            "backend": job.backend, "vehicle": job.vehicle, "controller": job.controller or "",
                            "repeat": job.repeat, "seed": job.seed}
    cols |= {f"param_{k}": float(v) for k, v in job.parameters.items()}
    return cols


def run_row(job: Job, run: Run, run_dir: Path, root: Path) -> dict[str, Any]:
    """Every scalar of a finished run: outcome, goals, excursions, comfort, timings, versions."""
    from simgap.evaluate.errors import comfort

    outcomes = [a.outcome for a in run.agents]
    worst = next((o for o in outcomes if o != "goal_reached"), "goal_reached")
    times = [a.time_to_goal_s for a in run.agents if a.time_to_goal_s is not None]
    gaps = [a.min_distance_to_traffic_m for a in run.agents if a.min_distance_to_traffic_m is not None]
    peaks = [comfort(t) for t in run.driven.values()]
    row = job_columns(job) | {
        "status": "failed" if run.failure else "ok", "failure": run.failure or "",
        "outcome": worst, "agents": len(run.agents), "goals_reached": outcomes.count("goal_reached"),
        "time_to_goal_max_s": max(times) if len(times) == len(outcomes) and times else math.nan,
        "distance_m": sum(a.distance_m for a in run.agents),
        "max_road_excursion_m": max((a.max_road_excursion_m for a in run.agents), default=0.0),
        "planner_failures": sum(a.planner_failures for a in run.agents),
        "min_distance_m": min(gaps) if gaps else math.nan,
        "peak_lateral_acceleration": max((p.peak_lateral_acceleration for p in peaks), default=math.nan),
        "peak_jerk": max((p.peak_jerk for p in peaks), default=math.nan),
        "wall_time_s": run.wall_time_s, "fingerprint": run.fingerprint,
        "run_dir": str(run_dir.relative_to(root)),
    }
    row |= _run_metrics(job, run)
    row |= {f"time_{phase}_s": float(v) for phase, v in run.timings.items()}
    row |= {f"version_{name}": v for name, v in run.versions.items()}
    return row


def _run_metrics(job: Job, run: Run) -> dict[str, float]:
    from simgap.evaluate.run_metrics import run_metrics
    from simgap.scenario import load_scenario

    scenario, problems = load_scenario(run.scenario_path)
    return run_metrics(run, scenario, problems, float(job.backend_settings.get("road_friction", 1.0)))


def execute_job(job: Job, context: dict[str, Any]) -> dict[str, Any]:
    """Run ``job`` into its run directory under ``context['root']`` and return its store row."""
    started = time.perf_counter()
    root = Path(context["root"])
    run_dir = run_dir_of(root, job)
    cosim = dict(context.get("cosim") or {}) | dict(job.cosim)
    request = RunRequest(scenario=Path(job.scenario_path or context["scenarios"][job.scenario]),
                         backend=job.backend, vehicles=job.vehicle, backend_settings=dict(job.backend_settings),
                         planner=FrenetSettings.from_mapping(context.get("planner")),
                         cosim=CosimSettings(**cosim), seed=job.seed)
    run = execute(request, run_dir)
    row = run_row(job, run, run_dir, root)
    row["job_time_s"] = time.perf_counter() - started
    return row
