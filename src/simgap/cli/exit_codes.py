"""What the `simgap` command's exit status means, the same for every command (a CI job can tell a
planner that failed its checks from bad input and from simgap itself failing)."""

from __future__ import annotations

import textwrap
from enum import IntEnum

import typer
from rich.console import Console
from rich.markup import escape


class ExitCode(IntEnum):
    OK = 0
    CHECK_FAILED = 1           # an outcome of --fail-on or a score under --min-score came out, or `simgap run`'s
                               # run failed (a batch goes on past a failed run: its exit says what its checks say)
    BAD_INPUT = 2              # a file, an option or a value simgap refused (one line: file, field, what is allowed)
    INTERNAL_FAILURE = 3       # simgap could not finish: an unexpected error (its traceback written to a file) or
                               # the machine (no space left on the device)


MEANINGS = {ExitCode.OK: "ok",
            ExitCode.CHECK_FAILED: "an outcome of --fail-on or a score below --min-score came out (or the run of "
                                   "simgap run failed)",
            ExitCode.BAD_INPUT: "bad input (a file, an option or a value; one line says which and what is allowed)",
            ExitCode.INTERNAL_FAILURE: "simgap could not finish: an unexpected error (one line says where its "
                                       "traceback was written) or the machine (a full disk)"}

# a help epilog: click keeps a paragraph that starts with \b as it is, so the lines are wrapped here
EXIT_CODES_HELP = "\b\nExit codes:\n" + "\n".join(
    textwrap.fill(text, 76, initial_indent=f"  {int(code)}  ", subsequent_indent="     ")
    for code, text in MEANINGS.items())


SHOWN_FAILURES = 20         # check failures printed, a line each (the rest counted)


def exit_on_failures(console: Console, failures: list[str], run_failed: bool = False) -> None:
    """Print what failed the checks (a line each) and exit `ExitCode.CHECK_FAILED` if anything did,
    or if ``run_failed``."""
    for line in failures[:SHOWN_FAILURES]:
        console.print(f"[red]check failed:[/red] {escape(line)}")
    if len(failures) > SHOWN_FAILURES:
        console.print(f"[red]check failed:[/red] ... and {len(failures) - SHOWN_FAILURES} more")
    if failures or run_failed:
        raise typer.Exit(ExitCode.CHECK_FAILED)
