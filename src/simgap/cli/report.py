"""`simgap report`: the HTML report of a set of runs."""

from __future__ import annotations

import time
from pathlib import Path

import typer

from simgap.cli.console import ProgressBars, output_console
from simgap.cli.main import app
from simgap.cli.outputs import OVERWRITE_HELP, check_report_out
from simgap.files import writable_directory


@app.command()
def report(
    runs: Path = typer.Argument(..., help="a directory with run directories below it (an experiment, a demo, runs/)"),
    out: Path = typer.Option(..., "--out", "-o", help="report directory to write (open its index.html)",
                             callback=writable_directory),
    overwrite: bool = typer.Option(False, "--overwrite", help=OVERWRITE_HELP),
) -> None:
    """Write the HTML report of every run below RUNS: an overview page and a page per scenario.

    Example: simgap report simgap-demo/runs --out simgap-demo/report
    """
    from simgap.report.site import build_report

    check_report_out(out, overwrite)
    console = output_console()
    start = time.perf_counter()
    with ProgressBars() as bars:
        index = build_report(runs, out, on_progress=bars.update)
    console.print(f"report written to [bold]{index}[/bold] in {time.perf_counter() - start:.1f} s")
