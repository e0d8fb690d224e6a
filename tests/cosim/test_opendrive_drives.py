"""Public OpenDRIVE roads (tests/scenario/opendrive_roads: ASAM's and esmini's examples), each
imported with its route of routes.yaml and driven by the Frenet planner in the ideal and the MuJoCo
world: a junction turn, a motorway exit onto a climbing, banked ramp, a 2+1 merge, a crest, a
banked loop. The MuJoCo world stands on the file's elevation and superelevation: the car climbs the
crest, and on the velodrome's 60 degree bank, at the speed the flat plan chose, it slides off the
road down the bank, as it does at once on ASAM's 45 degree test slope (routes.yaml says which
outcome each world must give)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import yaml
from concrete_runs import drive

from simgap.cosim import Outcome
from simgap.scenario.ground import network_surface
from simgap.scenario.opendrive.scenario import opendrive_scenario

ROADS = Path(__file__).parents[1] / "scenario" / "opendrive_roads"
ROUTES = yaml.safe_load((ROADS / "routes.yaml").read_text())


@pytest.mark.slow
@pytest.mark.parametrize("backend", ["ideal", "mujoco"])
@pytest.mark.parametrize("road", sorted(ROUTES))
def test_a_public_opendrive_road_is_driven_to_its_goal(road, backend):
    route = ROUTES[road]
    concrete = opendrive_scenario(ROADS / road, route["start"], route["goal"])
    run, _ = drive(concrete, backend)
    (agent,) = run.agents
    expected = Outcome(route.get(backend, Outcome.GOAL_REACHED.value))
    assert agent.history.outcome is expected, (agent.history.outcome, run.failure)
    if expected is Outcome.GOAL_REACHED:
        assert agent.evaluation.max_road_excursion_m == 0.0
    if backend != "mujoco":
        return
    attitude = run.history.agent(agent.id).attitudes
    z = np.array([a.z for a in attitude])
    roll = np.degrees([a.roll for a in attitude])
    surface = network_surface(concrete.opendrive, concrete.scenario.lanelet_network)
    if surface is None:                            # a flat road: the car's height stays (its body rolls in turns)
        assert np.ptp(z) < 0.05
        return
    driven = run.history.driven[agent.id]
    ground = surface.surface(driven.x, driven.y)
    # the car's centre of gravity follows the file's ground: it stands its height off the surface,
    # along the normal (h / n_z above the ground below it), within 0.15 m (its suspension's travel:
    # on the velodrome's 60 degree bank the springs carry the car's weight half across them)
    stand = (z[0] - ground.z[0]) * ground.normal[0, 2]
    off = z - ground.z - stand / ground.normal[:, 2]
    assert np.abs(off).max() < 0.15, np.abs(off).max()
    if road == "velodrome.xodr":                   # it rolls with the 60 degree bank before it slides off
        assert np.abs(roll).max() > 55.0
