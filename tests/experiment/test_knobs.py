"""Reality knobs in the loop: each one moves the outcome the way the real world would, in the
dynamic world and in MuJoCo alike; and how knobs become backend and loop settings."""

from __future__ import annotations

from pathlib import Path

import pytest
from cosim.concrete_runs import drive as drive_concrete

from simgap.experiment.knobs import KNOBS, apply_knobs
from simgap.scenario import build_scenario
from simgap.vehicles import load_vehicle

PERFECT_MACHINE = {"realism": "ideal"}     # each knob is measured against a car that has no other defect


def drive(concrete, backend: str, settings: dict | None = None, cosim: dict | None = None, seed: int = 0):
    return drive_concrete(concrete, backend, PERFECT_MACHINE | (settings or {}), cosim, seed)


@pytest.fixture(scope="module")
def sharp_curve():
    # the paper's tightest curve, entered at 15 m/s: the planner must brake, then turn
    return build_scenario("curve", {"radius": 10, "angle": 90, "initial_speed": 15})


# the single-track model's tyres are linear: friction there only softens them and caps braking,
# so the friction test takes the multi-body model (Pacejka tyres that saturate) of the dynamic world
@pytest.mark.parametrize("backend, settings", [("dynamic", {"model": "mb"}), ("mujoco", {})])
def test_lower_friction_gives_a_larger_lateral_error_on_a_sharp_curve(sharp_curve, backend, settings):
    _, dry = drive(sharp_curve, backend, settings)
    run, snow = drive(sharp_curve, backend, settings | {"road_friction": 0.25})
    # measured: dynamic (mb) 0.080 -> 0.178 m; mujoco 0.160 -> 0.209 m (0.254 m with tyres
    # without load sensitivity)
    assert snow["max_lateral_offset_m"] > dry["max_lateral_offset_m"] + 0.03
    assert snow["peak_grip_use"] > dry["peak_grip_use"]
    # on snow neither car makes the turn the ideal plan asks for
    assert run.agents[0].history.outcome != "goal_reached"


def test_friction_on_the_single_track_model_caps_braking():
    from simgap.control.protocol import Command
    from simgap.sim.dynamic.plant import SingleTrackPlant
    from simgap.trajectory import State

    start = State(t=0.0, x=0.0, y=0.0, yaw=0.0, v=20.0, a=0.0, yaw_rate=0.0, steer=0.0)
    stops = {}
    for mu in (1.0, 0.3):
        plant = SingleTrackPlant(load_vehicle("sedan"), road_friction=mu)
        state = plant.reset(start)
        while state.v > 0.0 and state.t < 20:
            state = plant.step(Command(steer=0.0, throttle=0.0, brake=1.0), 0.01)
        stops[mu] = state.x
    assert stops[0.3] > 2.5 * stops[1.0]          # braking distance grows as 1/mu once the brakes lock


@pytest.mark.parametrize("backend", ["dynamic", "mujoco"])
def test_steering_delay_gives_a_larger_tracking_error(sharp_curve, backend):
    _, prompt = drive(sharp_curve, backend)
    # measured (0.3 s): dynamic 0.0153 -> 0.0277 m, mujoco 0.0171 -> 0.0311 m (1.8x both); with the
    # tyre-based feed-forward the prompt car tracks this curve closely and replanning every step
    # absorbs part of a delay (0.5 s: 2.2x / 2.1x), so the margin asked is 1.5x, not 2x
    _, late = drive(sharp_curve, backend, {"steer_delay": 0.3})
    assert late["max_tracking_lateral_m"] > 1.5 * prompt["max_tracking_lateral_m"]


def test_pedal_delay_makes_the_car_late_on_its_speed_plan(sharp_curve):
    from simgap.evaluate.errors import tracking_errors

    prompt, _ = drive(sharp_curve, "dynamic")
    late, _ = drive(sharp_curve, "dynamic", {"pedal_delay": 0.3})
    gap = [abs(tracking_errors(r.history.driven[1], r.history.plans[1]).velocity).max() for r in (prompt, late)]
    assert gap[1] > gap[0] + 0.1


def test_observation_noise_moves_the_car_off_its_lane_centre(sharp_curve):
    real = {"realism": "real", "steer_delay": 0.0, "steer_lag": 0.0, "pedal_delay": 0.0, "pedal_lag": 0.0}
    _, clean = drive(sharp_curve, "dynamic", real, cosim={"sensing": {"profile": "perfect"}, "latency": 0})
    _, noisy = drive(sharp_curve, "dynamic", real, cosim={"sensing": {"profile": "perfect", "position_noise_m": 0.2},
                                                          "latency": 0}, seed=3)
    assert noisy["max_lateral_offset_m"] > clean["max_lateral_offset_m"] + 0.05


