"""A road's relief: its profiles, its surface in the world, the templates' parameters and the sidecar."""

from __future__ import annotations

import math

import numpy as np
import pytest

from simgap.errors import InputError
from simgap.scenario import build_scenario, read_sidecar, write_scenario
from simgap.scenario.geometry import Straight, centre_line
from simgap.scenario.ground import ground_of
from simgap.scenario.relief import (
    LEVEL,
    BankKnot,
    ElevationProfile,
    ReliefProfile,
    RoadRelief,
    RoadTilt,
    VerticalCurve,
    tilt_of,
)
from simgap.scenario.sidecar import ScenarioSidecar


def test_a_crest_is_a_parabola_of_its_radius_between_its_two_grades():
    crest = ReliefProfile(elevation=ElevationProfile(grade=8.0, changes=(VerticalCurve(s=100.0, grade=-8.0, radius=250.0),)))
    s = np.linspace(0.0, 200.0, 20001)
    z, slope = crest.height(s)
    assert z[0] == 0.0 and slope[0] == pytest.approx(0.08) and slope[-1] == pytest.approx(-0.08)
    half = 0.5 * 250.0 * 0.16                                   # the curve: 40 m long, centred on s = 100 m
    assert np.all(np.abs(np.diff(z)) < 0.08 * 0.01 + 1e-9)     # continuous
    assert np.abs(np.diff(slope)).max() < 1.001 * 0.01 / 250.0  # no kink where the curve meets the grades
    curvature = np.gradient(slope, s)
    on_curve = np.abs(s - 100.0) < half - 0.5
    assert curvature[on_curve] == pytest.approx(-1.0 / 250.0, rel=1e-6)
    assert slope[np.argmin(np.abs(s - 100.0))] == pytest.approx(0.0, abs=1e-9)
    assert z.max() == pytest.approx(8.0 - 0.5 * 0.08 * half, abs=1e-6)     # tangents meet 8 m up; the crest rounds it


def test_vertical_curves_that_overlap_or_start_before_the_road_are_refused():
    with pytest.raises(ValueError, match="before the road starts"):
        ElevationProfile(grade=5.0, changes=(VerticalCurve(s=10.0, grade=-5.0, radius=1000.0),))
    with pytest.raises(ValueError, match="before the one before it ends"):
        ElevationProfile(changes=(VerticalCurve(s=100.0, grade=6.0, radius=500.0),
                                  VerticalCurve(s=110.0, grade=0.0, radius=500.0)))


def test_a_banked_straight_tilts_its_cross_section_about_the_reference_line():
    bank = math.radians(6.0)
    relief = RoadRelief(ReliefProfile(superelevation=(BankKnot(s=0.0, bank=6.0),)),
                        centre_line([Straight(length=100.0)], max_step=0.2))
    x, y = np.array([10.0, 50.0, 50.0]), np.array([0.0, 3.0, -20.0])      # beside the road the cross slope goes on
    surface = relief.surface(x, y)
    assert surface.z == pytest.approx(y * math.tan(bank), abs=1e-12)     # positive bank: the right side lower
    assert surface.normal == pytest.approx(np.tile([0.0, -math.sin(bank), math.cos(bank)], (3, 1)), abs=1e-12)


def test_the_surface_normal_is_the_gradient_of_its_height_on_a_graded_banked_curve():
    concrete = build_scenario("curve", {"radius": 30, "angle": 90, "grade": 7, "grade_change": -14,
                                        "vertical_radius": 200, "bank": 6, "transition": 10})
    relief = concrete.blueprint.road_relief()
    rng = np.random.default_rng(3)
    idx = rng.integers(100, len(relief.centre.s) - 100, 300)
    offsets = rng.uniform(-8.0, 8.0, len(idx))
    heading = relief.centre.heading[idx]
    x = relief.centre.xy[idx, 0] - offsets * np.sin(heading)
    y = relief.centre.xy[idx, 1] + offsets * np.cos(heading)
    kinks = [k.s for k in relief.profile.superelevation] + [p.s_start for p in relief.profile.elevation.pieces()]
    smooth = np.abs(relief.frenet(x, y)[0][:, None] - np.array(kinks)[None, :]).min(axis=1) > 0.1
    x, y = x[smooth], y[smooth]                                 # (the gradient jumps at a kink)
    h = 1e-4
    zx = (relief.surface(x + h, y).z - relief.surface(x - h, y).z) / (2 * h)
    zy = (relief.surface(x, y + h).z - relief.surface(x, y - h).z) / (2 * h)
    expected = np.column_stack([-zx, -zy, np.ones_like(zx)]) / np.sqrt(1 + zx ** 2 + zy ** 2)[:, None]
    assert np.abs(relief.surface(x, y).normal - expected).max() < 1e-8


@pytest.mark.parametrize("bank", [5, -5])
def test_a_bank_into_the_turn_raises_the_outside_of_the_curve_and_one_against_it_the_inside(bank):
    for angle in (90, -90):
        relief = build_scenario("curve", {"radius": 50, "angle": angle, "bank": bank}).blueprint.road_relief()
        s_mid = 100.0 + 50.0 * math.pi / 4                       # the middle of the curve
        i = int(np.argmin(np.abs(relief.centre.s - s_mid)))
        left = relief.centre.offset(3.0)[i]
        right = relief.centre.offset(-3.0)[i]
        outside, inside = (right, left) if angle > 0 else (left, right)
        z = relief.surface(np.array([outside[0], inside[0]]), np.array([outside[1], inside[1]])).z
        assert z[0] - z[1] == pytest.approx(6.0 * math.tan(math.radians(bank)), rel=1e-3)


