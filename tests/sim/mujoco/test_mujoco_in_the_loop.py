"""The MuJoCo backend in the co-simulation loop, and the events it reports."""

from __future__ import annotations

import numpy as np
import pyarrow.parquet as pq
import pytest
from commonroad.geometry.shape import Rectangle
from commonroad.prediction.prediction import TrajectoryPrediction
from commonroad.scenario.obstacle import DynamicObstacle, ObstacleType
from commonroad.scenario.state import InitialState, KSState
from commonroad.scenario.trajectory import Trajectory as CrTrajectory

from simgap.cosim import CosimSettings
from simgap.errors import InputError
from simgap.experiment.single_run import RunRequest, execute
from simgap.scenario import build_scenario
from simgap.scenario.files import write_scenario
from simgap.sim.mujoco import MujocoBackend
from simgap.sim.mujoco.plant import proving_ground
from simgap.sim.mujoco.settings import mujoco_settings
from simgap.sim.protocol import Agent
from simgap.sim.registry import backend_settings
from simgap.trajectory import State, Trajectory
from simgap.vehicles import load_vehicle, vehicle_names


@pytest.fixture(scope="module")
def sharp_curve(tmp_path_factory):
    out = tmp_path_factory.mktemp("scenarios")
    return write_scenario(build_scenario("curve", {"radius": 10, "angle": 90}), out, preview=False)


@pytest.mark.parametrize("vehicle_name", vehicle_names())
def test_every_vehicle_drives_the_sharp_curve_to_its_goal(sharp_curve, vehicle_name, tmp_path):
    # the perfect machine: the physics alone (the suv's real steering, 0.24 s + 0.27 s, leaves this
    # curve's lane by 1.4 cm: tests/cosim/test_realism.py and bench/vehicles/realism.py measure the real cars)
    run = execute(RunRequest(scenario=sharp_curve, backend="mujoco", vehicles=vehicle_name,
                             backend_settings=backend_settings("mujoco", {"realism": "ideal"})), tmp_path / "run")
    agent = run.agents[0]
    assert agent.history.outcome == "goal_reached", run.history.events
    assert agent.evaluation.max_road_excursion_m == 0.0
    driven = run.history.driven[agent.id]
    assert driven.path_length() > 150.0
    assert run.history.timings["physics"] > 0 and run.history.timings["control"] > 0


def test_two_identical_runs_are_bit_identical(sharp_curve, tmp_path):
    # a fixed plan latency: the measured one depends on the machine's speed when a planning call
    # overruns its cycle (a loaded machine), and this test is about the physics
    request = RunRequest(scenario=sharp_curve, backend="mujoco", vehicles="city", cosim=CosimSettings(latency=0.1))
    execute(request, tmp_path / "a")
    execute(request, tmp_path / "b")
    a = pq.read_table(tmp_path / "a" / "trajectories.parquet")
    b = pq.read_table(tmp_path / "b" / "trajectories.parquet")
    assert a.num_rows > 100 and a.schema == b.schema
    for name in a.schema.names:        # plan_t is NaN on driven rows; NaN == NaN here
        x, y = a[name].to_numpy(), b[name].to_numpy()
        assert np.array_equal(x, y, equal_nan=x.dtype.kind == "f"), name


def _straight(state: State, n: int = 31, dt: float = 0.1) -> Trajectory:
    """Constant speed straight ahead from ``state``."""
    return Trajectory.from_states([state.replace(t=state.t + k * dt, x=state.x + np.cos(state.yaw) * state.v * k * dt,
                                                 y=state.y + np.sin(state.yaw) * state.v * k * dt, steer=0.0)
                                   for k in range(n)], dt)


def _drive_until_collision(backend: MujocoBackend, seconds: float = 5.0):
    states = backend.reset()
    for _ in range(int(seconds / 0.1)):
        states = backend.step({aid: _straight(st) for aid, st in states.items()})
        events = backend.events()
        if events:
            return events, states
    return [], states


def test_a_head_on_crash_is_reported_as_a_collision_of_both_cars():
    sedan = load_vehicle("sedan")
    backend = MujocoBackend()
    backend.load(proving_ground(), [Agent(1, sedan, State(0.0, 0.0, 0.0, 0.0, 8.0)),
                                    Agent(2, sedan, State(0.0, 30.0, 0.3, np.pi, 8.0))])
    events, states = _drive_until_collision(backend)
    assert {(e.agent_id, e.other_id, e.kind) for e in events} == {(1, 2, "collision"), (2, 1, "collision")}
    # contact when the fronts meet: 30 m apart closing at 16 m/s, cars 4.5 m long
    assert events[0].t == pytest.approx((30.0 - sedan.length) / 16.0, abs=0.15)
    assert "agent 2" in next(e.detail for e in events if e.agent_id == 1)


