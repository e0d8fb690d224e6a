"""`simgap render`: pictures and an animation of a finished run."""

from __future__ import annotations

from pathlib import Path
from typing import Optional

import typer

from simgap.cli.console import output_console
from simgap.cli.main import app
from simgap.cli.outputs import OVERWRITE_HELP, check_pictures_out, record_pictures
from simgap.files import writable_directory


@app.command()
def render(
    run_dir: Path = typer.Argument(..., help="a run directory written by `simgap run`"),
    out: Optional[Path] = typer.Option(None, "--out", "-o", help="where to write (default: the run directory)",
                                       callback=writable_directory),
    frame_every: int = typer.Option(3, min=1, help="one animation frame every N steps"),
    three_d: bool = typer.Option(False, "--3d", help="also render the 3D world (chase, bird's-eye, animation)"),
    overwrite: bool = typer.Option(False, "--overwrite", help=OVERWRITE_HELP),
) -> None:
    """Draw the final scene with every agent's driven path (PNG) and an animation (GIF).

    Example: simgap render runs/c10
    """
    from simgap.report import scene2d

    if three_d:
        from simgap.report import scene3d
        from simgap.sim.mujoco.graphics import check_mujoco_gl

        check_mujoco_gl()
        from simgap.sim.mujoco.replay import MujocoReplay
    folder = out or run_dir
    check_pictures_out(folder, list(scene2d.PICTURES) + (list(scene3d.PICTURES) if three_d else []), overwrite)
    console = output_console()
    with console.status("rendering the 2D scene"):
        written = scene2d.render_run(run_dir, out, frame_every)
    if three_d:
        with console.status("rendering the 3D world offscreen"):
            written += scene3d.render_run_3d(run_dir, out, frame_every, MujocoReplay)
    record_pictures(folder, run_dir, written)
    for path in written:
        console.print(f"wrote [bold]{path}[/bold]")
