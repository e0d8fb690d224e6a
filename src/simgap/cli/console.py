"""The command line's rich consoles, its progress bars and its notes.

On a terminal the output fits the terminal; piped into a file, a log or CI it wraps no line and
cuts no table (rich would make both 80 columns wide), so names and numbers print whole. Progress
bars go to standard error and only to a terminal: what a command prints on standard output is
the same with and without them."""

from __future__ import annotations

import os
import re
from collections.abc import Callable, Iterable

from rich.console import Console
from rich.markup import escape
from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn, TimeRemainingColumn

UNWRAPPED_WIDTH = 10_000     # columns of a console that is not a terminal: wider than any line simgap prints
PROGRESS_ENV = "SIMGAP_PROGRESS"   # "always": bars on standard error even when it is no terminal; "never": none


def output_console(stderr: bool = False) -> Console:
    """A console on standard output (or error) as the module docstring says."""
    terminal = Console(stderr=stderr)
    return terminal if terminal.is_terminal else Console(stderr=stderr, width=UNWRAPPED_WIDTH)


class ProgressBars:
    """Progress bars on standard error, one line per phase of a long command: how far it is, the
    time it has taken and the time it has left. Shown on a terminal only (``SIMGAP_PROGRESS=always``
    shows them anywhere, ``never`` nowhere), and never when ``shown`` is False (``--json``); hidden,
    an update costs a test. Use as a context manager; the bars appear at the first update, so a
    command refused before any work shows none."""

    def __init__(self, shown: bool = True, get_time: Callable[[], float] | None = None):
        wanted = os.environ.get(PROGRESS_ENV, "").strip().lower()
        console = Console(stderr=True, force_terminal=True if wanted == "always" else None)
        self.shown = shown and wanted != "never" and console.is_terminal
        self._tasks: dict[str, int] = {}
        redraws = 10 if Console(stderr=True).is_terminal else 1      # forced into a log: a frame a second
        self._bars = Progress(TextColumn("[bold]{task.description}"), BarColumn(), TextColumn("{task.fields[counts]}"),
                              TimeElapsedColumn(), TextColumn("elapsed,"), TimeRemainingColumn(), TextColumn("left"),
                              console=console, redirect_stdout=False, get_time=get_time,
                              refresh_per_second=redraws) if self.shown else None

    def __enter__(self) -> ProgressBars:
        return self

    def __exit__(self, *exc) -> None:
        self.stop()

    def update(self, phase: str, done: float, total: float | None, counts: str | None = None) -> None:
        """``phase`` has done ``done`` of ``total`` (None: not known yet); ``counts``: what the bar
        says beside it (default: done/total). A phase that starts again (done below the last) restarts
        its bar and its clock."""
        if self._bars is None:
            return
        if not self._bars.live.is_started:
            self._bars.start()
        text = counts if counts is not None else f"{done:g}/{total:g}" if total is not None else f"{done:g}"
        task = self._tasks.get(phase)
        if task is None:
            task = self._tasks[phase] = self._bars.add_task(escape(phase), total=total, counts=text)
        elif done < self._bars.tasks[task].completed:
            self._bars.reset(task, total=total)
        self._bars.update(task, completed=done, total=total, counts=text)

    def stop(self) -> None:
        """The bars drawn a last time, as they stand, and left."""
        if self._bars is not None and self._bars.live.is_started:
            self._bars.stop()


_NUMBER = re.compile(r"[-+]?\d+(?:\.\d+)?(?:e[-+]?\d+)?")


def collapsed_notes(notes: Iterable[str]) -> list[str]:
    """Notes that differ in their numbers only, as one: the first of them, and how many there were."""
    alike: dict[str, list[str]] = {}
    for note in notes:
        alike.setdefault(_NUMBER.sub("#", note), []).append(note)
    lines = []
    for same in alike.values():
        count = f" (×{len(same)}{'' if len(set(same)) == 1 else ', with other numbers'})" if len(same) > 1 else ""
        lines.append(same[0] + count)
    return lines


def print_notes(console: Console, notes: Iterable[str], label: str = "note") -> None:
    """Each note on a line of its own, those alike but for their numbers collapsed into one
    (`collapsed_notes`)."""
    for line in collapsed_notes(notes):
        console.print(f"{label}: {escape(line)}", soft_wrap=True)