def test_recorded_traffic_is_a_body_a_car_can_hit():
    scenario = proving_ground()
    states = [KSState(time_step=k, position=np.array([40.0, 0.0]), orientation=0.0, velocity=0.0,
                      steering_angle=0.0) for k in range(1, 100)]
    obstacle = DynamicObstacle(
        7, ObstacleType.CAR, Rectangle(4.0, 1.8),
        InitialState(time_step=0, position=np.array([40.0, 0.0]), orientation=0.0, velocity=0.0,
                     acceleration=0.0, yaw_rate=0.0, slip_angle=0.0),
        TrajectoryPrediction(CrTrajectory(1, states), Rectangle(4.0, 1.8)))
    scenario.add_objects(obstacle)
    backend = MujocoBackend()
    backend.load(scenario, [Agent(1, load_vehicle("suv"), State(0.0, 0.0, 0.0, 0.0, 10.0))])
    events, states = _drive_until_collision(backend)
    assert [(e.agent_id, e.other_id) for e in events] == [(1, 7)]
    # the box stood its ground: the car stopped at it, not through it
    assert states[1].x < 40.0 - 2.0


def test_a_blown_up_physics_is_a_failed_run_with_its_reason(sharp_curve, tmp_path, monkeypatch):
    original = MujocoBackend.step
    calls = {"n": 0}

    def exploding_step(self, plans):
        calls["n"] += 1
        if calls["n"] == 20:
            self.world.data.qvel[:] = np.nan
        return original(self, plans)

    monkeypatch.setattr(MujocoBackend, "step", exploding_step)
    run = execute(RunRequest(scenario=sharp_curve, backend="mujoco", vehicles="sedan"), tmp_path / "run")
    assert run.agents[0].history.outcome == "diverged"
    event = next(e for e in run.history.events if e.kind == "diverged")
    assert "no longer finite" in event.detail and event.t == pytest.approx(1.9, abs=1e-6)
    assert (tmp_path / "run" / "run.json").exists()


def test_a_car_that_flips_is_taken_out_and_the_others_drive_on(tmp_path, monkeypatch):
    """One car's chassis turned on its roof (as a start inside recorded traffic does): that car
    ends ``diverged`` with where it happened, it leaves the world, and the other cars of the run
    reach their goals; the run itself has not failed."""
    path = write_scenario(build_scenario("intersection", {"agents": 2}), tmp_path, preview=False)
    original = MujocoBackend.step
    calls = {"n": 0}

    def flipping_step(self, plans):
        calls["n"] += 1
        if calls["n"] == 10:
            car = self.world.cars[min(plans)]
            self.world.data.qpos[car.qpos + 3:car.qpos + 7] = [0.0, 1.0, 0.0, 0.0]     # upside down
        return original(self, plans)

    monkeypatch.setattr(MujocoBackend, "step", flipping_step)
    run = execute(RunRequest(scenario=path, backend="mujoco", vehicles="sedan"), tmp_path / "run")
    flipped, other = sorted(run.agents, key=lambda a: a.id)
    assert run.failure is None
    assert flipped.history.outcome == "diverged" and other.history.outcome == "goal_reached", run.history.events
    event = next(e for e in run.history.events if e.kind == "diverged")
    assert event.agent_id == flipped.id and "on its side or roof" in event.detail and event.t == pytest.approx(1.0)
    assert flipped.evaluation.max_road_excursion_m == 0.0          # parked far beyond the road, not judged there


def test_a_30_hz_recording_runs_at_fitted_controller_and_physics_rates(tmp_path):
    """A recording at 30 Hz (highD, inD, SinD): the default 100 Hz controller does not divide its
    step, so the controller runs at 90 Hz and physics at 540 Hz, and the run says so; a rate the
    user set that does not fit stays an error."""
    concrete = build_scenario("curve", {"radius": 50, "angle": 30})
    concrete.scenario.dt = 1 / 30
    path = write_scenario(concrete, tmp_path, preview=False)
    run = execute(RunRequest(scenario=path, backend="mujoco", vehicles="sedan"), tmp_path / "run")
    assert run.agents[0].history.outcome == "goal_reached", run.history.events
    notes = " ".join(run.history.backend_notes)
    assert "controller at 90 Hz" in notes and "physics at 540 Hz" in notes
    backend = MujocoBackend(mujoco_settings({"controller_hz": 100}))
    with pytest.raises(InputError, match="controller_hz"):
        backend.fit_rates(backend.settings, 1 / 30)
    backend = MujocoBackend(mujoco_settings({"physics_hz": 500}))
    with pytest.raises(InputError, match="physics_hz"):
        backend.fit_rates(backend.settings, 1 / 30)
