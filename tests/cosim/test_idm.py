"""Recorded traffic driven by the IDM: undisturbed it is the recording; blocked, it stops behind."""

from __future__ import annotations

import pytest
from real_like import DT, highway, recorded_car

from simgap.cosim.idm import IdmTraffic
from simgap.planning.protocol import TrafficParticipant
from simgap.trajectory import State, Trajectory


def _drive(traffic: IdmTraffic, steps: int, agents=None) -> None:
    for k in range(steps):
        traffic.advance(k * DT, DT, agents or {})


def test_undisturbed_it_keeps_to_its_recording():
    scenario = highway(lanes=1, length=300, segments=1)
    scenario.add_objects(recorded_car(700, 20, 0, 12.0, 200))
    traffic = IdmTraffic(scenario)
    _drive(traffic, 80)
    state, _, _ = traffic.poses(8.0)[700]
    assert state.x == pytest.approx(20 + 12.0 * 8.0, abs=1e-6) and state.v == pytest.approx(12.0)


def test_a_standing_agent_on_its_path_stops_it_behind():
    scenario = highway(lanes=1, length=300, segments=1)
    scenario.add_objects(recorded_car(700, 20, 0, 12.0, 200))
    standing = State(0.0, 100.0, 1.75, 0.0, 0.0)
    agent = TrafficParticipant(1, 4.5, 1.8, Trajectory.from_states([standing], DT))
    traffic = IdmTraffic(scenario)
    _drive(traffic, 150, {1: agent})
    state, length, _ = traffic.poses(15.0)[700]
    gap = 100.0 - 4.5 / 2 - (state.x + length / 2)
    assert state.v == pytest.approx(0.0, abs=0.05)
    assert 0.5 < gap < 5.0
