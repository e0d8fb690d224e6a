"""`simgap experiment`: run a spec (resumably, in parallel, locally or on Ray), see its status,
query its results store."""

from __future__ import annotations

import csv
from pathlib import Path
from typing import TYPE_CHECKING

import typer
from rich.console import Console
from rich.markup import escape
from rich.table import Table

from simgap.cli.console import ProgressBars, output_console
from simgap.cli.exit_codes import EXIT_CODES_HELP, exit_on_failures
from simgap.cli.main import app
from simgap.evaluate.odds import Odds
from simgap.evaluate.outcome_checks import FAIL_ON_HELP, MIN_SCORE_HELP, CheckedRun, OutcomeCheck
from simgap.experiment.ray_cluster import ADDRESS_HELP
from simgap.files import writable_directory

if TYPE_CHECKING:
    from simgap.experiment.run_row import RunRow

experiment_app = typer.Typer(help="Experiments: many scenarios x vehicles x fidelities, resumable.",
                             no_args_is_help=True, rich_markup_mode=None)
app.add_typer(experiment_app, name="experiment")


@experiment_app.command("run", epilog=EXIT_CODES_HELP)
def run_cmd(
    spec: str = typer.Argument(..., help="experiment spec (YAML file) or a built-in one: demo, paper-curves"),
    out: Path = typer.Option(..., "--out", "-o", help="experiment directory (re-run to resume)",
                             callback=writable_directory),
    workers: int | None = typer.Option(None, min=1,
                                          help="parallel runs (default: all cores, or all CPUs of the Ray cluster)"),
    executor: str = typer.Option("local", help="local (process pool) or ray"),
    address: str | None = typer.Option(None, help=ADDRESS_HELP),
    no_report: bool = typer.Option(False, "--no-report", help="skip building the HTML report"),
    retry_failed: bool = typer.Option(False, "--retry-failed", help="run the runs that failed before again"),
    no_validate: bool = typer.Option(False, "--no-validate", help="skip each run's solution validity check (the "
                                     "slow part of scoring) for quick loops"),
    fail_on: str | None = typer.Option(None, "--fail-on", help=FAIL_ON_HELP + " (a stored run's outcome is its "
                                          "first agent's that missed its goal)"),
    min_score: float | None = typer.Option(None, "--min-score", help=MIN_SCORE_HELP),
) -> None:
    """Generate the scenarios, run every combination, store the results, build the report.

    Running it again on the same --out resumes: finished runs are kept, runs that were cut off
    are run again (--fail-on and --min-score check every run, earlier ones too).

    \b
    Example:
    simgap experiment run paper-curves --out studies/paper --workers 2
    """
    from simgap.experiment.runner import run_experiment
    from simgap.experiment.store import MACHINE_FAILED
    from simgap.report.site import build_experiment_report

    check = OutcomeCheck.of_options(fail_on, min_score)
    console = output_console()
    with ProgressBars() as bars:
        def show(p) -> None:
            bars.update("runs", p.done + p.failed + p.skipped, p.total,
                        f"{p.done} done, {p.failed} failed, {p.skipped} earlier, {p.remaining} to run")

        result = run_experiment(spec, out, workers, executor, address, on_progress=show, retry_failed=retry_failed,
                                validate=not no_validate)
        report = None if no_report else build_experiment_report(out, bars.update)
    _say_unusable_rows(console, result.unusable_rows, "ran again")
    console.print(f"{result.total} runs: {result.ran} ran now ({result.failed} failed), "
                  f"{result.skipped} finished earlier; {result.wall_time_s:.1f} s")
    if result.skipped_failed:
        console.print(f"  {result.skipped_failed} of the runs that finished earlier failed; to run them again: "
                      f"simgap experiment run {escape(spec)} --out {escape(str(out))} --retry-failed")
    for key, reason in result.failures[:20]:
        console.print(f"  [red]failed[/red] {escape(key)}: {escape(reason)}")
    machine = sum(reason.startswith(MACHINE_FAILED) for _, reason in result.failures)
    if machine:
        console.print(f"  {machine} of the runs failed for the machine (disk, memory), not for their input: they are "
                      "no result and run again when the command is run again")
    print_odds(console, result.odds)
    if result.explained:
        new = sum(e.new for e in result.explained)
        console.print(f"{len(result.explained)} runs explained ({new} now; simgap explain RUN_DIR for the shares):")
        for e in result.explained:
            console.print(f"  {escape(e.key)}: {escape(e.attribution.sentence())}", highlight=False)
    console.print(f"results: [bold]{out / 'store' / 'results.parquet'}[/bold] "
                  f"(simgap experiment query {out} \"SELECT ...\")")
    if report:
        console.print(f"report: [bold]{report}[/bold]")
    if check.asked:
        from simgap.experiment.store import ResultsStore

        exit_on_failures(console, check.failures([stored_run(row) for row in ResultsStore(out).run_rows()]))


