"""`simgap run`: one scenario in one backend, every planning problem an agent."""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import typer
from pydantic import BaseModel
from rich.console import Console
from rich.markup import escape
from rich.table import Table

from simgap.cli.console import ProgressBars, output_console
from simgap.cli.exit_codes import EXIT_CODES_HELP, exit_on_failures
from simgap.cli.main import app
from simgap.cli.outputs import OVERWRITE_HELP, check_run_out
from simgap.cosim import REFERENCE, CosimSettings, Outcome
from simgap.cosim.interruptions import DEFAULT_RUN_TIMEOUT_S
from simgap.cosim.loop import MAX_SIMULATED_TIME_S
from simgap.errors import InputError, validated
from simgap.evaluate.outcome_checks import FAIL_ON_HELP, MIN_SCORE_HELP, CheckedRun, OutcomeCheck
from simgap.evaluate.run_evaluation import AgentEvaluation
from simgap.evaluate.settings import CostFunctionId, EvaluationSettings, ScoreSettings
from simgap.experiment import fork_server
from simgap.experiment.knobs import KNOBS, apply_knobs, check_knob, knob
from simgap.experiment.single_run import RunRequest, execute, parse_agent_map, parse_planners
from simgap.files import read_model, read_yaml_mapping, writable_directory
from simgap.planning.registry import DEFAULT_PLANNER
from simgap.planning.remote import ProcessLimits
from simgap.record import RunRecord
from simgap.scenario.placement import GOAL_FORMS, START_FORMS, AgentPlacement
from simgap.sim.protocol import Realism
from simgap.sim.registry import backend_settings, preflight
from simgap.sim.settings import realism_of
from simgap.vehicles import DEFAULT_VEHICLE

KNOB_HELP = "reality knob NAME=VALUE (repeatable): " + ", ".join(
    f"{k.name} [{k.unit}] {k.low:g} to {k.high:g} ({', '.join(k.backends)})" for k in KNOBS.values())


