"""`simgap render`: pictures and an animation of a finished run."""

from __future__ import annotations

from pathlib import Path

import typer

from simgap.cli.console import ProgressBars, output_console
from simgap.cli.main import app
from simgap.cli.outputs import OVERWRITE_HELP, check_pictures_out, record_pictures
from simgap.files import writable_directory


@app.command()
def render(
    run_dir: Path = typer.Argument(..., help="a run directory written by `simgap run`"),
    out: Path | None = typer.Option(None, "--out", "-o", help="where to write (default: the run directory)",
                                       callback=writable_directory),
    frame_every: int = typer.Option(3, min=1, help="one frame of the 2D animation every N steps"),
    three_d: bool = typer.Option(False, "--3d", help="also render the 3D world: chase camera and bird's-eye "
                                 "pictures, a chase-camera video (MP4) of the whole run, 3D beside 2D"),
    overwrite: bool = typer.Option(False, "--overwrite", help=OVERWRITE_HELP),
) -> None:
    """Draw the final scene with every agent's driven path (PNG) and an animation (GIF); with
    --3d, the run replayed in the MuJoCo world, offscreen, and filmed from behind the first agent's car.

    Example: simgap render runs/c10 --3d
    """
    from simgap.record import read_run
    from simgap.report import scene2d

    if three_d:
        from simgap.report import scene3d
        from simgap.sim.mujoco.graphics import check_mujoco_gl

        check_mujoco_gl()
        from simgap.sim.mujoco.replay import MujocoReplay
    folder = out or run_dir
    pictures = list(scene2d.PICTURES) + (list(scene3d.PICTURES) if three_d else [])
    check_pictures_out(folder, pictures, overwrite)
    read_run(run_dir)                     # a run that cannot be drawn is refused before the folder is made
    # said before any is drawn: a render cut short (a kill, a full disk) leaves a folder its rerun draws into again
    record_pictures(folder, run_dir, [folder / name for name in pictures])
    console = output_console()
    with ProgressBars() as bars:
        bars.update("2D animation: frames", 0, None)       # the scene's picture comes first
        written = scene2d.render_run(run_dir, out, frame_every,
                                     on_frame=lambda done, total: bars.update("2D animation: frames", done, total))
        if three_d:
            bars.update("3D video offscreen: frames", 0, None)    # the world is built and the stills taken first
            written += scene3d.render_run_3d(
                run_dir, out, MujocoReplay,
                on_frame=lambda done, total: bars.update("3D video offscreen: frames", done, total))
    for path in written:
        console.print(f"wrote [bold]{path}[/bold]")
