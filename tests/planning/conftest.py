"""Fixtures of the planner tests: the sedan, the paper's roads, planners built on them."""

from __future__ import annotations

import pytest
from planner_roads import two_lane_road

from simgap.planning.frenet import FrenetPlanner
from simgap.planning.protocol import PlannerSetup
from simgap.vehicles import load_vehicle


@pytest.fixture(scope="session")
def sedan():
    return load_vehicle("sedan")


@pytest.fixture(scope="session")
def straight_road():
    return two_lane_road(radius=10.0, angle_deg=0.0)


@pytest.fixture(scope="session")
def curve_road():
    """The sharp curve: r = 10 m, 90 degrees to the left."""
    return two_lane_road(radius=10.0, angle_deg=90.0)


@pytest.fixture(scope="session")
def curve_planner(sedan, curve_road):
    return FrenetPlanner(PlannerSetup.for_problem(curve_road.problem, sedan, curve_road.lanelet_network))


@pytest.fixture(scope="session")
def straight_planner(sedan, straight_road):
    return FrenetPlanner(PlannerSetup.for_problem(straight_road.problem, sedan, straight_road.lanelet_network))
