"""The MuJoCo world on a road's relief against closed-form physics (the drives are
bench/roads/road_relief.py's, which prints the same figures as tables)."""

from __future__ import annotations

import importlib.util
import math
import sys
from pathlib import Path

import pytest

from simgap.vehicles import load_vehicle

BENCH = Path(__file__).resolve().parents[3] / "bench" / "roads" / "road_relief.py"


@pytest.fixture(scope="module")
def road_relief():
    spec = importlib.util.spec_from_file_location("road_relief", BENCH)
    module = sys.modules["road_relief"] = importlib.util.module_from_spec(spec)     # (its dataclasses look it up)
    try:
        spec.loader.exec_module(module)
        yield module
    finally:
        del sys.modules["road_relief"]


@pytest.fixture(scope="module")
def sedan():
    return load_vehicle("sedan")


@pytest.mark.parametrize("grade", [10.0, -10.0])
def test_braking_distance_on_a_grade_is_the_closed_forms(road_relief, sedan, grade):
    stop = road_relief.braking(grade, sedan)
    assert stop.speed == pytest.approx(100.0 / 3.6, rel=0.02)
    assert abs(stop.error_percent) < 3.0          # v^2 / (2 g (mu cos(theta) + sin(theta)))
    flat = stop.speed ** 2 / (2 * 9.81 * sedan.physics.tyres.magic_formula.p_dx1)
    assert (stop.measured < flat) == (grade > 0)     # uphill shorter than on the flat, downhill longer


def test_the_tyres_carry_less_at_the_top_of_a_crest(road_relief, sedan):
    top = road_relief.crest(200.0, 25.0, 15.0, sedan)
    assert abs(top.error_percent) < 3.0           # m (g - v^2 / R)
    assert top.measured < 0.75 * sedan.physics.mass * 9.81


@pytest.mark.parametrize("bank, speed", [(8.0, 16.0), (-5.0, 16.0)])
def test_a_steady_turn_on_a_bank_uses_the_textbooks_friction(road_relief, sedan, bank, speed):
    turn = road_relief.banked_turn(bank, speed, sedan)
    assert turn.radius == pytest.approx(50.0, abs=0.2)
    assert abs(turn.error_percent) < 3.0          # (v^2/gR - tan phi) / (1 + v^2/gR tan phi)
    flat = turn.speed ** 2 / (9.81 * turn.radius)
    assert (turn.measured < flat) == (bank > 0)   # a bank into the turn needs less, against it more


@pytest.mark.parametrize("heading", [0.0, math.pi])
def test_a_braked_car_stays_put_on_a_20_percent_slope(road_relief, sedan, heading):
    assert road_relief.hold(20.0, heading, sedan).moved_m < 0.001


def test_a_relief_flat_everywhere_drives_as_the_plane(road_relief, sedan):
    assert road_relief.flat_against_plane(sedan, duration=5.0) == 0.0