def stored_run(row: RunRow) -> CheckedRun:
    """A stored run as the checks see it."""
    return CheckedRun(row.id.key, row.outcome, row.score)


def print_odds(console: Console, odds: list[Odds]) -> None:
    """The odds of every scenario run more than once (over its repeats' seeds), as a table."""
    repeated = [o for o in odds if o.runs > 1]
    if not repeated:
        return
    table = Table(title=escape("over the repeats' seeds: rates with Wilson 95 % intervals, max |d| [m] with "
                               "bootstrap 95 % intervals"))
    for column in ("scenario", "fidelity", "planner", "runs", "goal", "failure", "max |d| median", "max |d| p90"):
        table.add_column(column, justify="left" if column in ("scenario", "fidelity", "planner") else "right")
    for o in repeated:
        table.add_row(escape(o.scenario), escape(o.fidelity), escape(o.planner), str(o.runs), str(o.goal),
                      str(o.failure), str(o.max_d_median), str(o.max_d_p90))
    console.print(table)


def _say_unusable_rows(console: Console, unusable_rows: dict[Path, str], then: str) -> None:
    """One line per row file the store left out, with why, and what became of its run."""
    for path, why in unusable_rows.items():
        console.print(f"[yellow]skipped[/yellow] {escape(str(path))}: {escape(why)}; its run {then}")


@experiment_app.command("status")
def status_cmd(out: Path = typer.Argument(..., help="experiment directory")) -> None:
    """What is done, what failed (with reasons) and what is left.

    Example: simgap experiment status studies/paper
    """
    from simgap.experiment.runner import experiment_status

    st = experiment_status(out)
    console = output_console()
    _say_unusable_rows(console, st.unusable_rows, "counts as left and runs again on resume")
    console.print(f"{st.total} runs: {len(st.ok)} done, {len(st.failed)} failed, {len(st.left)} left")
    for key, reason in st.failed:
        console.print(f"  [red]failed[/red] {escape(key)}: {escape(reason)}")
    if st.left:
        shown = ", ".join(st.left[:5]) + (" ..." if len(st.left) > 5 else "")
        console.print(f"  left: {escape(shown)}")


@experiment_app.command("query")
def query_cmd(
    out: Path = typer.Argument(..., help="experiment directory"),
    sql: str = typer.Argument(..., help="DuckDB SQL over the table 'runs' (one row per run)"),
    to_csv: Path | None = typer.Option(None, "--csv", help="write the result as CSV instead of printing it"),
) -> None:
    """Query the results store with SQL; columns: key, scenario, fidelity, backend, vehicle,
    controller, planner, param_*, status, failure, outcome, planning_mean_s, wall_time_s, time_*_s,
    score, score_* (its components), solution_valid, solution_reason, solution_cost, version_*, ...

    Example: simgap experiment query studies/paper "SELECT fidelity, median(wall_time_s) FROM runs GROUP BY 1"
    """
    from simgap.experiment.store import ResultsStore

    store = ResultsStore(out)
    columns, rows = store.query(sql)
    _say_unusable_rows(output_console(stderr=True), store.unusable_rows, "is left out and runs again on resume")
    if to_csv is not None:
        with to_csv.open("w", newline="") as fh:
            writer = csv.writer(fh)
            writer.writerow(columns)
            writer.writerows(rows)
        output_console().print(f"{len(rows)} rows written to [bold]{to_csv}[/bold]")
        return
    table = Table()
    for c in columns:
        table.add_column(escape(c))
    for r in rows:
        table.add_row(*(f"{v:.4g}" if isinstance(v, float) else escape(str(v)) for v in r))
    output_console().print(table)
