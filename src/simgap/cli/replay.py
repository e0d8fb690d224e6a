"""`simgap replay`: a recorded run run again from its record alone, and whether it reproduced."""

from __future__ import annotations

import json
from pathlib import Path

import typer

from simgap.cli.console import output_console
from simgap.cli.exit_codes import ExitCode
from simgap.cli.main import app
from simgap.cli.outputs import OVERWRITE_HELP, refuse
from simgap.files import writable_directory


@app.command()
def replay(
    run_dir: Path = typer.Argument(..., help="a run directory (simgap run --out, or one of an experiment's runs)"),
    out: Path | None = typer.Option(None, "--out", "-o", help="write the replay's run directory here too",
                                       callback=writable_directory),
    as_json: bool = typer.Option(False, "--json", help="print the verdict as JSON on stdout"),
    overwrite: bool = typer.Option(False, "--overwrite", help=OVERWRITE_HELP),
) -> None:
    """Run a recorded run again from its record (scenario, vehicles, planners, settings, seed, and
    the plans' latencies where they were measured) and say whether it reproduced: the same
    fingerprint. Exit 0 when it did, 1 when it did not.

    Example: simgap replay runs/mujoco
    """
    from simgap.experiment.replay import replay as replay_run

    if out is not None and out.exists() and not overwrite and (not out.is_dir() or any(out.iterdir())):
        refuse(out, "files")
    result = replay_run(run_dir, out)
    worst = result.largest_difference()
    if as_json:
        typer.echo(json.dumps({"run": str(run_dir), "reproduced": result.reproduced,
                               "fingerprint": result.original.fingerprint,
                               "replay_fingerprint": result.replayed.fingerprint,
                               "seed": result.original.settings.seed,
                               "outcome": result.replayed.history.outcome.value,
                               "largest_difference": None if worst is None else
                               {"field": worst[0], "max": worst[1], "from_t": worst[2]}}, indent=2))
    else:
        console = output_console()
        if result.reproduced:
            console.print(f"reproduced: fingerprint {result.replayed.fingerprint} "
                          f"({result.replayed.history.outcome}, seed {result.original.settings.seed})")
        else:
            where = "" if worst is None else f"; {worst[0]} differs by up to {worst[1]:.3g} from t = {worst[2]:.1f} s"
            console.print(f"[red]not reproduced[/red]: fingerprint {result.replayed.fingerprint}, the record's "
                          f"{result.original.fingerprint} ({result.original.history.outcome} -> "
                          f"{result.replayed.history.outcome}{where})")
    if not result.reproduced:
        raise typer.Exit(ExitCode.CHECK_FAILED)
