"""The pedal map (acceleration <-> throttle/brake) and the speed controller."""

from __future__ import annotations

import math

import pytest

from simgap.control.longitudinal import (
    DEFAULT_PHYSICS,
    LongitudinalMap,
    SpeedController,
    SpeedGains,
)
from simgap.errors import InputError

PHYSICS = {"mass": 1500.0, "wheel_radius": 0.33, "max_drive_torque": 3000.0,
           "max_brake_torque": 6000.0, "drag_coefficient_area": 0.7, "rolling_resistance": 0.015}


def test_defaults_are_a_bmw_320i_like_car():
    m = LongitudinalMap.from_physics(None)
    assert m.mass == pytest.approx(1093.3, abs=0.1)      # CommonRoad parameter set 2
    assert m.max_brake_deceleration == pytest.approx(11.5, rel=0.01)  # CommonRoad a_max
    assert m == LongitudinalMap(**DEFAULT_PHYSICS)


def test_numbers_come_from_the_physics_section():
    m = LongitudinalMap.from_physics(PHYSICS)
    assert (m.mass, m.wheel_radius, m.max_drive_torque, m.max_brake_torque) == (
        1500.0, 0.33, 3000.0, 6000.0)
    # throttle = demand * m * r / T_drive, plus resistance
    throttle, brake = m.pedals(1.0, 0.0)
    f_roll = 0.015 * 1500.0 * 9.81
    assert throttle == pytest.approx((1500.0 * 1.0 + f_roll) * 0.33 / 3000.0)
    assert brake == 0.0
    throttle, brake = m.pedals(-5.0, 20.0)
    f_res = f_roll + 0.5 * 1.204 * 0.7 * 400.0
    assert throttle == 0.0
    assert brake == pytest.approx((1500.0 * 5.0 - f_res) * 0.33 / 6000.0)


def test_optional_keys_fall_back_to_defaults():
    m = LongitudinalMap.from_physics({k: PHYSICS[k] for k in
                                      ("mass", "wheel_radius", "max_drive_torque", "max_brake_torque")})
    assert m.drag_coefficient_area == DEFAULT_PHYSICS["drag_coefficient_area"]
    assert m.rolling_resistance == DEFAULT_PHYSICS["rolling_resistance"]


@pytest.mark.parametrize("key", ["mass", "wheel_radius", "max_drive_torque", "max_brake_torque"])
def test_missing_required_key_names_the_field(key):
    physics = {k: v for k, v in PHYSICS.items() if k != key}
    with pytest.raises(InputError) as err:
        LongitudinalMap.from_physics(physics, source="vehicles/data/x.yaml")
    assert err.value.field == f"physics.{key}"
    assert err.value.file == "vehicles/data/x.yaml"


@pytest.mark.parametrize("value", [0.0, -1.0, "heavy", None, math.inf])
def test_bad_value_names_the_field(value):
    with pytest.raises(InputError) as err:
        LongitudinalMap.from_physics({**PHYSICS, "mass": value})
    assert err.value.field == "physics.mass"


@pytest.mark.parametrize("accel", [-9.0, -3.0, -0.2, 0.0, 0.5, 2.0, 4.0])
@pytest.mark.parametrize("v", [0.5, 5.0, 15.0, 30.0])
def test_pedals_and_acceleration_are_inverse(accel, v):
    m = LongitudinalMap.from_physics(PHYSICS)
    throttle, brake = m.pedals(accel, v)
    assert 0.0 <= throttle <= 1.0 and 0.0 <= brake <= 1.0
    assert throttle == 0.0 or brake == 0.0
    assert m.acceleration(throttle, brake, v) == pytest.approx(accel, abs=1e-9)


def test_pedals_saturate():
    m = LongitudinalMap.from_physics(PHYSICS)
    assert m.pedals(50.0, 10.0) == (1.0, 0.0)
    assert m.pedals(-50.0, 10.0) == (0.0, 1.0)


def test_brakes_hold_but_never_reverse():
    m = LongitudinalMap.from_physics(PHYSICS)
    assert m.acceleration(0.0, 1.0, 0.0) == 0.0
    assert m.acceleration(0.1, 0.5, 0.0) == 0.0   # throttle below what the brake holds
    assert m.acceleration(1.0, 0.0, 0.0) > 0.0


def _speed_controller(**gains):
    m = LongitudinalMap.from_physics(None)
    return SpeedController(SpeedGains(**gains), m, max_accel=11.5)


def test_demand_is_feedforward_plus_pi():
    c = _speed_controller(kp=1.5, ki=0.2, position_gain=0.0)
    assert c.demand(v=10.0, a=0.0, v_ref=10.0, a_ref=1.2, along_track_error=0.0,
                    dt=0.01) == pytest.approx(1.2)
    d = c.demand(v=10.0, a=0.0, v_ref=10.5, a_ref=0.0, along_track_error=0.0, dt=0.01)
    assert d == pytest.approx(1.5 * 0.5 + 0.2 * 0.5 * 0.01)


def test_integral_is_bounded_and_paused_for_large_errors():
    c = _speed_controller(kp=0.0, ki=1.0, integral_limit=0.5, integral_band=1.0,
                          position_gain=0.0)
    for _ in range(1000):
        c.demand(v=10.0, a=0.0, v_ref=10.9, a_ref=0.0, along_track_error=0.0, dt=0.01)
    assert c.last_demand == pytest.approx(0.5)
    c.reset()
    for _ in range(100):
        c.demand(v=10.0, a=0.0, v_ref=12.0, a_ref=0.0, along_track_error=0.0, dt=0.01)
    assert c.last_demand == 0.0


def test_position_error_corrects_speed_within_its_limit():
    c = _speed_controller(kp=1.0, ki=0.0, position_gain=0.5, position_correction_limit=2.0)
    assert c.demand(10.0, 0.0, 10.0, 0.0, along_track_error=1.0, dt=0.01) == pytest.approx(0.5)
    assert c.demand(10.0, 0.0, 10.0, 0.0, along_track_error=100.0, dt=0.01) == pytest.approx(2.0)


def test_never_asks_to_reverse_and_holds_a_stop():
    c = _speed_controller()
    assert c.pedals(0.05, 0.0, 0.0, 0.0, 0.0, 0.01, stop_planned=True) == (0.0, 0.4)
    throttle, brake = c.pedals(2.0, 0.0, -3.0, 0.0, 0.0, 0.01, stop_planned=False)
    assert throttle == 0.0 and brake > 0.0
    assert c.demand(2.0, 0.0, -3.0, 0.0, 0.0, 0.01) == pytest.approx(-1.5 * 2.0, abs=0.01)