@app.command(epilog=EXIT_CODES_HELP)
def run(
    scenario: Path = typer.Argument(..., help="CommonRoad XML scenario (every planning problem is an agent), or "
                                    "any CommonRoad map with --start and --goal (simgap maps lists real ones)"),
    out: Path = typer.Option(..., "--out", "-o", help="run directory to write", callback=writable_directory),
    start: str | None = typer.Option(None, "--start", help="one agent on the map, in place of its planning "
                                        "problems, starting at " + START_FORMS),
    goal: str | None = typer.Option(None, "--goal", help="with --start: the agent's goal, " + GOAL_FORMS),
    backend: str = typer.Option(REFERENCE, help="ideal (2D, perfect tracking), dynamic (single-track model), "
                                "mujoco (3D physics) or beamng (a BeamNG.tech server)"),
    backend_config: Path | None = typer.Option(None, help="YAML file of backend settings (for beamng: host, "
                                                  "port, home, driver, ...)"),
    vehicle: str = typer.Option(DEFAULT_VEHICLE, help="vehicle for every agent, or per agent: 1=sedan,2=suv (catalogue "
                                "names or vehicle data files)"),
    planner_vehicle: str = typer.Option(DEFAULT_VEHICLE, help="the vehicle the planner assumes it drives"),
    controller: str | None = typer.Option(None, help="tracking controller (physics backends): "
                                             "pure_pursuit, stanley, lqr"),
    controller_hz: float | None = typer.Option(None, help="controller rate [Hz] (physics backends, >= 50)"),
    physics_hz: float | None = typer.Option(None, help="physics rate [Hz] (mujoco, >= 200, a multiple of the "
                                               "controller rate)"),
    realism: Realism | None = typer.Option(None, help="physics backends: real (default: the vehicle's measured "
                                              "actuators, a drifting localisation, compute latency) or ideal (a "
                                              "perfect machine: the ideal world's assumptions on a physical car)"),
    road_friction: float | None = typer.Option(None, help="road surface friction, scales each tyre's (mujoco)"),
    offroad_friction: float | None = typer.Option(None, help="off-road friction, scales each tyre's (mujoco)"),
    knobs: list[str] | None = typer.Option(None, "--knob", help=KNOB_HELP),
    replan_every: int = typer.Option(1, min=1, help="replan every N steps (the paper's planner: 3)"),
    planner: str = typer.Option(DEFAULT_PLANNER, help="planner of every agent, or per agent: 1=frenet,2=idm; a "
                                "name (simgap planners), my_pkg.module:Class, path/to/file.py:Class, or a planner "
                                "in its own process: 'exec:COMMAND ARGS' (simgap starts it) or tcp://HOST:PORT"),
    planner_config: Path | None = typer.Option(None, help="YAML file of the planner's settings (several "
                                                  "planners: planner name -> its settings)"),
    planning_budget: float | None = typer.Option(None, help="wall time a planning call may take [s]; longer "
                                                    "calls are counted per agent"),
    isolate: bool = typer.Option(False, "--isolate", help="run each agent's planner class in a process of its own "
                                 "(a hang or a crash fails its cycles, never the run)"),
    planner_deadline: float = typer.Option(ProcessLimits.model_fields["deadline_s"].default, help="planners in "
                                           "their own process (exec:, tcp://, --isolate): wall time a planning call "
                                           "may take before its cycle fails [s]"),
    planner_startup_timeout: float = typer.Option(ProcessLimits.model_fields["startup_timeout_s"].default,
                                                  help="planners in their own process: wall time to start and "
                                                  "initialise [s]"),
    max_time: float | None = typer.Option(
        None, help="stop after this much simulated time [s]; default: the end of the goal's time window "
                   f"(60 s when the goal has none); at most {MAX_SIMULATED_TIME_S:g} s"),
    run_timeout: float = typer.Option(DEFAULT_RUN_TIMEOUT_S, help="wall time the run may take [s]; a run still "
                                      "going then (a planner that does not return) is stopped and recorded as failed"),
    traffic: str = typer.Option("replay", help="recorded traffic: replay (as recorded) or idm (driven along "
                                               "its recorded path by an IDM towards the vehicle ahead)"),
    cost_function: CostFunctionId | None = typer.Option(
        None, help="CommonRoad cost function of the solutions when the scenario's benchmark ID names none "
                   "(default SM1)"),
    score_config: Path | None = typer.Option(None, help="YAML file of the closed-loop score's thresholds and "
                                                "weights (evaluation.score; defaults: nuPlan's)"),
    seed: int = typer.Option(0, min=0, help="seed of everything random in the run (the localisations' errors); "
                             "the same seed, scenario and settings drive the same run"),
    no_validate: bool = typer.Option(False, "--no-validate", help="skip the solution's validity check (the slow "
                                     "part of scoring: feasibility state by state) for quick loops"),
    fail_on: str | None = typer.Option(None, "--fail-on", help=FAIL_ON_HELP + ", e.g. off_road,collision"),
    min_score: float | None = typer.Option(None, "--min-score", help=MIN_SCORE_HELP),
    as_json: bool = typer.Option(False, "--json", help="print the summary as JSON on stdout"),
    explain: bool = typer.Option(False, "--explain", help="then say which of the planner's assumptions the run broke "
                                 "and what each cost (simgap explain; physics backends)"),
    overwrite: bool = typer.Option(False, "--overwrite", help=OVERWRITE_HELP + " (a run of another scenario, "
                                   "backend, vehicle or planner)"),
) -> None:
    """Run a scenario and print a per-agent summary.

    \b
    Example:
    simgap run curve_radius-10_angle-90.xml --backend ideal --out runs/c10
    (your planner: --planner my_planner.py:MyPlanner;
     a planner per agent: --planner 1=frenet,2=my_planner)
    (on snow, with a later steering than the car's:
     --backend mujoco --knob road_friction=0.3 --knob steer_delay=0.3)
    (the perfect machine of the ideal world's assumptions, in 3D:
     --backend mujoco --realism ideal)
    (a planner in its own interpreter:
     --planner 'exec:venv/bin/python my_server.py'; guarded: --isolate)
    (any map: simgap run MAP.xml --start 10,2 --goal 80,-3,4 --out runs/map)
    (in CI: --fail-on off_road,collision --min-score 0.5 exits 1 when an agent
     leaves the road, collides or scores below 0.5)
    """
    if not (math.isfinite(run_timeout) and run_timeout > 0):
        raise InputError(f"{run_timeout:g} s is no wall-time limit", field="run-timeout",
                         allowed="a finite number of seconds > 0")
    check = OutcomeCheck.of_options(fail_on, min_score)
    placement = AgentPlacement.of_options(start, goal)
    physical = {"realism": realism, "controller": controller, "controller_hz": controller_hz, "physics_hz": physics_hz,
                "road_friction": road_friction, "offroad_friction": offroad_friction}
    knob_values = _knobs(knobs or [], backend)
    knob_settings, knob_cosim = apply_knobs(backend, knob_values)
    scoring: dict[str, Any] = {"score": read_model(score_config, ScoreSettings, "score settings file",
                                                   empty_ok=True)} if score_config else {}
    if cost_function is not None:
        scoring["cost_function"] = cost_function
    evaluation = EvaluationSettings(**scoring)
    request = RunRequest(scenario=scenario, backend=backend, vehicles=parse_agent_map(vehicle),
                         planner_vehicle=planner_vehicle,
                         backend_settings=_settings(backend, {k: v for k, v in physical.items() if v is not None},
                                                    backend_config, knob_settings),
                         planner=parse_planners(planner, planner_config, isolate, validated(
                             ProcessLimits, {"deadline_s": planner_deadline,
                                             "startup_timeout_s": planner_startup_timeout},
                             prefix="planner")),
                         cosim=validated(CosimSettings, dict(replan_every=replan_every, max_time_s=max_time,
                                                             traffic=traffic, planning_budget_s=planning_budget,
                                                             **knob_cosim)),
                         evaluation=evaluation,
                         seed=seed, validate=not no_validate, run_timeout_s=run_timeout, placement=placement)
    for name, value in knob_values.items():            # (a perfect machine drops the loop's knobs: refused)
        check_knob(name, value, value, where=f"knob {name}", realism=realism_of(request.backend_settings))
    check_run_out(out, request, overwrite)
    preflight(request.backend, request.backend_settings)
    if explain and backend == REFERENCE:
        raise InputError("the ideal world is the planner's assumptions: a run there has nothing to explain",
                         field="explain", allowed="--backend dynamic, mujoco or beamng")
    _execute(request, out, as_json, check, explain)


