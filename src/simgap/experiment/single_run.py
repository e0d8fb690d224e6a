"""One run wired end to end: scenario file → agents → planners → backend → simulate → History →
evaluate → RunRecord → run directory.

This is the one place where a concrete planner and a concrete backend meet; the CLI and the
batch executors call it.
"""

from __future__ import annotations

import importlib.metadata
import os
import tempfile
import time
import warnings
from collections.abc import Callable, Mapping
from contextlib import ExitStack
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

from pydantic import BaseModel

from simgap.cosim import REFERENCE, CosimSettings, History, PlannerError, not_started, simulate
from simgap.cosim.agents import agents_from_problems
from simgap.cosim.driven_scenario import driven_scenario
from simgap.cosim.interruptions import PLANNER_CRASHES, RUN_STOPS, interruptions
from simgap.cosim.sensing import localisation_accuracy
from simgap.errors import InputError, validated
from simgap.evaluate import EvaluationSettings
from simgap.evaluate.run_evaluation import EvaluationContext, evaluate, solution_of, with_criticality, with_validity
from simgap.evaluate.solution import solution_xml
from simgap.evaluate.validity import SolutionCheckCache
from simgap.experiment.run_scene import RunScene, read_scene
from simgap.files import read_yaml_mapping
from simgap.planning.protocol import PlannerSetup
from simgap.planning.registry import PlannerAssignment, PlannerChoice, assignment_label, planner_of
from simgap.planning.remote import PlannerTarget, ProcessLimits
from simgap.record import DrivenScenarioFile, PlannerRecord, RunFiles, RunRecord, RunSettings, rewrite_record, write_run
from simgap.scenario.files import scenario_xml
from simgap.scenario.placement import AgentPlacement
from simgap.scenario.relief import road_tilt
from simgap.sim.registry import backend_settings, make_backend
from simgap.sim.settings import realism_of, road_friction
from simgap.vehicles import DEFAULT_VEHICLE, Vehicle, load_vehicle

VERSIONED_PACKAGES = ("simgap", "frenetix", "commonroad-io", "mujoco", "numpy")


@dataclass
class RunRequest:
    """What to run: a scenario file in a backend, with vehicles, planners and loop settings.

    ``backend_settings`` is the backend's settings model (`simgap.sim.registry.backend_settings`,
    validated where they were read), which goes to the backend as it is; a mapping given here
    (by a script) is validated into that model now, None means the backend's defaults."""

    scenario: Path
    backend: str = REFERENCE
    vehicles: str | Vehicle | Mapping[int, str | Vehicle] = DEFAULT_VEHICLE     # names, files or models
    planner_vehicle: str = DEFAULT_VEHICLE      # the vehicle the planner assumes it drives
    backend_settings: BaseModel | Mapping[str, Any] | None = None
    planner: PlannerAssignment = field(default_factory=PlannerChoice)   # one for all, or per agent id
    cosim: CosimSettings = field(default_factory=CosimSettings)
    evaluation: EvaluationSettings = field(default_factory=EvaluationSettings)   # cost function, score settings
    seed: int = 0
    validate: bool = False                     # check the solution's validity (slow; after the run is saved;
                                               # the CLI's commands ask for it unless --no-validate)
    check_cache: Path | None = None            # where validity verdicts are cached (None: the user's cache)
    run_timeout_s: float | None = None         # wall time the co-simulation may take (None: no limit)
    criticality: bool = True                   # evaluate the criticality of agent pairs (commonroad-crime; slow)
    replayed_latencies: Mapping[int, tuple[float, ...]] | None = None   # a record's plan latencies, which
                                               # replace the measured ones (`simgap.experiment.replay`)
    placement: AgentPlacement | None = None    # one agent from a start to a goal, in place of the scenario's
                                               # planning problems (a map without any: --start and --goal)
    flat_road: bool = False                    # the scenario's road without its relief or a tilt: its flat twin
                                               # (the relief assumption restored, `simgap.experiment.attribution`)

    def __post_init__(self) -> None:
        if not isinstance(self.backend_settings, BaseModel):
            self.backend_settings = backend_settings(self.backend, self.backend_settings)


