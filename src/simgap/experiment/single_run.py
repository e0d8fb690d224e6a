"""One run wired end to end: scenario file → agents → planners → backend → loop → run directory.

This is the one place where a concrete planner and a concrete backend meet; the CLI and the
batch executors call it.
"""

from __future__ import annotations

import importlib.metadata
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Mapping

from simgap.cosim import CosimSettings, Run, simulate
from simgap.cosim.agents import agents_from_problems
from simgap.cosim.driven_scenario import driven_scenario, scenario_xml
from simgap.errors import InputError
from simgap.evaluate.run_metrics import run_metrics
from simgap.experiment.knobs import knob_value
from simgap.experiment.records import PLANNER_VEHICLE
from simgap.planning.frenet import FrenetPlanner, FrenetSettings
from simgap.scenario import load_scenario, read_metadata
from simgap.sim.registry import make_backend
from simgap.vehicles import load_vehicle

VERSIONED_PACKAGES = ("simgap", "frenetix", "commonroad-io", "mujoco", "numpy")


@dataclass
class RunRequest:
    """What to run: a scenario file in a backend, with vehicles, planner and loop settings."""

    scenario: Path
    backend: str = "ideal"
    vehicles: str | Mapping[int, str] = "sedan"
    planner_vehicle: str = PLANNER_VEHICLE      # the vehicle the planner assumes it drives
    backend_settings: dict[str, Any] = field(default_factory=dict)
    planner: FrenetSettings = field(default_factory=FrenetSettings)
    cosim: CosimSettings = field(default_factory=CosimSettings)
    seed: int = 0


def software_versions() -> dict[str, str]:
    versions = {}
    for name in VERSIONED_PACKAGES:
        try:
            versions[name] = importlib.metadata.version(name)
        except importlib.metadata.PackageNotFoundError:
            pass
    return versions


def parse_vehicle_map(text: str) -> str | dict[int, str]:
    """``sedan`` (every agent) or ``1=sedan,2=suv`` (per planning problem id)."""
    if "=" not in text:
        return text
    mapping = {}
    for item in text.split(","):
        key, _, name = item.partition("=")
        try:
            mapping[int(key)] = name.strip()
        except ValueError:
            raise InputError(f"'{item}' is not AGENT_ID=VEHICLE", field="vehicle",
                             allowed="a vehicle name, or 1=sedan,2=suv") from None
    return mapping


def execute(request: RunRequest, out: Path | None = None,
            progress: Callable[[float], None] | None = None) -> Run:
    """Run ``request``; write the run directory to ``out`` when given."""
    scenario, problems = load_scenario(request.scenario)
    dt = float(scenario.dt)
    if isinstance(request.vehicles, str):
        vehicles: Any = load_vehicle(request.vehicles)
    else:
        vehicles = {pid: load_vehicle(name) for pid, name in request.vehicles.items()}
    agents = agents_from_problems(problems, dt, vehicles)
    planner_vehicle = load_vehicle(request.planner_vehicle)
    planners = {
        a.id: FrenetPlanner(planner_vehicle, scenario.lanelet_network,
                            problems.planning_problem_dict[a.id], request.planner)
        for a in agents
    }
    backend = make_backend(request.backend, **request.backend_settings)
    run = simulate(scenario, problems, backend, agents, planners, request.cosim, progress, seed=request.seed)
    meta = read_metadata(request.scenario)
    run.scenario_id = meta.get("name", Path(request.scenario).stem)
    run.scenario_path = str(request.scenario)
    run.parameters = meta.get("parameters", {})
    run.sections = meta.get("sections", {})
    run.versions = software_versions()
    run.seed = request.seed
    run.vehicles = {a.id: a.vehicle for a in agents}
    run.metrics = run_metrics(run, scenario, problems, knob_value("road_friction", request.backend_settings))
    run.settings |= {"parameter_units": meta.get("units", {}),
                     "planner": request.planner.model_dump(), "backend": request.backend_settings,
                     "planner_vehicle": request.planner_vehicle}
    if out is not None:
        t0 = time.perf_counter()
        xml = scenario_xml(driven_scenario(scenario, agents, run), problems)
        run.timings["io"] = time.perf_counter() - t0
        run.save(out, xml)
    return run
