"""Controllers by name, gains from defaults and vehicle files, and the error paths."""

from __future__ import annotations

import pytest
import yaml

from simgap.control import (
    Command,
    LqrController,
    PurePursuitController,
    StanleyController,
    controller_gains,
    controller_names,
    make_controller,
)
from simgap.errors import InputError
from simgap.trajectory import State, Trajectory
from simgap.vehicles.catalogue import load_vehicle_file


def test_names():
    assert controller_names() == ["pure_pursuit", "stanley", "lqr"]


@pytest.mark.parametrize("name,cls", [("pure_pursuit", PurePursuitController),
                                      ("stanley", StanleyController), ("lqr", LqrController)])
def test_factory_builds_each_controller(name, cls, sedan):
    c = make_controller(name, sedan)
    assert isinstance(c, cls)
    assert c.rate_hz == 100.0
    assert make_controller(name, sedan, rate_hz=50).rate_hz == 50.0


def test_unknown_name_lists_the_allowed_ones(sedan):
    with pytest.raises(InputError) as err:
        make_controller("mpc", sedan)
    assert err.value.field == "controller"
    assert "pure_pursuit" in err.value.allowed and "stanley" in err.value.allowed


@pytest.mark.parametrize("rate", [10.0, 49.9, 0.0, -100.0, "fast"])
def test_rate_below_50_hz_is_refused(rate, sedan):
    with pytest.raises(InputError) as err:
        make_controller("stanley", sedan, rate_hz=rate)
    assert err.value.field == "rate_hz"


def test_documented_defaults():
    pp = controller_gains("pure_pursuit")
    assert (pp.lookahead_time, pp.lookahead_min, pp.lookahead_max) == (0.4, 4.0, 30.0)
    assert pp.curvature_feedforward == 1.0 and pp.lateral_integral_gain == 2.0
    st = controller_gains("stanley")
    assert (st.cross_track_gain, st.heading_gain, st.softening_speed) == (2.5, 1.0, 1.0)
    assert st.lateral_integral_gain == 4.0
    lqr = controller_gains("lqr")
    assert (lqr.lateral_weight, lqr.input_weight, lqr.steer_time_constant) == (1.0, 0.02, 0.05)
    assert (pp.speed.kp, pp.speed.ki, pp.speed.position_gain) == (1.5, 0.2, 0.5)


def test_vehicle_file_overrides_defaults(sedan):
    vehicle = sedan.model_copy(update={"controllers": {
        "pure_pursuit": {"lookahead_time": 0.8, "speed": {"kp": 0.9}},
        "stanley": {"cross_track_gain": 3.0}}})
    c = make_controller("pure_pursuit", vehicle)
    assert c.gains.lookahead_time == 0.8
    assert c.gains.lookahead_min == 4.0            # untouched defaults stay
    assert c.gains.speed.kp == 0.9 and c.gains.speed.ki == 0.2
    assert c.speed.gains.kp == 0.9
    assert make_controller("stanley", vehicle).gains.cross_track_gain == 3.0
    # explicit overrides (an experiment's config) win over the vehicle file
    c = make_controller("pure_pursuit", vehicle, overrides={"speed": {"kp": 2.0}})
    assert c.gains.speed.kp == 2.0 and c.gains.lookahead_time == 0.8


def test_unknown_gain_names_vehicle_file_and_field(tmp_path):
    path = tmp_path / "coupe.yaml"
    path.write_text(yaml.safe_dump({
        "length": 4.5, "width": 1.8, "wheelbase": 2.7, "rear_axle_to_center": 1.4,
        "limits": {"max_steer": 0.6, "max_steer_rate": 0.5, "max_accel": 9.0,
                   "max_speed": 60.0, "v_switch": 8.0},
        "controllers": {"stanley": {"cross_trak_gain": 3.0}}}))
    vehicle = load_vehicle_file(path)
    with pytest.raises(InputError) as err:
        make_controller("stanley", vehicle)
    assert err.value.field == "controllers.stanley.cross_trak_gain"
    assert "cross_track_gain" in err.value.allowed
    assert "coupe" in err.value.file
    assert "unknown gain" in str(err.value)
    # other controllers of the same vehicle are unaffected
    make_controller("lqr", vehicle)


def test_catalogue_vehicle_errors_name_its_data_file(sedan):
    vehicle = sedan.model_copy(update={"controllers": {"lqr": {"speed": {"kq": 1.0}}}})
    with pytest.raises(InputError) as err:
        make_controller("lqr", vehicle)
    assert err.value.field == "controllers.lqr.speed.kq"
    assert err.value.file.endswith("vehicles/data/sedan.yaml")
    assert "kp" in err.value.allowed


@pytest.mark.parametrize("gains,field", [
    ({"lookahead_min": -1.0}, "controllers.pure_pursuit.lookahead_min"),
    ({"lookahead_time": "long"}, "controllers.pure_pursuit.lookahead_time"),
    ({"speed": {"standstill_brake": 2.0}}, "controllers.pure_pursuit.speed.standstill_brake"),
])
def test_bad_gain_values(gains, field, sedan):
    vehicle = sedan.model_copy(update={"controllers": {"pure_pursuit": gains}})
    with pytest.raises(InputError) as err:
        make_controller("pure_pursuit", vehicle)
    assert err.value.field == field


def test_gains_must_be_a_mapping(sedan):
    vehicle = sedan.model_copy(update={"controllers": {"stanley": {}}})
    with pytest.raises(InputError):
        make_controller("stanley", vehicle, overrides=[1, 2])


def test_physics_errors_reach_the_factory(sedan):
    vehicle = sedan.model_copy(update={"physics": {"mass": 1200.0}})
    with pytest.raises(InputError) as err:
        make_controller("stanley", vehicle)
    assert err.value.field == "physics.wheel_radius"


def test_output_is_held_between_updates(sedan):
    c = make_controller("pure_pursuit", sedan, rate_hz=50)
    start = State(t=0.0, x=0.0, y=0.0, yaw=0.0, v=10.0)
    plan = Trajectory.from_states(
        [State(t=0.1 * k, x=1.0 * k, y=0.02 * k * k, yaw=0.04 * k, v=10.0) for k in range(31)], 0.1)
    c.reset(start)
    first = c.command(start, plan, 0.0)
    assert isinstance(first, Command)
    moved = start.replace(t=0.01, y=-0.5)
    assert c.command(moved, plan, 0.01) is first            # inside the 20 ms period
    assert c.command(moved, plan, 0.02) != first            # next update
    c.reset(start)
    assert c.command(start, plan, 0.0) == first             # reset forgets everything
