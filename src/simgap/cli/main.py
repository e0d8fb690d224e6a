"""Entry point of the `simgap` command: one module per command, registered here."""

from __future__ import annotations

import sys

import typer

from simgap.errors import InputError

app = typer.Typer(
    name="simgap",
    help="Validate a motion planner across simulation fidelities: generate scenarios, "
    "run them in a 2D and a 3D world, compare, and find where they part.",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
)


def _register() -> None:
    from simgap.cli import (compare, demo, experiment, export, generate, planners, render, report, run,  # noqa: F401
                            search, vehicles)


def main() -> None:
    _register()
    try:
        app()
    except InputError as err:
        typer.secho(f"error: {err.describe()}", err=True, fg="red")
        sys.exit(2)

