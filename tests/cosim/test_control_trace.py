"""What the controller asked and what the car did, per control tick: recorded by a physical world
in the run's history and its trajectories file, none in the ideal world; a late steering shows as
a late road-wheel angle."""

from __future__ import annotations

import pickle

import numpy as np
import pytest

from concrete_runs import drive
from simgap.record import read_run, write_run
from simgap.scenario import build_scenario

EXACT = {"sensing": {"profile": "perfect"}, "latency": 0.0}
PROMPT_PEDALS = {"steer_lag": 0.0, "pedal_delay": 0.0, "pedal_lag": 0.0}


@pytest.fixture(scope="module")
def sharp_curve():
    return build_scenario("curve", {"radius": 10, "angle": 90})


def steering_lag_s(trace) -> float:
    """The shift of the road-wheel angle behind the requested one that correlates them best."""
    asked = trace.steer_requested - trace.steer_requested.mean()
    had = trace.steer_at_wheels - trace.steer_at_wheels.mean()
    shifts = np.arange(0, 100)
    correlation = [np.dot(asked[:len(asked) - k], had[k:]) / (len(asked) - k) for k in shifts]
    return float(shifts[int(np.argmax(correlation))] * (trace.t[1] - trace.t[0]))


def test_the_ideal_world_records_no_commands(sharp_curve):
    run, _ = drive(sharp_curve, "ideal", cosim={"max_time_s": 2.0})
    assert run.history.agents[0].controls is None


def test_a_physical_run_records_its_commands_per_control_tick_and_they_reload_equal(sharp_curve, tmp_path):
    run, _ = drive(sharp_curve, "dynamic", settings=PROMPT_PEDALS, cosim=EXACT)
    agent = run.history.agents[0]
    trace = agent.controls
    assert agent.outcome == "goal_reached"
    assert np.diff(trace.t) == pytest.approx(0.01)                  # the controller's 100 Hz
    assert trace.t[0] == 0.0 and trace.t[-1] <= agent.driven.t_end  # until its outcome
    assert np.abs(trace.steer_requested).max() > 0.1                # it steered through the curve
    # with prompt pedals the car mostly does what the pedals ask (not at the stop, where it holds)
    moving = np.interp(trace.t, agent.driven.t, agent.driven.v) > 1.0
    assert np.median(np.abs(trace.accel_requested - trace.accel_achieved)[moving]) < 0.2
    write_run(run, tmp_path / "run")
    again = read_run(tmp_path / "run").history.agents[0].controls
    assert again == trace
    assert pickle.loads(pickle.dumps(run)).history.agents[0].controls == trace


def test_a_late_steering_shows_as_a_road_wheel_angle_that_lags_the_request(sharp_curve):
    prompt, _ = drive(sharp_curve, "dynamic", settings=PROMPT_PEDALS | {"steer_delay": 0.0}, cosim=EXACT)
    late, _ = drive(sharp_curve, "dynamic", settings=PROMPT_PEDALS | {"steer_delay": 0.3}, cosim=EXACT)
    prompt_lag = steering_lag_s(prompt.history.agents[0].controls)
    late_lag = steering_lag_s(late.history.agents[0].controls)
    # measured: 0.11 s (the plant's steering servo and rate limit) and 0.41 s
    assert late_lag - prompt_lag == pytest.approx(0.3, abs=0.03)
    assert prompt_lag < 0.15
