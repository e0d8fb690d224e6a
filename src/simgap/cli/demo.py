"""`simgap demo`: the README's main job."""

from __future__ import annotations

from pathlib import Path

import typer
from rich.console import Console

from simgap.cli.main import app


@app.command()
def demo(out: Path = typer.Option(Path("simgap-demo"), "--out", "-o", help="where to write everything")) -> None:
    """Run a small real experiment on built-in curve scenarios and write an HTML report.

    Three curve scenarios of the paper's grid run in every installed fidelity (ideal; MuJoCo
    with the sedan and the city car when that backend is installed), are compared with the
    ideal run and summarised in REPORT/index.html.

    Example: simgap demo --out simgap-demo
    """
    from simgap.experiment.demo import run_demo

    console = Console()
    result = run_demo(out, say=lambda msg: console.print(f"[dim]{msg}[/dim]"))
    console.print(f"{result.runs} runs ({result.failed} failed) in {result.wall_time_s:.1f} s")
    console.print(f"report: [bold]{result.report.resolve()}[/bold]")
    if result.failed:
        raise typer.Exit(1)
