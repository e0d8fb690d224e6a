"""`simgap compare`: two runs of one scenario (e.g. two fidelities), agent by agent."""

from __future__ import annotations

import json
from dataclasses import asdict
from pathlib import Path
from typing import Any

import typer
from rich.console import Console
from rich.markup import escape
from rich.table import Table

from simgap.cli.console import output_console
from simgap.cli.main import app
from simgap.errors import InputError
from simgap.evaluate.compare import compare_histories
from simgap.evaluate.route_centre import route_centre
from simgap.evaluate.route_edges import EventPlace, event_places, route_edges
from simgap.evaluate.score_drop import score_drop
from simgap.files import writable_directory
from simgap.record import RunRecord, read_run
from simgap.report.plots import plot_d_over_s, plot_v_over_t
from simgap.scenario import load_scenario, read_sidecar

METRICS = ("lateral_displacement", "position_error", "orientation_error", "velocity_error")
UNITS = {"lateral_displacement": "m", "position_error": "m", "orientation_error": "rad", "velocity_error": "m/s"}


def score_comparison(a: RunRecord, b: RunRecord) -> list[dict]:
    """Per agent of both runs: each world's score, cost and validity, the score's drop and the
    components that lost it (the largest loss first)."""
    weights = b.settings.evaluation.score.weights
    out = []
    for aid in sorted({x.id for x in a.evaluation.agents} & {x.id for x in b.evaluation.agents}):
        agent_a, agent_b = a.evaluation.agent(aid), b.evaluation.agent(aid)
        drop, losses = score_drop(agent_a, agent_b, weights)
        out.append({"agent_id": aid,
                    **{side: {"score": x.score, "solution_cost": x.solution_cost, "solution_valid": x.solution_valid,
                              "solution_reason": x.solution_reason}
                       for side, x in (("a", agent_a), ("b", agent_b))},
                    "score_drop": drop, "solution_cost_change": None if agent_a.solution_cost is None or
                    agent_b.solution_cost is None else agent_b.solution_cost - agent_a.solution_cost,
                    "components": [asdict(c) for c in losses]})
    return out


def print_scores(console: Console, result: dict) -> None:
    rows = [s for s in result["scores"] if s["a"]["score"] is not None and s["b"]["score"] is not None]
    if not rows:
        return
    table = Table(title="scores (closed-loop score, CommonRoad solution)")
    for col in ("agent", "score A", "score B", "drop", "lost on (score regained if as in A)", "cost A", "cost B",
                "valid A", "valid B"):
        table.add_column(col, justify="left" if col.startswith(("lost", "valid")) else "right", no_wrap=False)

    def fmt(value, spec=".3f"):
        return "—" if value is None else format(value, spec)

    for s in rows:
        lost = ", ".join(f"{c['name']} {c['a']:.2g}→{c['b']:.2g} (+{c['regained']:.3f})"
                         for c in s["components"] if c["regained"] > 1e-9 or c["a"] != c["b"]) or "nothing"
        table.add_row(str(s["agent_id"]), fmt(s["a"]["score"]), fmt(s["b"]["score"]), fmt(s["score_drop"]),
                      escape(lost), fmt(s["a"]["solution_cost"], ".0f"), fmt(s["b"]["solution_cost"], ".0f"),
                      *(escape({True: "valid", False: f"invalid: {s[k]['solution_reason']}", None: "—"}
                               [s[k]["solution_valid"]]) for k in ("a", "b")))
    console.print(table)


def event_rows(places: list[EventPlace]) -> list[dict]:
    """The events of a run, in time order, with their place (x, y; s, d along the agent's route)."""
    return [{"t": p.event.t, "agent_id": p.event.agent_id, "kind": p.event.kind.value, "x": p.event.x,
             "y": p.event.y, "s": p.s, "d": p.d, "detail": p.event.detail} for p in places]


def print_events(console: Console, result: dict) -> None:
    table = Table(title="events (where: x, y in the scenario; s, d along the agent's route centre)")
    for col in ("run", "t [s]", "agent", "event", "x, y [m]", "s [m]", "d [m]", "detail"):
        table.add_column(escape(col), justify="right" if col in ("t [s]", "agent", "s [m]", "d [m]") else "left",
                         no_wrap=col != "detail")
    for side in ("a", "b"):
        for e in result["events"][side]:
            table.add_row(side.upper(), f"{e['t']:.2f}", str(e["agent_id"]), e["kind"],
                          "—" if e["x"] is None else f"{e['x']:.1f}, {e['y']:.1f}",
                          "—" if e["s"] is None else f"{e['s']:.1f}", "—" if e["d"] is None else _signed(e["d"]),
                          escape(e["detail"]))
    console.print(table)


def _label(run: RunRecord, run_dir: Path) -> str:
    return f"{run.fidelity.label} ({run_dir.name})"


