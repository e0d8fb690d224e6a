"""The planner in the co-simulation loop, on a scenario from the scenario generator."""

from __future__ import annotations

import pytest
from evaluated import recorded

from simgap.cosim import simulate
from simgap.cosim.agents import agents_from_problems
from simgap.planning.frenet import FrenetPlanner
from simgap.planning.protocol import PlannerSetup
from simgap.sim.ideal import IdealBackend
from simgap.vehicles import load_vehicle

scenario_package = pytest.importorskip("simgap.scenario")


@pytest.mark.parametrize("params", [{"radius": 10, "angle": 90},
                                    {"radius": 10, "angle": -90, "initial_speed": 10}])
def test_ideal_run_reaches_the_goal(params):
    built = scenario_package.build_scenario("curve", params)
    scenario, problems = built.scenario, built.problems
    vehicle = load_vehicle("sedan")
    agents = agents_from_problems(problems, scenario.dt, vehicle)
    planners = {a.id: FrenetPlanner(PlannerSetup.for_problem(problems.planning_problem_dict[a.id], vehicle, scenario.lanelet_network))
                for a in agents}
    run = recorded(simulate(scenario, problems, IdealBackend(), agents, planners), scenario, problems)
    (agent,) = run.agents
    assert agent.history.outcome == "goal_reached", run.history.events
    assert agent.history.planner_failures == 0
    assert agent.evaluation.max_road_excursion_m == 0.0
