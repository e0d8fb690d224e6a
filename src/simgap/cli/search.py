"""`simgap search`: look for scenarios that pass in the ideal world and fail in a higher fidelity,
the strategies of the spec on equal shares of the budget; resumable."""

from __future__ import annotations

from pathlib import Path

import typer
from rich.console import Console
from rich.markup import escape
from rich.table import Table

from simgap.cli.console import ProgressBars, output_console
from simgap.cli.exit_codes import EXIT_CODES_HELP, exit_on_failures
from simgap.cli.main import app
from simgap.evaluate.outcome_checks import FAIL_ON_HELP, MIN_SCORE_HELP, CheckedRun, OutcomeCheck
from simgap.experiment.ray_cluster import ADDRESS_HELP
from simgap.experiment.search.budget import CONFIRMATION_REPEATS
from simgap.files import writable_directory


@app.command("search", epilog=EXIT_CODES_HELP)
def search_cmd(
    spec: str = typer.Argument(..., help="search spec (YAML file) or a built-in one: curve-gaps"),
    budget: str = typer.Option(..., "--budget", "-b", help="the search's total, shared evenly among its strategies: wall clock "
                        "(20m, 90s, 1h) or runs (200); it pays for probing, confirming and explaining what each "
                        "reports too"),
    out: Path = typer.Option(..., "--out", "-o", help="search directory (re-run to resume)",
                             callback=writable_directory),
    workers: int | None = typer.Option(None, min=1,
                                          help="parallel runs (default: all cores, or all CPUs of the Ray cluster)"),
    strategy: list[str] | None = typer.Option(None, help="run only this strategy (repeatable)"),
    executor: str = typer.Option("local", help="local (process pool) or ray"),
    address: str | None = typer.Option(None, help=ADDRESS_HELP),
    repeats: int = typer.Option(CONFIRMATION_REPEATS, "--repeats", min=1,
                                help="seeds each reported violation is confirmed over in high fidelity (its own "
                                     "included): it says in how many of them it fails"),
    explain: bool = typer.Option(True, "--explain/--no-explain",
                                 help="explain each reported violation within the budget (simgap explain: which of "
                                      "the planner's assumptions it broke; 2^n runs each)"),
    no_report: bool = typer.Option(False, "--no-report", help="skip building the HTML report"),
    no_validate: bool = typer.Option(False, "--no-validate", help="skip each run's solution validity check (the "
                                     "slow part of scoring) for quick loops"),
    fail_on: str | None = typer.Option(None, "--fail-on", help=FAIL_ON_HELP + " (in any rung of the search; a "
                                          "stored run's outcome is its first agent's that missed its goal)"),
    min_score: float | None = typer.Option(None, "--min-score", help=MIN_SCORE_HELP + " (in any rung)"),
) -> None:
    """Search the spec's space for violated planning assumptions, one strategy after another.

    --budget is the whole search's: each strategy gets an equal share, which pays for its search
    and for following up each distinct violation it reports (its probes, its confirmation over
    seeds, its explanation): the search stops early enough to leave room for them. Running it
    again on the same --out resumes each strategy where it stopped, with the share it has left
    (give a larger --budget to go on).

    \b
    Example:
    simgap search curve-gaps --budget 20m --out studies/gaps --workers 2
    """
    from simgap.experiment.search import parse_budget, run_search
    from simgap.experiment.search.follow_up import FollowUp
    from simgap.experiment.search.results import search_results
    from simgap.report.search_page import build_search_report

    limit = parse_budget(budget)
    check = OutcomeCheck.of_options(fail_on, min_score)
    console = output_console()
    with ProgressBars() as bars:
        def show(p) -> None:             # each strategy against its share of the budget
            total = p.budget.seconds if p.budget.seconds is not None else p.budget.runs
            done = p.elapsed_s if p.budget.seconds is not None else p.runs
            bars.update(p.strategy, min(done, total), total, f"{p.runs} runs, {p.high_failures} high-fidelity failures")

        results = run_search(spec, out, limit, workers, executor, address, strategy or None, on_progress=show,
                             validate=not no_validate, follow_up=FollowUp(repeats, explain))
    _print(console, results)
    _print_findings(console, results, limit)
    if not no_report:
        console.print(f"report: [bold]{build_search_report(search_results(out))}[/bold]")
    if check.asked:
        from simgap.experiment.search.rows import read_search_rows

        exit_on_failures(console, check.failures([
            CheckedRun(f"{r.name} {row.run.id.key}", row.run.outcome, row.run.score)
            for r in results for row in read_search_rows(out / r.name) if row.ideal_of is None]))


