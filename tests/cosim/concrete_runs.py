"""A concrete scenario driven by the Frenet planner in one backend: the run and its run metrics
(the helper of the tests that measure what a reality setting does to the drive)."""

from __future__ import annotations

from collections.abc import Callable

from evaluated import recorded

from simgap.cosim import CosimSettings, simulate
from simgap.cosim.agents import agents_from_problems
from simgap.evaluate.run_metrics import run_metrics
from simgap.planning.frenet import FrenetPlanner
from simgap.planning.protocol import PlannerSetup
from simgap.scenario.ground import ground_of
from simgap.scenario.relief import road_tilt
from simgap.sim.registry import backend_settings, make_backend
from simgap.sim.settings import road_friction
from simgap.vehicles import load_vehicle


def drive(concrete, backend: str, settings: dict | None = None, cosim: dict | None = None, seed: int = 0,
          planner_of: Callable = lambda planner: planner):
    """``concrete`` in ``backend`` with the sedan, on its ground (a relief or an imported network's
    heights, the world's tilt laid on a generated road, as `simgap run` builds it); ``planner_of`` may
    wrap each agent's planner."""
    scenario, problems = concrete.scenario, concrete.problems
    settings = settings or {}
    sedan = load_vehicle("sedan")
    agents = agents_from_problems(problems, scenario.dt, sedan)
    planners = {a.id: planner_of(FrenetPlanner(PlannerSetup.for_problem(problems.planning_problem_dict[a.id], sedan,
                                                                        scenario.lanelet_network)))
                for a in agents}
    loop = CosimSettings(**(cosim or {}))
    model = backend_settings(backend, settings)
    history = simulate(scenario, problems, make_backend(backend, model), agents, planners,
                       loop, seed=seed, relief=ground_of(concrete.sidecar, scenario.lanelet_network, road_tilt(model)))
    return (recorded(history, scenario, problems, loop),
            run_metrics(history, scenario, problems, road_friction(model)))
