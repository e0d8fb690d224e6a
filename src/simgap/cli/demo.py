"""`simgap demo`: the README's main job."""

from __future__ import annotations

from pathlib import Path

import typer
from rich.console import Console

from simgap.cli.main import app


@app.command()
def demo(out: Path = typer.Option(Path("simgap-demo"), "--out", "-o", help="where to write everything")) -> None:
    """Run a small real experiment on built-in curve scenarios and write an HTML report.

    The built-in `demo` experiment: four curve scenarios of the paper's grid, ideal against
    MuJoCo with the sedan and the city car, run in parallel on all cores, drawn in 2D (the
    sharpest also in 3D), compared with the ideal runs and summarised in OUT/report/index.html.
    Running it again resumes (finished runs are kept).

    Example: simgap demo --out simgap-demo
    """
    from simgap.experiment.demo import run_demo

    console = Console()
    result = run_demo(out, say=lambda msg: console.print(f"[dim]{msg}[/dim]"))
    console.print(f"{result.runs} runs ({result.failed} failed) in {result.wall_time_s:.1f} s")
    console.print(f"report: [bold]{result.report.resolve()}[/bold]")
    if result.failed:
        raise typer.Exit(1)
