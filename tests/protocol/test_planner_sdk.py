"""One planner SDK: a planner written against `simgap_planner`'s types runs unchanged in simgap's
process and in its own, and drives the same run both ways; simgap's own types carry every field
the SDK documents."""

from __future__ import annotations

import dataclasses
import sys
from pathlib import Path

import numpy as np
import pytest
import simgap_planner
from simgap_planner.messages import setup_of

from simgap.cosim import CosimSettings
from simgap.experiment.single_run import RunRequest, execute
from simgap.planning.protocol import PlannerSetup, TrafficParticipant, World
from simgap.planning.registry import PlannerChoice
from simgap.planning.remote import initialize_message
from simgap.scenario.files import load_scenario
from simgap.trajectory import State, Trajectory
from simgap.vehicles import load_vehicle

KEEP_LANE = Path(__file__).resolve().parents[2] / "examples" / "remote_planner" / "keep_lane.py"


def documented(sdk_type: type) -> list[str]:
    """The fields and properties a planner may use of one of the SDK's types (those it documents)."""
    fields = [f.name for f in dataclasses.fields(sdk_type) if "doc" in f.metadata] \
        if dataclasses.is_dataclass(sdk_type) else []
    return fields + [name for name, value in vars(sdk_type).items()
                     if isinstance(value, property) and value.__doc__ and not name.startswith("_")]


def test_the_docs_example_drives_the_same_run_in_process_and_in_its_own(curve_xml, tmp_path):
    cosim = CosimSettings(latency=0.1)          # fixed: the planner's compute time does not move the car
    settings = {"speed_m_s": 6.0}               # read from setup.settings both ways
    runs = {how: execute(RunRequest(scenario=curve_xml, backend="dynamic", cosim=cosim,
                                    planner=PlannerChoice(planner=planner, settings=settings)), tmp_path / how)
            for how, planner in (("in_process", f"{KEEP_LANE}:KeepLane"),
                                 ("own_process", f"exec:{sys.executable} {KEEP_LANE}"))}
    in_process, own_process = runs["in_process"], runs["own_process"]
    assert in_process.agents[0].history.outcome == own_process.agents[0].history.outcome == "goal_reached"
    assert 5.0 < max(in_process.agents[0].history.driven.v) < 6.5, "it cruises at the speed its settings give"
    assert in_process.settings.planner.process is None
    assert own_process.settings.planner.process.protocol_version == simgap_planner.PROTOCOL_VERSION
    assert own_process.agents[0].history.planner_failures == 0 and len(own_process.agents[0].history.driven) > 20
    assert own_process.fingerprint == in_process.fingerprint


@pytest.fixture(scope="module")
def both_setups(curve_xml):
    """An agent's setup as simgap builds it in process, and as the SDK rebuilds it from Initialize."""
    scenario, problems = load_scenario(curve_xml)
    problem = next(iter(problems.planning_problem_dict.values()))
    setup = PlannerSetup(problem.planning_problem_id, load_vehicle("sedan"), scenario.lanelet_network, problem,
                         float(scenario.dt), {"speed_m_s": 6.0})
    message = initialize_message(setup, '{"speed_m_s": 6.0}')
    return setup, setup_of(message.initialize)


def test_simgap_s_types_carry_every_field_the_sdk_documents(both_setups):
    setup, sdk_setup = both_setups
    trajectory = Trajectory.from_states([State(0.0, 0.0, 0.0, 0.0, 1.0), State(0.1, 0.1, 0.0, 0.0, 1.0)], 0.1)
    participant = TrafficParticipant(7, 4.5, 1.8, trajectory)
    world = World(setup.lanelet_network, setup.planning_problem.goal, setup.dt, (participant,))
    pairs = [(simgap_planner.Setup, setup), (simgap_planner.Vehicle, setup.vehicle),
             (simgap_planner.VehicleLimits, setup.vehicle.limits), (simgap_planner.State, State(0.0, 0.0, 0.0, 0.0, 1.0)),
             (simgap_planner.World, world), (simgap_planner.Participant, participant)]
    for sdk_type, ours in pairs:
        names = documented(sdk_type)
        assert names, f"{sdk_type.__name__} documents its fields"
        missing = [n for n in names if not hasattr(ours, n)]
        assert not missing, f"simgap's {type(ours).__name__} lacks the SDK's {sdk_type.__name__} fields {missing}"
    sdk_trajectory = simgap_planner.Trajectory(0.1, t=[0.0, 0.1], x=[0.0, 0.1])
    for name in ("dt", *simgap_planner.STATE_FIELDS):
        assert hasattr(sdk_trajectory, name) and hasattr(trajectory, name), f"both trajectories have {name}"


def test_the_two_setups_hold_the_same_values(both_setups):
    setup, sdk_setup = both_setups
    assert np.array_equal(sdk_setup.route, setup.route) and len(setup.route) > 10
    assert sdk_setup.vehicle.limits == simgap_planner.VehicleLimits(**setup.vehicle.limits.model_dump())
    assert sdk_setup.vehicle.max_steer == setup.vehicle.limits.max_steer     # the SDK 1.0's name still answers
    assert sdk_setup.vehicle.data == setup.vehicle.data
    assert sdk_setup.settings == dict(setup.settings) == {"speed_m_s": 6.0}
    assert (sdk_setup.agent_id, sdk_setup.dt, sdk_setup.commonroad_xml) == (setup.agent_id, setup.dt,
                                                                           setup.commonroad_xml)
    ours = {lanelet.lanelet_id: lanelet.center_vertices for lanelet in setup.lanelet_network.lanelets}
    theirs = {lanelet.lanelet_id: lanelet.center_vertices for lanelet in sdk_setup.lanelet_network.lanelets}
    assert ours.keys() == theirs.keys() and all(np.allclose(ours[k], theirs[k], atol=1e-7) for k in ours)
    assert sdk_setup.planning_problem.planning_problem_id == setup.agent_id
