"""The README's main job: the built-in `demo` experiment (four curve scenarios of the paper's
grid, ideal against MuJoCo with the sedan and the city car), every run drawn in 2D and the
sharpest curve in 3D, ending in the HTML report."""

from __future__ import annotations

import os
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

from simgap.experiment.runner import run_experiment
from simgap.experiment.store import ResultsStore
from simgap.report.scene2d import render_run
from simgap.report.site import build_report

RENDER_3D = "curve_radius-10_angle-90/mujoco-sedan"


@dataclass
class DemoResult:
    report: Path
    runs: int
    failed: int
    wall_time_s: float


def run_demo(out: Path, workers: int | None = None, say: Callable[[str], None] = print) -> DemoResult:
    t0 = time.perf_counter()
    out = Path(out)

    def progress(p) -> None:
        if p.done + p.failed + p.skipped in (p.total, 0) or (p.done + p.failed) % 4 == 0:
            say(f"runs: {p.done} done, {p.failed} failed, {p.skipped} earlier, {p.remaining} left")

    result = run_experiment("demo", out, workers or os.cpu_count() or 1, on_progress=progress, report=False)
    say("drawing the runs")
    for run_json in sorted((out / "runs").rglob("run.json")):
        run_dir = run_json.parent
        if not (run_dir / "scene.png").exists():
            render_run(run_dir, animation=False)
    sharp = out / "runs" / RENDER_3D
    if (sharp / "run.json").exists() and not (sharp / "side_by_side.png").exists():
        from simgap.report.scene3d import render_run_3d

        say(f"rendering {RENDER_3D} in 3D")
        render_run_3d(sharp, frame_every=5)
    say("building the report")
    index = build_report(out / "runs", out / "report", store_rows=ResultsStore(out).rows())
    return DemoResult(index, result.total, result.failed, time.perf_counter() - t0)