def software_versions() -> dict[str, str]:
    versions = {}
    for name in VERSIONED_PACKAGES:
        try:
            versions[name] = importlib.metadata.version(name)
        except importlib.metadata.PackageNotFoundError:
            pass
    return versions


def parse_agent_map(text: str, what: str = "vehicle", example: str = "1=sedan,2=suv") -> str | dict[int, str]:
    """``NAME`` (every agent) or ``1=NAME,2=OTHER`` (per planning problem id), for ``--vehicle``
    and ``--planner``."""
    if "=" not in text or PlannerTarget.parse(text.strip()) is not None:     # a command may hold "=" and ","
        return text.strip()
    mapping = {}
    for item in text.split(","):
        key, _, name = item.partition("=")
        try:
            agent = int(key)
        except ValueError:
            raise InputError(f"'{item}' is not AGENT_ID={what.upper()}", field=what,
                             allowed=f"a {what} for every agent, or {example}") from None
        if agent in mapping:
            raise InputError(f"agent {agent} is given a {what} twice", field=what,
                             allowed=f"one {what} per agent, as {example}")
        mapping[agent] = name.strip()
        if not name.strip():
            raise InputError(f"'{item}' names no {what}", field=what, allowed=f"a {what}, or {example}")
    return mapping


def parse_planners(text: str, settings_file: Path | None = None, isolate: bool = False,
                   process: ProcessLimits | None = None) -> PlannerAssignment:
    """``--planner`` and ``--planner-config`` as a planner assignment, every planner loaded and its
    settings validated (errors name the file and the field); ``isolate`` runs every planner class
    in a process of its own (refused where no planner is a class: exec: and addresses have theirs), ``process`` limits every planner in its own process.

    The settings file holds the settings of the planner when one planner drives every agent (or
    every agent named); with several different planners, it maps each planner, as ``--planner``
    names it, to its settings (``{frenet: {speed: {cruise_m_s: 8}}, idm: {...}}``).
    """
    parsed = parse_agent_map(text, "planner", "1=frenet,2=idm")
    refs = list(dict.fromkeys([parsed] if isinstance(parsed, str) else parsed.values()))
    settings: dict[str, dict] = {ref: {} for ref in refs}
    if settings_file is not None:
        raw = read_yaml_mapping(settings_file, "planner settings file", empty_ok=True)
        if len(refs) == 1:
            settings[refs[0]] = raw
        else:
            for ref, values in raw.items():
                if ref not in settings or not isinstance(values, dict):
                    raise InputError(f"with several planners the file maps each planner to its settings; "
                                     f"'{ref}' is not one of them" if ref not in settings else
                                     f"the settings of '{ref}' are not a mapping", file=settings_file,
                                     field=str(ref), allowed=", ".join(refs))
                settings[ref] = values
    if isolate and all(PlannerTarget.parse(ref) is not None for ref in refs):
        raise InputError(f"'{refs[0]}' runs in a process of its own already; --isolate is for planner classes",
                         field="isolate", allowed="a planner class (a name, module:Class or file.py:Class), "
                                                  "or no --isolate")
    choices = {}
    for ref in refs:
        own_process = isolate and PlannerTarget.parse(ref) is None
        choice = validated(PlannerChoice, dict(planner=ref, settings=settings[ref], isolate=own_process,
                                               process=process or ProcessLimits()), file=settings_file)
        choice.load(file=settings_file, settings_field="" if len(refs) == 1 else ref)
        choices[ref] = choice
    if isinstance(parsed, str):
        return choices[parsed]
    return {aid: choices[ref] for aid, ref in parsed.items()}


