"""`simgap render`: pictures and an animation of a finished run."""

from __future__ import annotations

from pathlib import Path
from typing import Optional

import typer
from rich.console import Console

from simgap.cli.main import app


@app.command()
def render(
    run_dir: Path = typer.Argument(..., help="a run directory written by `simgap run`"),
    out: Optional[Path] = typer.Option(None, "--out", "-o", help="where to write (default: the run directory)"),
    frame_every: int = typer.Option(3, min=1, help="one animation frame every N steps"),
    three_d: bool = typer.Option(False, "--3d", help="also render the 3D world (chase, bird's-eye, animation)"),
) -> None:
    """Draw the final scene with every agent's driven path (PNG) and an animation (GIF).

    Example: simgap render runs/c10
    """
    from simgap.report.scene2d import render_run

    console = Console()
    with console.status("rendering the 2D scene"):
        written = render_run(run_dir, out, frame_every)
    if three_d:
        from simgap.report.scene3d import render_run_3d

        with console.status("rendering the 3D world offscreen"):
            written += render_run_3d(run_dir, out, frame_every)
    for path in written:
        console.print(f"wrote [bold]{path}[/bold]")
