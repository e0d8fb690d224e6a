"""`simgap explain`: why a physical run parted from the ideal run — which of the planner's
assumptions it broke, and by how much (`simgap.experiment.attribution`)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import TYPE_CHECKING, Any

import typer
from rich.console import Console

from simgap.cli.console import output_console
from simgap.cli.main import app
from simgap.errors import InputError
from simgap.experiment import fork_server
from simgap.sim.assumptions import Assumption

if TYPE_CHECKING:
    from simgap.experiment.attribution import Attribution

ASSUMPTION_HELP = ("restore only this one of the assumptions the run broke: " + ", ".join(Assumption) +
                   " (repeatable; default: all; the others stay broken in every world, so the base holds them too)")


@app.command()
def explain(
    run_dir: Path = typer.Argument(..., help="run directory of a run in a physical world (simgap run --out)"),
    workers: int = typer.Option(2, min=1, help="processes the counterfactual runs share"),
    assumptions: list[Assumption] | None = typer.Option(
        None, "--assumption", metavar="ASSUMPTION",
        help=ASSUMPTION_HELP),
    as_json: bool = typer.Option(False, "--json", help="print the attribution as JSON on stdout"),
) -> None:
    """Rerun a run's scenario in the worlds where some of the planner's assumptions hold (its own
    seed, planner and settings) and say what each broken assumption costs: its share of the gap to
    the ideal run (max |d|, Shapley: the shares add up to the gap), whether restoring it alone fixes
    the outcome, the smallest sets that do, and the score restoring it alone gives back. A run that
    ended early is measured where it drove: the worlds whose end no answer needs stop a second past it.

    Example: simgap explain runs/c10-suv-mujoco
    """
    if workers > 1:     # the fork server loads what a run imports while this process loads the rest
        fork_server.start()
    if not (run_dir / "run.json").is_file():
        raise InputError("no run here (run.json is missing)", file=run_dir, field="RUN_DIR",
                         allowed="a run directory simgap run wrote")
    if assumptions and Assumption.VEHICLE_DYNAMICS in assumptions:
        raise InputError("vehicle_dynamics cannot be restored apart: its world is the ideal one (the base)",
                         field="assumption", allowed=", ".join(a for a in Assumption if a != Assumption.VEHICLE_DYNAMICS))
    if as_json:
        typer.echo(json.dumps(explanation(run_dir, workers, assumptions), indent=2))
        return
    print_explanation(output_console(), run_dir, workers, assumptions)


def explanation(run_dir: Path, workers: int = 2, assumptions: list[Assumption] | None = None) -> dict[str, Any]:
    """The attribution of the run in ``run_dir``, as ``--json`` prints it."""
    return _attribute(run_dir, workers, assumptions).as_json()


def print_explanation(console: Console, run_dir: Path, workers: int = 2,
                      assumptions: list[Assumption] | None = None) -> None:
    """The attribution of the run in ``run_dir``: a line per assumption, largest first, then why."""
    for line in _attribute(run_dir, workers, assumptions).lines():
        console.print(line, highlight=False, markup=False)


def _attribute(run_dir: Path, workers: int, assumptions: list[Assumption] | None) -> Attribution:
    from simgap.experiment.attribution import explain  # imported after the fork server has started

    return explain(run_dir, workers, assumptions or None)