def _check_agents_assigned_exist(request: RunRequest, agent_ids: list[int]) -> None:
    """A per-agent vehicle or planner names only agents (planning problems) of the scenario."""
    for what, assignment in (("vehicle", request.vehicles), ("planner", request.planner)):
        unknown = sorted(set(assignment) - set(agent_ids)) if isinstance(assignment, dict) else []
        if unknown:
            raise InputError(f"agent {unknown[0]} is not in the scenario", file=request.scenario, field=what,
                             allowed="planning problem ids " + ", ".join(map(str, agent_ids)))


def scene_of(request: RunRequest) -> RunScene:
    """The scenario ``request`` runs, read once (`simgap.experiment.run_scene`)."""
    scene = read_scene(Path(request.scenario), request.placement, request.flat_road, request.cosim.offroad_tolerance,
                       road_tilt(request.backend_settings))
    _check_agents_assigned_exist(request, scene.agent_ids)
    return scene


def execute(request: RunRequest, out: Path | None = None,
            progress: Callable[[float], None] | None = None) -> RunRecord:
    """Run ``request`` — simulate, evaluate, record — and write the run directory to ``out`` when given."""
    scene = scene_of(request)
    if request.placement is None:
        return _execute(request, scene, scene.file, out, progress)
    with tempfile.TemporaryDirectory(prefix="simgap-placed-") as tmp:     # the scenario the solution is checked in
        placed = Path(tmp) / scene.file.name
        with warnings.catch_warnings():       # a map's sign of a country commonroad-io does not know: said on reading
            warnings.simplefilter("ignore")
            placed.write_text(scenario_xml(scene.read, scene.problems))
        return _execute(request, scene, placed, out, progress)


@dataclass(frozen=True)
class Simulated:
    """What a run's co-simulation gives, before it is evaluated: its history on its scene, and what
    the record says of its planners."""

    history: History
    scene: RunScene
    planner_records: dict[int, PlannerRecord]
    planner_vehicle: Vehicle


def simulated(request: RunRequest) -> Simulated:
    """``request``'s co-simulation alone: no evaluation, no record (what a counterfactual world of
    `simgap.experiment.attribution` needs of a run; `execute` does the rest)."""
    return _simulated(request, scene_of(request), None)


def _execute(request: RunRequest, scene: RunScene, scenario_file: Path, out: Path | None,
             progress: Callable[[float], None] | None) -> RunRecord:
    """`execute` on ``scene`` (``scenario_file``: a file that holds its scenario and planning
    problems, for the solution's checks)."""
    out = None if out is None else Path(out).absolute()     # a planner's os.chdir does not move it
    run = _simulated(request, scene, progress)
    history, sidecar = run.history, scene.sidecar
    settings = RunSettings(
        scenario_id=sidecar.name if sidecar.name is not None else scene.file.stem, cosim=request.cosim,
        evaluation=request.evaluation,
        planner=_planner_record(request.planner, run.planner_records), scenario_path=str(request.scenario),
        parameters=sidecar.parameters, parameter_units=sidecar.units,
        sections=sidecar.sections, backend=request.backend_settings,
        sensing_accuracy=localisation_accuracy(request.cosim.sensing, history.realism),
        planner_vehicle=request.planner_vehicle, recorded_as=scene.recorded_egos, seed=request.seed,
        versions=software_versions())
    context = EvaluationContext(scene.scenario, scene.problems, request.evaluation, request.cosim.offroad_tolerance,
                                request.cosim.planning_budget_s, road_friction(request.backend_settings),
                                run.planner_vehicle, scene.relief, scenario_file, scene.road, scene.obstacles)
    clock = time.perf_counter()
    evaluation = evaluate(history, context)
    timings = {"scoring": time.perf_counter() - clock}
    if request.criticality and len(history.agents) > 1:
        clock = time.perf_counter()
        evaluation = with_criticality(evaluation, history, context)
        timings["criticality"] = time.perf_counter() - clock
    if out is not None:
        t0 = time.perf_counter()
        driven = DrivenScenarioFile(scenario_xml(driven_scenario(scene.scenario, history), scene.problems), sidecar)
        timings["io"] = time.perf_counter() - t0
        write_run(RunFiles(RunRecord(history, evaluation, settings, timings), driven,
                           solution_xml(solution_of(history, context))), out)
    if request.validate:           # the slow check, once the run is safe on disk
        clock = time.perf_counter()
        evaluation = with_validity(evaluation, history, context, SolutionCheckCache(request.check_cache))
        timings["validation"] = time.perf_counter() - clock
    record = RunRecord(history, evaluation, settings, timings)
    if out is not None and request.validate:
        rewrite_record(record, out)
    return record


