"""Entry point of the `simgap` command: one module per command, registered here."""

from __future__ import annotations

import importlib
import signal
import sys

import typer

from simgap.errors import ENVIRONMENT_ERRORS, InputError

app = typer.Typer(
    name="simgap",
    help="Validate a motion planner across simulation fidelities: generate scenarios, "
    "run them in a 2D and a 3D world, compare, and find where they part.",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
)


# the module that registers each command: a run imports only the one asked for (the commands'
# modules together take about 2.5 s to import); no command, --help or an unknown name import all
COMMANDS = {"compare": "compare", "demo": "demo", "experiment": "experiment", "export": "export",
            "generate": "generate", "planners": "planners", "render": "render", "replay": "replay",
            "report": "report", "run": "run", "search": "search", "search-status": "search", "vehicles": "vehicles"}


@app.callback()
def _commands() -> None:
    """Keeps `simgap NAME` a command's name when only that command is registered."""


def _register(argv: list[str]) -> None:
    name = next((a for a in argv if not a.startswith("-")), None)
    for module in [COMMANDS[name]] if name in COMMANDS else sorted(set(COMMANDS.values())):
        importlib.import_module(f"simgap.cli.{module}")


def main() -> None:
    signal.signal(signal.SIGTERM, _terminated)
    try:
        _register(sys.argv[1:])
        app()
    except (SystemExit, KeyboardInterrupt):
        if not _TERMINATED:
            raise
        typer.secho("error: stopped by SIGTERM before it finished; what it was writing was not kept (an "
                    "experiment's finished runs are): run the command again", err=True, fg="red")
        sys.exit(128 + signal.SIGTERM)
    except InputError as err:
        typer.secho(f"error: {err.describe()}", err=True, fg="red")
        sys.exit(2)
    except OSError as err:
        if err.errno not in ENVIRONMENT_ERRORS:
            raise
        where = f" writing {err.filename}" if err.filename else ""
        typer.secho(f"error: {ENVIRONMENT_ERRORS[err.errno]}{where}; nothing half-written was kept: free the space "
                    "or choose another --out, then run the command again", err=True, fg="red")
        sys.exit(1)




_TERMINATED: list[int] = []


def _terminated(signum, frame) -> None:
    """The first SIGTERM stops the command as Ctrl-C does, where it is — so what it was writing is
    cleaned up, and a run in the loop lets it through (`RunInterrupted`, if the loop is loaded) —
    and the command says so; a second one ends it at once."""
    _TERMINATED.append(signum)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    loop_stops = sys.modules.get("simgap.cosim.interruptions")
    raise loop_stops.RunInterrupted() if loop_stops is not None else KeyboardInterrupt()
