"""What the controller asked and what the car did, per control tick: recorded by a physical world
in the run's history and its trajectories file, none in the ideal world; a late steering shows as
a late road-wheel angle; the run's timeline reads it, with the plan latencies and the sensing
error, from the record."""

from __future__ import annotations

import pickle

import numpy as np
import pyarrow.parquet as pq
import pytest
from concrete_runs import drive

from simgap.errors import InputError
from simgap.evaluate.route_centre import route_centre
from simgap.evaluate.timeline import agent_timeline
from simgap.record import RunFiles, read_run, write_run
from simgap.report.timeline import plot_timeline
from simgap.scenario import build_scenario

EXACT_STATE = {"sensing": {"profile": "perfect"}, "latency": 0.1}
PROMPT_PEDALS = {"steer_lag": 0.0, "pedal_delay": 0.0, "pedal_lag": 0.0}


@pytest.fixture(scope="module")
def sharp_curve():
    return build_scenario("curve", {"radius": 10, "angle": 90})


@pytest.fixture(scope="module")
def prompt(sharp_curve):
    run, _ = drive(sharp_curve, "dynamic", settings=PROMPT_PEDALS | {"steer_delay": 0.0}, cosim=EXACT_STATE)
    return run


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
    assert agent_timeline(run.history.agents[0], None).controls is None


def test_a_physical_run_records_its_commands_per_control_tick_and_they_reload_equal(prompt, tmp_path):
    agent = prompt.history.agents[0]
    trace = agent.controls
    assert agent.outcome == "goal_reached"
    assert np.diff(trace.t) == pytest.approx(0.01)                  # the controller's 100 Hz
    assert trace.t[0] == 0.0 and trace.t[-1] <= agent.driven.t_end  # until its outcome
    assert np.abs(trace.steer_requested).max() > 0.1                # it steered through the curve
    # with prompt pedals the car mostly does what the pedals ask (not at the stop, where it holds)
    moving = np.interp(trace.t, agent.driven.t, agent.driven.v) > 1.0
    assert np.median(np.abs(trace.accel_requested - trace.accel_achieved)[moving]) < 0.2
    write_run(RunFiles(prompt), tmp_path / "run")
    again = read_run(tmp_path / "run").history.agents[0].controls
    assert again == trace
    assert pickle.loads(pickle.dumps(prompt)).history.agents[0].controls == trace
    # a hand-edited file whose commands lost their columns is refused, naming it
    path = tmp_path / "run" / "trajectories.parquet"
    pq.write_table(pq.read_table(path).drop_columns(["steer_at_wheels"]), path)
    with pytest.raises(InputError, match="without the columns steer_at_wheels") as refused:
        read_run(tmp_path / "run")
    assert refused.value.file == str(path)


def test_a_late_steering_shows_as_a_road_wheel_angle_that_lags_the_request(sharp_curve, prompt):
    late, _ = drive(sharp_curve, "dynamic", settings=PROMPT_PEDALS | {"steer_delay": 0.3}, cosim=EXACT_STATE)
    prompt_lag = steering_lag_s(prompt.history.agents[0].controls)
    late_lag = steering_lag_s(late.history.agents[0].controls)
    # measured: 0.11 s (the plant's steering servo and rate limit) and 0.41 s
    assert late_lag - prompt_lag == pytest.approx(0.3, abs=0.03)
    assert prompt_lag < 0.15


def test_the_timeline_of_a_run_reads_its_latencies_sensing_and_commands_from_the_record(sharp_curve, prompt,
                                                                                        tmp_path):
    agent = prompt.history.agents[0]
    problem = sharp_curve.problems.planning_problem_dict[agent.id]
    timeline = agent_timeline(agent, route_centre(sharp_curve.scenario.lanelet_network, problem))
    assert len(timeline.plan_latency) == len(agent.plans) and np.all(timeline.plan_latency.values == 0.1)
    assert len(timeline.sensing_error) == len(agent.observed) and np.all(timeline.sensing_error.values == 0.0)
    assert len(timeline.planning_call) == len(agent.planning_call_s)
    assert 0.0 < np.abs(timeline.lateral_error.values).max() < 0.5 and len(timeline.heading_error)
    assert timeline.controls == agent.controls
    png = plot_timeline(timeline, [e for e in prompt.history.events if e.agent_id == agent.id], tmp_path / "t.png",
                        "timeline")
    assert png.stat().st_size > 20_000