def test_a_flat_road_has_no_relief_and_its_sidecar_is_as_before(tmp_path):
    flat = build_scenario("curve", {"radius": 20, "angle": 45, "grade": 0, "bank": 0})
    assert flat.blueprint.relief is None
    assert "relief" not in flat.sidecar.as_json()["blueprint"]
    assert ground_of(flat.sidecar) is None


def test_the_relief_travels_in_the_sidecar(tmp_path):
    concrete = build_scenario("s-curve", {"radius": 30, "angle": 60, "grade": -5, "bank": 4})
    xml = write_scenario(concrete, tmp_path, preview=False)
    relief = ground_of(read_sidecar(xml))
    assert relief is not None and relief.profile == concrete.blueprint.relief
    assert relief.profile.height(np.array([100.0]))[0][0] == pytest.approx(-5.0)
    banks = [k.bank for k in relief.profile.superelevation]
    assert banks == [0.0, 0.0, -4.0, -4.0, 4.0, 4.0, 0.0, 0.0]     # left turn falls left, right turn right


def test_a_vertical_curve_off_the_road_is_refused_naming_its_parameters():
    with pytest.raises(InputError) as err:
        build_scenario("curve", {"grade_change": -20, "vertical_radius": 5000})
    assert "vertical_radius" in err.value.field and "before the road starts" in str(err.value)


def test_a_tilt_banks_and_grades_a_straight_road_about_its_reference_line():
    road = build_scenario("curve", {"radius": 50, "angle": 0}).blueprint      # flat, straight along +x from the origin
    assert road.road_relief() is None and road.road_relief(LEVEL) is None
    tan5 = math.tan(math.radians(5.0))
    banked = road.road_relief(RoadTilt(road_bank=5.0))
    surface = banked.surface(np.array([20.0, 20.0, 20.0]), np.array([0.0, 1.0, -1.0]))
    assert surface.z == pytest.approx([0.0, tan5, -tan5], abs=1e-12)          # it falls to the right of the line
    pitch, roll = tilt_of(surface.normal[0], 0.0)
    assert math.degrees(roll) == pytest.approx(5.0) and pitch == pytest.approx(0.0, abs=1e-12)
    assert math.degrees(tilt_of(surface.normal[0], math.pi)[1]) == pytest.approx(-5.0)   # against it: to the left
    graded = road.road_relief(RoadTilt(road_grade=5.0))
    surface = graded.surface(np.array([0.0, 40.0, 40.0]), np.array([0.0, 0.0, 2.0]))
    assert surface.z == pytest.approx([0.0, 40.0 * tan5, 40.0 * tan5], abs=1e-9)      # uphill along it, level across
    pitch, roll = tilt_of(surface.normal[1], 0.0)
    assert math.degrees(pitch) == pytest.approx(5.0) and roll == pytest.approx(0.0, abs=1e-12)


def test_a_tilt_adds_to_every_grade_and_bank_of_a_relief_and_keeps_its_vertical_curves():
    relief = build_scenario("crest-curve").blueprint.relief
    tilted = relief.tilted(RoadTilt(road_bank=3.0, road_grade=2.0))
    s = np.linspace(0.0, 400.0, 4001)
    assert tilted.height(s)[0] == pytest.approx(relief.height(s)[0] + math.tan(math.radians(2.0)) * s, abs=1e-9)
    assert tilted.bank(s)[0] == pytest.approx(relief.bank(s)[0] + math.radians(3.0), abs=1e-12)
    assert [p.s_start for p in tilted.elevation.pieces()] == pytest.approx([p.s_start for p in relief.elevation.pieces()])
    assert relief.tilted(LEVEL) is relief


def test_a_tilt_where_no_road_lies_or_past_the_reliefs_bounds_is_refused_naming_the_knob():
    with pytest.raises(InputError, match="and a recorded map has none") as refused:
        ground_of(ScenarioSidecar(), None, RoadTilt(road_bank=4.0), "recorded.xml")
    assert (refused.value.file, refused.value.field) == ("recorded.xml", "road_bank")
    assert refused.value.allowed.startswith("a generated road")
    assert ground_of(ScenarioSidecar(), None, LEVEL, "recorded.xml") is None
    with pytest.raises(InputError, match="a generated junction") as refused:
        ground_of(build_scenario("t-junction").sidecar, None, RoadTilt(road_grade=2.0), "junction.xml")
    assert refused.value.field == "road_grade"
    steep = build_scenario("curve", {"radius": 50, "angle": 90, "grade": 35}).sidecar     # 35 % + 15 deg: 62 %
    with pytest.raises(InputError, match="a grade of 15 deg laid on the road's relief takes it past ±40 %") as refused:
        ground_of(steep, None, RoadTilt(road_bank=1.0, road_grade=15.0), "steep.xml")
    assert refused.value.field == "road_grade"
    banked = build_scenario("curve", {"radius": 50, "angle": 90, "bank": 20}).sidecar
    with pytest.raises(InputError, match="a bank of -15 deg") as refused:
        ground_of(banked, None, RoadTilt(road_bank=-15.0), "banked.xml")
    assert refused.value.field == "road_bank"