def _print(console: Console, results) -> None:
    t = Table(title="what each strategy found")
    for col in ("strategy", "min", "runs", "high runs", "high failures", "violations", "distinct", "scenarios",
                "reported", "modes", "per CPU-h"):
        t.add_column(col, justify="left" if col == "strategy" else "right")
    for r in results:
        t.add_row(r.name, f"{r.wall_s / 60:.1f}", str(r.runs), str(r.high_runs), str(r.high_failures),
                  str(r.violations), str(r.distinct), str(r.scenarios), str(len(r.reported)), str(len(r.modes)),
                  f"{r.per_cpu_hour:.1f}")
    console.print(t)


FINDINGS_SHOWN = 10


def _print_findings(console: Console, results, budget) -> None:
    """The reported violations (each probed), worst first (by the objective's value in the
    high-fidelity run), each with the seeds it fails in, the command that reproduces it and its
    explanation; then, once, what the budget left undone and the budget that would do it."""
    found = [v for r in results for v in r.reported]
    if found:
        worst = sorted(found, key=lambda v: -_objective(v))
        shown = f" (the first {FINDINGS_SHOWN}; all in the report)" if len(found) > FINDINGS_SHOWN else ""
        console.print(f"{len(found)} distinct violation{'s' if len(found) > 1 else ''}, each probed; worst first, "
                      f"each with the command that reproduces it{shown}:")
        for v in worst[:FINDINGS_SHOWN]:
            seeds = "" if v.reproduces is None or v.reproduces.n < 2 else f"; fails in {v.reproduces} seeds"
            console.print(f"  {escape(v.scenario)} ({v.vehicle}, {escape(v.strategy)}): "
                          f"{escape(v.row.failure_reason)}{seeds}")
            console.print(f"    {escape(v.reproduce)}", soft_wrap=True)
            if v.explanation is not None:
                console.print(f"    why: {escape(v.explanation.sentence())}", soft_wrap=True)
    for line in _left(results, budget, found):
        console.print(line, soft_wrap=True)


def _left(results, budget, found) -> list[str]:
    """One line for the violations the budget left unprobed (not reported), one for the reported
    ones it left unexplained, each with the --budget that would follow them up (shares being
    equal, the strategy that needs the most sets it)."""
    left = [r.left for r in results if r.left is not None]
    out = []
    unprobed = sum(x.unprobed for x in left)
    if unprobed:
        more = budget + _most(results, [x.to_probe for x in left])
        out.append(f"{unprobed} more distinct violation{'s' if unprobed > 1 else ''} found, left unprobed by the "
                   f"budget and not reported: --budget {more.option()} on this --out would probe, confirm and explain "
                   f"{'them' if unprobed > 1 else 'it'}")
    unexplained = sum(x.unexplained for x in left)
    if unexplained:
        more = budget + _most(results, [x.to_explain for x in left])
        out.append(f"{unexplained} of the {len(found)} reported violations {'are' if unexplained > 1 else 'is'} not "
                   f"explained: the budget did not allow it (--budget {more.option()} on this --out would explain "
                   f"{'them' if unexplained > 1 else 'it'})")
    return out


def _most(results, costs):
    """What the whole budget (shared evenly) must grow by for every strategy's share to pay for
    the dearest of ``costs``."""
    from simgap.experiment.search import Budget

    most = max(costs, key=lambda b: b.seconds if b.seconds is not None else b.runs)
    n = len(results)
    return Budget(seconds=most.seconds * n) if most.seconds is not None else Budget(runs=(most.runs or 0) * n)


def _objective(v) -> float:
    value = v.row.run.metrics.get("max_lateral_offset_m", float("nan"))
    return value if value == value else float("-inf")


@app.command("search-status")
def status_cmd(out: Path = typer.Argument(..., help="search directory")) -> None:
    """What each strategy of a search has spent and found so far.

    Example: simgap search-status studies/gaps
    """
    from simgap.experiment.search.results import search_results

    _print(output_console(), search_results(out).strategies)
