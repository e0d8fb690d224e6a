"""The command line's rich console. On a terminal it fits the terminal; piped into a file, a log
or CI it wraps no line and cuts no table (rich would make both 80 columns wide), so names and
numbers print whole."""

from __future__ import annotations

from rich.console import Console

UNWRAPPED_WIDTH = 10_000     # columns of a console that is not a terminal: wider than any line simgap prints


def output_console(stderr: bool = False) -> Console:
    """A console on standard output (or error) as the module docstring says."""
    terminal = Console(stderr=stderr)
    return terminal if terminal.is_terminal else Console(stderr=stderr, width=UNWRAPPED_WIDTH)