def _settings(backend: str, options: dict, backend_config: Path | None, knob_settings: dict) -> BaseModel:
    """The backend's settings model: the options' settings over the ``--backend-config`` file's,
    the knobs' over both, validated once."""
    if backend_config is not None and backend == REFERENCE:
        raise InputError("the ideal backend has no settings", file=backend_config, field="backend-config",
                         allowed="dynamic, mujoco, beamng")
    if options and backend == REFERENCE:
        raise InputError(f"--{next(iter(options)).replace('_', '-')} applies to physics backends only; "
                         "the ideal backend executes every plan exactly", field="backend",
                         allowed="dynamic, mujoco, beamng")
    if backend_config is not None:
        options = read_yaml_mapping(backend_config, "backend settings file",
                                    "setting: value, e.g. host: 10.0.0.5, port: 25252") | options
    return backend_settings(backend, options | knob_settings, file=backend_config)


def _execute(request: RunRequest, out: Path, as_json: bool, check: OutcomeCheck = OutcomeCheck(),
             explain: bool = False) -> None:
    """Run ``request`` into ``out`` and print its summary (as a table, or JSON), with ``explain`` its
    attribution (`simgap.cli.explain`); exit `simgap.cli.exit_codes.ExitCode.CHECK_FAILED` if the run
    failed or ``check`` fails."""
    if explain:     # the fork server of the explanation's worlds loads what a run imports during the run
        fork_server.start()
    if as_json:
        result = execute(request, out)
        if explain:
            from simgap.cli.explain import explanation
        typer.echo(json.dumps(result.summary() | ({"explanation": explanation(out)} if explain else {}), indent=2))
        _exit_on_failures(result, check, output_console(stderr=True))
        return
    console = output_console()
    with ProgressBars() as bars:      # the run's simulated time against its end, with the time left
        phase = f"{request.backend}: {Path(request.scenario).name}"
        result = execute(request, out, progress=lambda f: bars.update(phase, f, 1.0, f"{100 * f:.0f} %"))
    print_summary(console, result)
    console.print(f"run written to [bold]{out}[/bold]")
    if explain:
        from simgap.cli.explain import print_explanation

        print_explanation(console, out)
    _exit_on_failures(result, check, console)


def _exit_on_failures(result: RunRecord, check: OutcomeCheck, console: Console) -> None:
    """Exit `simgap.cli.exit_codes.ExitCode.CHECK_FAILED` if an agent fails ``check`` (saying which) or the run failed."""
    exit_on_failures(console, check.failures([CheckedRun(f"agent {a.id}", a.history.outcome, a.evaluation.score)
                                              for a in result.agents]), run_failed=bool(result.failure))


def _knobs(items: list[str], backend: str) -> dict[str, float]:
    """``--knob NAME=VALUE`` options as knob values, checked (each knob once)."""
    values: dict[str, float] = {}
    for item in items:
        name, _, text = (part.strip() for part in item.partition("="))
        k = knob(name)
        try:
            value = float(text)
        except ValueError:
            raise InputError(f"'{item}' is not NAME=NUMBER", field=f"knob {name}",
                             allowed=f"{k.low:g} to {k.high:g} {k.unit}") from None
        if name in values:
            raise InputError(f"given twice ({values[name]:g} and {value:g})", field=f"knob {name}",
                             allowed="each knob once")
        values[name] = value
        check_knob(name, value, value, where=f"knob {name}", backend=backend)
    return values


