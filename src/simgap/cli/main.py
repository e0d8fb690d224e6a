"""Entry point of the `simgap` command: one module per command, registered here."""

from __future__ import annotations

import faulthandler
import importlib
import os
import signal
import sys
import tempfile
import traceback
from typing import NoReturn

import typer

from simgap.cli.exit_codes import EXIT_CODES_HELP, ExitCode
from simgap.errors import ENVIRONMENT_ERRORS, InputError

app = typer.Typer(
    name="simgap",
    help="Validate a motion planner across simulation fidelities: generate scenarios, "
    "run them in a 2D and a 3D world, compare, and find where they part.",
    epilog=EXIT_CODES_HELP,
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
    rich_markup_mode=None,          # click's help: an option's name is never cut, at any width
)


# the module that registers each command: a run imports only the one asked for (the commands'
# modules together take about 2.5 s to import); no command, --help or an unknown name import all
COMMANDS = {"compare": "compare", "demo": "demo", "experiment": "experiment", "explain": "explain", "export": "export",
            "generate": "generate", "maps": "maps", "planners": "planners", "render": "render", "replay": "replay",
            "report": "report", "run": "run", "search": "search", "search-status": "search", "vehicles": "vehicles"}


@app.callback()
def _commands() -> None:
    """Keeps `simgap NAME` a command's name when only that command is registered."""


def _register(argv: list[str]) -> None:
    name = next((a for a in argv if not a.startswith("-")), None)
    for module in [COMMANDS[name]] if name in COMMANDS else sorted(set(COMMANDS.values())):
        importlib.import_module(f"simgap.cli.{module}")


def main() -> None:
    try:       # an interpreter that crashes (a planner's segfault) says so, and where
        faulthandler.enable()
    except (OSError, ValueError):  # a standard error without a file descriptor (a caller captured it)
        pass
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
        sys.exit(ExitCode.BAD_INPUT)
    except OSError as err:
        if err.errno not in ENVIRONMENT_ERRORS:
            _internal_failure(err)
        where = f" writing {err.filename}" if err.filename else ""
        typer.secho(f"error: {ENVIRONMENT_ERRORS[err.errno]}{where}; nothing half-written was kept: free the space "
                    "or choose another --out, then run the command again", err=True, fg="red")
        sys.exit(ExitCode.INTERNAL_FAILURE)
    except Exception as err:        # a bug of simgap's (or of a library's): one line, not a traceback
        _internal_failure(err)


def _internal_failure(err: BaseException) -> NoReturn:
    """Say in one line that simgap failed and where its traceback is (a file in the temporary
    folder, for a bug report), and exit with `ExitCode.INTERNAL_FAILURE`."""
    text = "".join(traceback.format_exception(err))
    try:
        handle, path = tempfile.mkstemp(prefix="simgap-traceback-", suffix=".txt")
        with os.fdopen(handle, "w") as fh:
            fh.write(f"simgap {' '.join(sys.argv[1:])}\n\n{text}")
        where = f"its traceback is in {path}"
    except OSError as unwritten:
        sys.stderr.write(text)
        where = f"its traceback is above (it could not be written to a file: {unwritten.strerror})"
    message = " ".join(str(err).split())
    typer.secho(f"internal error: {type(err).__name__}{': ' * bool(message)}{message}; {where} (please report it)",
                err=True, fg="red")
    sys.exit(ExitCode.INTERNAL_FAILURE)


_TERMINATED: list[int] = []


def _terminated(signum, frame) -> None:
    """The first SIGTERM stops the command as Ctrl-C does, where it is — so what it was writing is
    cleaned up, and a run in the loop lets it through (`RunInterrupted`, if the loop is loaded) —
    and the command says so; a second one ends it at once."""
    _TERMINATED.append(signum)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    loop_stops = sys.modules.get("simgap.cosim.interruptions")
    raise loop_stops.RunInterrupted() if loop_stops is not None else KeyboardInterrupt()