@app.command()
def compare(
    run_a: Path = typer.Argument(..., help="reference run directory (e.g. the ideal run)"),
    run_b: Path = typer.Argument(..., help="run directory to compare with it"),
    out: Path | None = typer.Option(None, "--out", "-o", help="write d-over-s and v-over-t plots here",
                                       callback=writable_directory),
    as_json: bool = typer.Option(False, "--json", help="print the metrics as JSON"),
) -> None:
    """Compare two runs of the same scenario: lateral displacement by arc length, errors by time,
    and where and when each run's events happened (goal, off road, collision, ...).

    Example: simgap compare runs/c10 runs/c10-dynamic --out runs/c10-vs-dynamic
    """
    a, b = read_run(run_a), read_run(run_b)
    if a.scenario_id != b.scenario_id:
        raise InputError(f"runs are of different scenarios ('{a.scenario_id}' and '{b.scenario_id}')",
                         file=run_b, field="scenario_id", allowed=f"a run of '{a.scenario_id}'")
    path = a.settings.scenario_path
    xml = Path(path) if path and Path(path).exists() else run_a / "driven.xml"
    scenario, problems = load_scenario(xml)
    sections = a.settings.sections or read_sidecar(xml).sections
    comparisons = compare_histories(a.history, b.history, scenario, problems, sections)
    network, by_id = scenario.lanelet_network, problems.planning_problem_dict
    frames = {aid: route_centre(network, by_id[aid]) if aid in by_id else None
              for aid in {x.id for x in a.history.agents} | {x.id for x in b.history.agents}}
    places = {side: event_places(run.history.events, frames) for side, run in (("a", a), ("b", b))}
    result: dict[str, Any] = {"scenario_id": a.scenario_id, "a": _label(a, run_a), "b": _label(b, run_b),
                              "agents": [c.as_dict() for c in comparisons], "scores": score_comparison(a, b),
                              "events": {side: event_rows(p) for side, p in places.items()},
                              "criticality": {"a": [asdict(c) for c in a.evaluation.criticality],
                                              "b": [asdict(c) for c in b.evaluation.criticality]}}
    if out is not None:
        out.mkdir(parents=True, exist_ok=True)
        for c in comparisons:
            frame = frames.get(c.agent_id)
            plot_d_over_s({result["a"]: (c.s, c.d_a), result["b"]: (c.s, c.d_b)},
                          out / f"d_over_s_agent{c.agent_id}.png",
                          f"{a.scenario_id}, agent {c.agent_id}: lateral offset from the lane centre",
                          None if c.section_along_s is None else (c.s, c.section_along_s),
                          None if frame is None else route_edges(network, by_id[c.agent_id], frame),
                          {result[side]: [p for p in places[side] if p.event.agent_id == c.agent_id]
                           for side in ("a", "b")})
            plot_v_over_t({result["a"]: a.history.driven[c.agent_id], result["b"]: b.history.driven[c.agent_id]},
                          out / f"v_over_t_agent{c.agent_id}.png", f"{a.scenario_id}, agent {c.agent_id}: speed")
        (out / "comparison.json").write_text(json.dumps(result, indent=2))
    if as_json:
        typer.echo(json.dumps(result, indent=2))
        return
    console = output_console()
    table = Table(title=escape(f"{a.scenario_id}: {result['b']} against {result['a']}"))
    for col in ("agent", "metric", "max", "rms", "mean", "p95"):
        table.add_column(col, justify="left" if col in ("metric",) else "right", no_wrap=True)
    for c in comparisons:
        d = c.as_dict()
        for m in METRICS:
            agg = d[m]
            table.add_row(str(c.agent_id), escape(f"{m} [{UNITS[m]}]"),
                          *(f"{agg[k]:.3f}" for k in ("max", "rms", "mean", "p95")))
        for kind, agg in d["lateral_displacement_by_section"].items():
            table.add_row(str(c.agent_id), escape(f"  d on {kind} sections [m]"),
                          *(f"{agg[k]:.3f}" for k in ("max", "rms", "mean", "p95")))
        for side in ("a", "b"):
            for key, name in (("tracking_error", "tracking error"), ("lateral_tracking_error", "  lateral"),
                              ("longitudinal_tracking_error", "  longitudinal")):
                agg = d[f"{key}_{side}"]
                table.add_row(str(c.agent_id), escape(f"{name} in {side.upper()} [m]"),
                              *(f"{agg[k]:.3f}" for k in ("max", "rms", "mean", "p95")))
    console.print(table)
    console.print("lateral displacement: |d_b - d_a| at equal arc length along the route's lane centre; "
                  "position, orientation and velocity errors at equal time; tracking error: where a run's "
                  "vehicle was against where its plan in force said it would be", style="dim")
    print_events(console, result)
    print_scores(console, result)
    if result["criticality"]["a"]:
        crit = Table(title="criticality per agent pair (commonroad-crime; most critical value over the run)")
        for col in ("ego", "other", "measure", "A", "B"):
            crit.add_column(col, justify="right", no_wrap=True)
        for ra, rb in zip(result["criticality"]["a"], result["criticality"]["b"]):
            crit.add_row(str(ra["ego_id"]), str(ra["other_id"]), ra["measure"].upper(),
                         f"{ra['worst']:.2f}", f"{rb['worst']:.2f}")
        console.print(crit)
        console.print(escape("TTC, THW [s]: smaller is more critical; BTN, STN [-]: larger is more critical"),
                      style="dim")
    if out is not None:
        console.print(f"plots written to [bold]{out}[/bold]")


def _signed(value: float, digits: int = 2) -> str:
    """``value`` with its sign, but none where it rounds to zero (a centre line's -1e-12 and +1e-12
    are both 0.00: the same on any machine)."""
    text = f"{value:+.{digits}f}"
    return text[1:] if float(text) == 0.0 else text
