"""`simgap demo`: the README's main job — the built-in `demo` experiment (four curve scenarios of
the paper's grid, ideal against MuJoCo with the sedan and the city car), every run drawn in 2D and
the sharpest curve in 3D, ending in the HTML report."""

from __future__ import annotations

import os
import time
from pathlib import Path

import typer

from simgap.cli.console import output_console
from simgap.cli.exit_codes import ExitCode
from simgap.cli.main import app
from simgap.files import writable_directory

RENDER_3D = "curve_radius-10_angle-90/mujoco-sedan"
# its video at one frame per step (dt = 0.1 s), to keep the demo about a minute: 12 CPU seconds
# for this run's 23.5 s against 28 at `simgap render --3d`'s 25 frames a second
DEMO_VIDEO_FPS = 10


@app.command()
def demo(out: Path = typer.Option(Path("simgap-demo"), "--out", "-o", help="where to write everything",
                                  callback=writable_directory)) -> None:
    """Run a small real experiment on built-in curve scenarios and write an HTML report.

    The built-in `demo` experiment: four curve scenarios of the paper's grid, ideal against
    MuJoCo with the sedan and the city car, run in parallel on all cores, drawn in 2D (the
    sharpest also in 3D), compared with the ideal runs and summarised in OUT/report/index.html.
    Every run is scored; the solutions' validity check, which would take as long as the runs, is
    left to `simgap experiment run demo`. Running it again resumes (finished runs are kept).

    Example: simgap demo --out simgap-demo
    """
    from simgap.experiment.runner import run_experiment
    from simgap.report.site import build_experiment_report

    console = output_console()

    def say(msg: str) -> None:
        console.print(f"[dim]{msg}[/dim]")

    def progress(p) -> None:
        if p.done + p.failed + p.skipped in (p.total, 0) or (p.done + p.failed) % 4 == 0:
            say(f"runs: {p.done} done, {p.failed} failed, {p.skipped} earlier, {p.remaining} left")

    t0 = time.perf_counter()
    result = run_experiment("demo", out, os.cpu_count() or 1, on_progress=progress, validate=False)
    say("drawing the runs")
    _draw(out, say)
    say("building the report")
    report = build_experiment_report(out)
    console.print(f"{result.total} runs ({result.failed} failed) in {time.perf_counter() - t0:.1f} s")
    if report is not None:
        console.print(f"report: [bold]{report.resolve()}[/bold]")
    if result.failed or report is None:
        raise typer.Exit(ExitCode.CHECK_FAILED)


def _draw(out: Path, say) -> None:
    """Every run in 2D (where not drawn yet), and the sharpest curve in 3D."""
    from simgap.report.scene2d import render_run

    for run_json in sorted((out / "runs").rglob("run.json")):
        if not (run_json.parent / "scene.png").exists():
            render_run(run_json.parent, animation=False)
    sharp = out / "runs" / RENDER_3D
    if (sharp / "run.json").exists() and not (sharp / "side_by_side.png").exists():
        from simgap.report.scene3d import render_run_3d
        from simgap.sim.mujoco.replay import MujocoReplay

        say(f"rendering {RENDER_3D} in 3D")
        render_run_3d(sharp, None, MujocoReplay, fps=DEMO_VIDEO_FPS)
