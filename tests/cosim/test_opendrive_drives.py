"""Public OpenDRIVE roads (tests/scenario/opendrive_roads: ASAM's and esmini's examples), each
imported with its route of routes.yaml and driven by the Frenet planner to the goal in the ideal
and the MuJoCo world: a junction turn, a motorway exit, a 2+1 merge, a crest, a banked loop."""

from __future__ import annotations

from pathlib import Path

import pytest
import yaml
from concrete_runs import drive

from simgap.cosim import Outcome
from simgap.scenario.opendrive.scenario import opendrive_scenario

ROADS = Path(__file__).parents[1] / "scenario" / "opendrive_roads"
ROUTES = yaml.safe_load((ROADS / "routes.yaml").read_text())


@pytest.mark.slow
@pytest.mark.parametrize("backend", ["ideal", "mujoco"])
@pytest.mark.parametrize("road", sorted(ROUTES))
def test_a_public_opendrive_road_is_driven_to_its_goal(road, backend):
    route = ROUTES[road]
    run, _ = drive(opendrive_scenario(ROADS / road, route["start"], route["goal"]), backend)
    (agent,) = run.agents
    assert agent.outcome is Outcome.GOAL_REACHED, (agent.outcome, run.failure)
    assert agent.max_road_excursion_m == 0.0
