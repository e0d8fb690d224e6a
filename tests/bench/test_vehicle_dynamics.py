"""Smoke test of bench/vehicles/vehicle_dynamics.py: its whole quick run with ``--json`` (every section) on one
MuJoCo car prints one JSON object with figures that any tyre model must give (the bench itself
reports numbers, not pass/fail)."""

from __future__ import annotations

import json
import math

import pytest


@pytest.fixture(scope="module")
def vehicle_dynamics(bench_module):
    return bench_module("vehicles/vehicle_dynamics")


def test_quick_json_benchmark_of_one_car_gives_sane_handling_figures(vehicle_dynamics, capsys):
    vehicle_dynamics.main(["--quick", "--json", "--vehicles", "city", "--controllers", "pure_pursuit"])
    out = capsys.readouterr().out
    figures = json.loads(out)["city"]          # every section's figures, as plain JSON

    for key in ("understeer_gradient_deg_per_g", "sideslip_gradient_deg_per_g", "max_lateral_acceleration",
                "yaw_rate_rise_time_s", "braking_distance_100_m"):
        assert key in figures
    assert math.isfinite(figures["understeer_gradient_deg_per_g"])
    assert math.isfinite(figures["sideslip_gradient_deg_per_g"])
    # the quick sweep ends at 14 m/s on R = 50 m: 3.9 m/s^2 must be held by any car
    assert 3.5 < figures["max_lateral_acceleration"] < 12.0
    assert 0.05 < figures["yaw_rate_rise_time_s"] < 1.5
    assert figures["step_steer_lateral_acceleration"] == pytest.approx(4.0, abs=0.5)
    # from 100 km/h: mu v^2 / 2g is 38 m at mu = 1; any tyre on dry asphalt stops within 25-80 m
    assert 25.0 < figures["braking_distance_100_m"] < 80.0
    unlocked = figures["braking_distance_100_unlocked_m"]
    assert unlocked is None or 25.0 < unlocked < 80.0
    assert 1.0 < figures["roll_gradient_deg_per_g"] < 15.0
    # past the limit on flat ground a car slides: it does not roll over
    assert figures["beyond_limit_runs"] == 2 and figures["beyond_limit_rollovers"] == 0
    run = figures["lane_change_60"]["pure_pursuit"]
    assert math.isfinite(run["peak_lateral_error_m"]) and run["peak_lateral_error_m"] < 5.0