def _simulated(request: RunRequest, scene: RunScene, progress: Callable[[float], None] | None) -> Simulated:
    """The co-simulation of ``request`` on ``scene``."""
    scenario, problems = scene.scenario, scene.problems
    dt = float(scenario.dt)
    if isinstance(request.vehicles, (str, Vehicle)):
        vehicles: Any = _vehicle(request.vehicles)
    else:
        vehicles = {pid: _vehicle(v) for pid, v in request.vehicles.items()}
    agents = agents_from_problems(problems, dt, vehicles)
    planner_vehicle = load_vehicle(request.planner_vehicle)
    planners, errors, planner_records = {}, [], {}
    folder = os.getcwd()        # a planner's os.chdir does not move it
    with ExitStack() as closing:     # planners in their own process are closed (and ended) whatever happens
        closing.callback(_back_in, folder)
        for a in agents:
            choice = planner_of(request.planner, a.id, [b.id for b in agents])
            planner_class, settings = choice.load()
            planner_records[a.id] = PlannerRecord(choice.name, choice.planner,
                                                  settings.model_dump(mode="json") if isinstance(settings, BaseModel)
                                                  else dict(settings or {}))
            setup = PlannerSetup(a.id, planner_vehicle, scenario.lanelet_network,
                                 problems.planning_problem_dict[a.id], dt, planner_records[a.id].settings)
            try:
                with interruptions():
                    planners[a.id] = planner_class.build(setup, settings)
            except RUN_STOPS:
                raise
            except PLANNER_CRASHES as exc:  # the planner's own bug (or exit): this run fails, recorded, the batch goes on
                errors.append(PlannerError.of(exc, a.id, None))
                continue
            closing.callback(planners[a.id].close)
        _back_in(folder)
        if errors:
            history = not_started(scenario, request.backend, agents, errors, realism_of(request.backend_settings))
        else:
            backend = make_backend(request.backend, request.backend_settings)
            history = simulate(scenario, problems, backend, agents, planners, request.cosim, progress,
                               seed=request.seed, wall_time_limit_s=request.run_timeout_s, relief=scene.relief,
                               replayed_latencies=request.replayed_latencies, road=scene.road,
                               obstacles=scene.obstacles)
        for aid, planner in planners.items():
            planner_records[aid] = replace(planner_records[aid], process=planner.report())
    return Simulated(history, scene, planner_records, planner_vehicle)


def _vehicle(vehicle: str | Vehicle) -> Vehicle:
    return vehicle if isinstance(vehicle, Vehicle) else load_vehicle(vehicle)


def _back_in(folder: str) -> None:
    """Back in the working folder ``folder`` when a planner moved simgap's process out of it."""
    if os.getcwd() != folder:
        os.chdir(folder)


def _planner_record(planners: PlannerAssignment, planner_records: dict[int, PlannerRecord]) -> PlannerRecord:
    """The record of the planner of every agent (``agents`` per agent id when they differ)."""
    if isinstance(planners, PlannerChoice):
        return next(iter(planner_records.values())) if planner_records else PlannerRecord(planners.name, planners.planner)
    return PlannerRecord(assignment_label(planners), agents=planner_records)
