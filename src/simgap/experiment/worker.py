"""One job as a worker executes it: its run directory, the run (`simgap.experiment.single_run`),
and the store row the finished run becomes."""

from __future__ import annotations

import math
import time
from dataclasses import asdict
from pathlib import Path

from simgap.cosim import Outcome, Run
from simgap.evaluate.errors import comfort
from simgap.evaluate.run_scores import worst_scores
from simgap.experiment.job import Job, JobContext
from simgap.experiment.run_row import RunRow
from simgap.experiment.single_run import RunRequest, execute


def run_dir_of(root: Path, job: Job) -> Path:
    return Path(root) / "runs" / job.id.folder


def run_row(job: Job, run: Run, run_dir: Path, root: Path, job_time_s: float) -> RunRow:
    """Every scalar of a finished run: outcome, goals, excursions, comfort, scores, timings, versions."""
    outcomes = [a.outcome for a in run.agents]
    times = [a.time_to_goal_s for a in run.agents if a.time_to_goal_s is not None]
    gaps = [a.min_distance_to_traffic_m for a in run.agents if a.min_distance_to_traffic_m is not None]
    peaks = [comfort(t) for t in run.driven.values()]
    return RunRow(
        job.id, job.parameters, job.vehicle, "failed" if run.failure else "ok", run.failure or "",
        outcome=Outcome.worst(outcomes), agents=len(run.agents),
        goals_reached=outcomes.count(Outcome.GOAL_REACHED),
        time_to_goal_max_s=max(times) if len(times) == len(outcomes) and times else math.nan,
        distance_m=sum(a.distance_m for a in run.agents),
        max_road_excursion_m=max((a.max_road_excursion_m for a in run.agents), default=0.0),
        planner_failures=sum(a.planner_failures for a in run.agents),
        planner_exceptions=sum(a.planner_exceptions for a in run.agents),
        planning_mean_s=_slowest(a.planning_mean_s for a in run.agents),
        planning_p95_s=_slowest(a.planning_p95_s for a in run.agents),
        planning_max_s=_slowest(a.planning_max_s for a in run.agents),
        planning_over_budget=sum(a.planning_over_budget for a in run.agents),
        min_distance_m=min(gaps) if gaps else math.nan,
        peak_lateral_acceleration=max((p.peak_lateral_acceleration for p in peaks), default=math.nan),
        peak_jerk=max((p.peak_jerk for p in peaks), default=math.nan),
        wall_time_s=run.wall_time_s, fingerprint=run.fingerprint, run_dir=str(run_dir.relative_to(root)),
        job_time_s=job_time_s, metrics=dict(run.metrics), timings=dict(run.timings), versions=dict(run.versions),
        **asdict(worst_scores(run)))


def _slowest(values) -> float:
    """The largest of the agents' planning-time figures (NaN when no agent planned)."""
    known = [v for v in values if v is not None]
    return max(known) if known else math.nan


def execute_job(job: Job, context: JobContext) -> RunRow:
    """Run ``job`` into its run directory under ``context.root`` and return its store row."""
    started = time.perf_counter()
    run_dir = run_dir_of(context.root, job)
    scenario = job.scenario_path or (context.scenarios or {})[job.scenario]
    request = RunRequest(scenario=Path(scenario), backend=job.backend, vehicles=job.vehicle,
                         planner_vehicle=context.planner_vehicle, backend_settings=job.backend_settings,
                         planner=job.planner, cosim=job.cosim, seed=job.seed, validate=context.validate)
    run = execute(request, run_dir)
    return run_row(job, run, run_dir, context.root, time.perf_counter() - started)