def test_bank_pushes_the_car_downhill_and_grade_slows_it():
    # the knobs tilt the flat straight road into a relief (`simgap.scenario.relief.RoadTilt`)
    straight = build_scenario("curve", {"radius": 50, "angle": 0, "initial_speed": 10})
    flat_run, flat = drive(straight, "mujoco")
    banked_run, banked = drive(straight, "mujoco", {"road_bank": 8})
    assert banked["max_tracking_lateral_m"] > 3 * flat["max_tracking_lateral_m"]
    from simgap.evaluate.errors import lateral_profile
    from simgap.evaluate.route_centre import route_centre

    frame = route_centre(straight.scenario.lanelet_network, straight.problems.planning_problem_dict[1])
    _, d = lateral_profile(banked_run.history.driven[1], frame)
    # the road falls to the right of its reference line, which the car drives along: the car drifts right
    assert d.min() < -0.01 and -d.min() > 5 * max(d.max(), 0.0)
    uphill_run, _ = drive(straight, "mujoco", {"road_grade": 8})
    assert uphill_run.agents[0].history.time_to_goal_s > flat_run.agents[0].history.time_to_goal_s


def test_knobs_go_where_they_apply():
    values = {"road_friction": 0.4, "steer_delay": 0.1, "position_noise": 0.2, "road_bank": 5.0, "pedal_delay": 0.0,
              "latency": 0.05}
    assert apply_knobs("ideal", values) == ({}, {})
    # a knob at the ideal world's value is set too: the physical worlds' default is the vehicle's
    assert apply_knobs("dynamic", values) == ({"road_friction": 0.4, "steer_delay": 0.1, "pedal_delay": 0.0},
                                              {"sensing": {"position_noise_m": 0.2}, "latency": 0.05})
    settings, _ = apply_knobs("mujoco", values)
    assert settings == {"road_friction": 0.4, "steer_delay": 0.1, "road_bank": 5.0, "pedal_delay": 0.0}
    for knob in KNOBS.values():                 # every nominal value is inside its allowed range
        assert knob.low <= knob.nominal <= knob.high and knob.unit and knob.meaning


def test_the_docs_table_of_knobs_is_generated_from_the_knob_table():
    page = (Path(__file__).parents[2] / "docs" / "reference" / "knobs.md").read_text()
    assert "<!-- gen:knobs -->" in page and "| knob |" not in page


def test_a_perfect_machine_takes_no_knob_of_the_loop_and_no_record_says_it_did():
    from simgap.cosim import CosimSettings
    from simgap.errors import InputError
    from simgap.experiment.knobs import check_knob, with_knobs
    from simgap.sim.protocol import Realism
    from simgap.sim.registry import backend_settings

    values = {"latency": 0.5, "position_drift": 2.0, "steer_delay": 0.2}
    assert apply_knobs("dynamic", values, Realism.IDEAL) == ({"steer_delay": 0.2}, {})   # dead times it has
    for name in ("latency", "position_drift"):
        with pytest.raises(InputError, match="does not apply under realism ideal"):
            check_knob(name, 0.1, 0.1, realism=Realism.IDEAL)
    check_knob("steer_delay", 0.2, 0.2, realism=Realism.IDEAL)
    ideal = backend_settings("dynamic", {"realism": "ideal"})
    settings, cosim = with_knobs(ideal, CosimSettings(), values)       # a search's rung
    assert settings.steer_delay == 0.2 and cosim == CosimSettings()
    _, cosim = with_knobs(backend_settings("dynamic", {}), CosimSettings(), values)
    assert cosim.latency == 0.5 and cosim.sensing.position_drift_m == 2.0


def test_a_union_setting_says_every_form_it_may_take():
    from simgap.cosim import CosimSettings
    from simgap.errors import InputError, validated

    with pytest.raises(InputError) as refused:
        validated(CosimSettings, {"latency": 1000}, file="spec.yaml", prefix="cosim")
    assert refused.value.field == "cosim.latency" and "less than or equal to 1" in refused.value.reason
    assert refused.value.allowed == "'measured' or a number up to 1"
    with pytest.raises(InputError, match="'fast' is none of the forms") as refused:
        validated(CosimSettings, {"latency": "fast"}, prefix="cosim")
    assert refused.value.field == "cosim.latency"