def print_summary(console: Console, result: RunRecord) -> None:
    table = Table(title=f"{result.scenario_id} — {result.history.backend}")
    budget = result.settings.cosim.planning_budget_s
    columns = ["agent", "planner", "vehicle", "outcome", "goal at [s]", "driven [m]", "gap [m]", "failed",
               "plan [ms]"] + (["> budget"] if budget else []) + ["score", "solution", "cost"]
    for col in columns:
        table.add_column(escape(col), justify="left" if col in ("planner", "vehicle", "outcome", "solution") else "right",
                         no_wrap=True)
    for agent in result.agents:
        h, a = agent.history, agent.evaluation
        colour = "green" if h.outcome == Outcome.GOAL_REACHED else "red"
        times = "—" if a.planning_mean_s is None else "/".join(     # (all three, or none: no call)
            f"{1000 * v:.1f}" for v in (a.planning_mean_s, a.planning_p95_s, a.planning_max_s) if v is not None)
        table.add_row(str(a.id), escape(agent.planner), h.vehicle.name, f"[{colour}]{h.outcome}[/{colour}]",
                      "—" if a.time_to_goal_s is None else f"{a.time_to_goal_s:.1f}",
                      f"{a.distance_m:.1f}",
                      "—" if a.min_distance_to_traffic_m is None else f"{a.min_distance_to_traffic_m:.2f}",
                      f"{h.planner_failures}" + (f" ({h.planner_exceptions} raised)" if h.planner_exceptions else ""),
                      times,
                      *([str(a.planning_over_budget)] if budget else []),
                      "—" if a.score is None else f"{a.score:.3f}", _validity(a.solution_valid),
                      "—" if a.solution_cost is None else f"{a.solution_cost:.0f}")
    console.print(table)
    console.print("gap: smallest distance to any other road user; failed: planning cycles without a plan "
                  "(none feasible, or the planner raised); plan: wall time per planning call, mean/p95/max"
                  + (f"; > budget: calls longer than {budget:g} s" if budget else "")
                  + "; score: closed-loop score (nuPlan's CLS); solution: the driven trajectory as a CommonRoad "
                  "solution (solution.xml), valid by commonroad-drivability-checker; cost: its cost function's "
                  "total", style="dim")
    for a in result.evaluation.agents:
        for line in score_lines(a):
            console.print(escape(line))
    for error in result.history.planner_errors[:1]:
        console.print(f"[red]agent {error.agent_id}'s planner raised {escape(error.exception)}"
                      f"{'' if error.t is None else f' at t = {error.t:.1f} s'}: {escape(error.message)}[/red] "
                      "(tracebacks in run.json, history.planner_errors)")
    phases = ", ".join(f"{k} {v:.2f} s" for k, v in result.all_timings.items())
    console.print(f"wall time {result.history.wall_time_s:.2f} s ({phases}); fingerprint {result.fingerprint}")
    if result.failure:
        console.print(f"[red]run failed: {result.failure}[/red]")


def _validity(valid: bool | None) -> str:
    return "[green]valid[/green]" if valid else "[red]invalid[/red]" if valid is False else "—"


def score_lines(a: AgentEvaluation) -> list[str]:
    """What an agent's score and cost are made of, in a line each."""
    if a.score is None:
        lines = [f"agent {a.id}: no score (it drove no step)"]
    else:
        outside = [k.removesuffix("_within") for k, v in a.score_measures.items() if k.endswith("_within") and not v]
        lost = [f"{name} {value:.3g}" + (f" ({', '.join(outside)} beyond bounds)" if name == "comfort" and outside
                                         else "") for name, value in a.score_components.items() if value < 1.0]
        lines = [f"agent {a.id}: score {a.score:.3f}" + (f", lost on {', '.join(lost)}" if lost else ", nothing lost")]
    if a.solution_partial_costs:
        terms = ", ".join(f"{name} {c.weighted:.0f} ({_partial(c.cost)} x {c.weight:g})"
                          for name, c in a.solution_partial_costs.items())
        lines.append(f"agent {a.id}: {a.solution_benchmark} cost {a.solution_cost:.0f} = {terms}")
    if a.solution_cost_error:
        lines.append(f"agent {a.id}: {a.solution_benchmark} cost not evaluated: {a.solution_cost_error}")
    if a.solution_valid is False:
        lines.append(f"agent {a.id}: solution invalid: {a.solution_reason}")
    return lines


def _partial(cost: float) -> str:
    """A partial cost to 3 significant digits; 0 below 1e-9 (a straight road's steering terms are
    rounding noise, ~1e-28, whose digits differ between machines)."""
    return "0" if abs(cost) < 1e-9 else f"{cost:.3g}"
