"""Logical scenarios: grid counts, names, pins and every kind of bad input."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest

from simgap.errors import InputError
from simgap.scenario import build_scenario, builtin_names, load_logical


def test_builtins_are_shipped():
    assert {"curve", "s-curve", "t-junction", "intersection"} <= set(builtin_names())


def test_the_papers_grid_has_78_deterministically_named_scenarios():
    spec = load_logical("curve")
    names = [spec.scenario_name(p) for p in spec.grid()]
    assert len(names) == 78 == len(set(names))
    assert names == [spec.scenario_name(p) for p in spec.grid()]
    assert "curve_radius-10_angle-90" in names and "curve_radius-100_angle-m180" in names


def test_pins_give_one_scenario():
    spec = load_logical("curve")
    combos = list(spec.grid(spec.pinned({"radius": "10", "angle": "90"})))
    assert len(combos) == 1
    assert spec.build(combos[0]).name == "curve_radius-10_angle-90"


def test_moving_start_is_kept():
    concrete = build_scenario("curve", {"radius": 50, "angle": 90, "initial_speed": 10})
    assert concrete.problems.planning_problem_dict[1].initial_state.velocity == 10.0
    assert concrete.name == "curve_radius-50_angle-90_initialspeed-10"


@pytest.mark.parametrize("pins, field, allowed", [
    ({"radiuss": "10"}, "radiuss", "radius, angle"),
    ({"radius": "2"}, "radius", "5 to 1000 m"),
    ({"radius": "ten"}, "radius", "5 to 1000 m"),
])
def test_bad_pins_name_field_and_allowed(pins, field, allowed):
    with pytest.raises(InputError) as err:
        load_logical("curve").pinned(pins)
    assert err.value.field == field and allowed in err.value.allowed


def test_radius_too_small_for_the_road():
    with pytest.raises(InputError) as err:
        build_scenario("curve", {"radius": 6, "angle": 90, "lanes": 2})
    assert err.value.field == "radius" and "> 7 m" in err.value.allowed


def test_self_intersecting_road(tmp_path):
    spec = tmp_path / "loop.yaml"
    spec.write_text("""
name: loop
template: road
fixed:
  segments:
    - {kind: straight, length: 50}
    - {kind: arc, radius: 20, angle: 270}
    - {kind: straight, length: 60}
parameters:
  lane_width: {unit: m, min: 2.5, max: 5, default: 3}
""")
    with pytest.raises(InputError) as err:
        build_scenario(str(spec))
    assert err.value.field == "segments" and "crosses itself" in str(err.value)


def test_bad_segment_is_named(tmp_path):
    spec = tmp_path / "bad.yaml"
    spec.write_text("""
name: bad
template: road
fixed:
  segments: [{kind: arc, radius: -5, angle: 90}]
parameters:
  lane_width: {unit: m, min: 2.5, max: 5, default: 3}
""")
    with pytest.raises(InputError) as err:
        build_scenario(str(spec))
    assert err.value.field.startswith("segments.0")


def test_malformed_and_invalid_yaml(tmp_path):
    broken = tmp_path / "broken.yaml"
    broken.write_text("name: [unclosed\n")
    with pytest.raises(InputError, match="malformed YAML") as err:
        load_logical(broken)
    assert err.value.file == str(broken)
    wrong = tmp_path / "wrong.yaml"
    wrong.write_text("name: x\ntemplate: curve\nparameters:\n  radius: {unit: m, min: 5, max: 10, default: 50}\n")
    with pytest.raises(InputError) as err:
        load_logical(wrong)
    assert err.value.field == "parameters.radius"


@pytest.mark.parametrize("dt, field", [
    ("fixed: {dt: 0}", "fixed"),
    ("fixed: {dt: -0.1}", "fixed"),
    ("fixed: {dt: .nan}", "fixed"),
    ("fixed: {dt: fast}", "fixed"),
    ("fixed: {dt: 1.0e-9}", "fixed"),
    ("parameters:\n  dt: {unit: s, min: 0, max: 0.2, default: 0.1}", "parameters"),
])
def test_a_time_step_no_scenario_can_have_is_refused_at_load(tmp_path, dt, field):
    spec = tmp_path / "dt.yaml"
    parameters = "" if dt.startswith("parameters") else "parameters:\n"
    spec.write_text(f"name: dt\ntemplate: curve\n{dt}\n{parameters}"
                    "  radius: {unit: m, min: 5, max: 100, default: 50}\n")
    with pytest.raises(InputError) as err:
        load_logical(spec)
    assert err.value.file == str(spec) and err.value.field == field
    assert "dt" in err.value.reason and "0.01 to 10 s" in err.value.reason


@pytest.mark.parametrize("width", [0, -3, 1.0])
def test_a_lane_too_narrow_for_a_vehicle_is_refused(width):
    with pytest.raises(InputError) as err:
        build_scenario("curve", {"radius": 50, "angle": 90, "lane_width": width})
    assert err.value.field == "lane_width" and ">= 2" in err.value.allowed


def test_the_3d_logical_scenarios_build_their_relief():
    """Every built-in road with a third dimension carries the relief its description promises."""
    crest = build_scenario("crest-curve").blueprint.road_relief()
    sag = build_scenario("sag-curve").blueprint.road_relief()
    s = np.linspace(0.0, 300.0, 601)
    crest_z, sag_z = crest.profile.height(s)[0], sag.profile.height(s)[0]
    assert 0.0 < s[np.argmax(crest_z)] and crest_z.max() > crest_z[-1] + 3.0     # up, over the top, down
    assert sag_z.min() < sag_z[0] - 3.0 and sag_z.min() < sag_z[-1]            # down into it, up again
    banked = build_scenario("banked-curve", {"bank": 10}).blueprint.road_relief()
    assert np.degrees(banked.profile.bank(np.array([115.0]))[0][0]) == pytest.approx(-10.0)  # in the left turn: falls left
    downhill = build_scenario("downhill-curve").blueprint.road_relief()
    assert downhill.profile.height(np.array([100.0]))[0][0] == pytest.approx(-10.0)
    assert build_scenario("curve-3d").blueprint.relief is None                 # its defaults are the flat curve
    assert len(list(load_logical("curve-3d").grid())) == 4 * 3 * 3


def test_a_mountain_road_zig_zags_up_its_grade():
    concrete = build_scenario("mountain-road", {"hairpins": 3, "hairpin_radius": 12, "grade": 8})
    arcs = [seg for seg in concrete.blueprint.segments if seg.kind == "arc"]
    assert [a.angle for a in arcs] == [180.0, -180.0, 180.0] and all(a.radius == 12 for a in arcs)
    relief = concrete.blueprint.road_relief()
    end = relief.centre.s[-1]
    assert relief.profile.height(np.array([end]))[0][0] == pytest.approx(0.08 * end)
    assert concrete.problems.planning_problem_dict[1].goal is not None


def test_an_opendrive_road_as_a_logical_scenario(tmp_path):
    """The opendrive template: a real road's file beside the YAML, a route on it, the problem's
    settings as parameters; a missing file or route is refused naming the field."""
    roads = Path(__file__).parent / "opendrive_roads"
    spec = tmp_path / "exit.yaml"
    spec.write_text(f"""
name: exit
template: opendrive
fixed: {{file: {os.path.relpath(roads / 'Ex_Entry_Exit.xodr', tmp_path)}, start: "300:-3:370", goal: "308:-1:105"}}
parameters:
  initial_speed: {{unit: m/s, min: 0, max: 30, default: 0, values: [0, 15]}}
""")
    logical = load_logical(spec)
    built = [logical.build(p) for p in logical.grid()]
    assert [c.name for c in built] == ["exit_initialspeed-0", "exit_initialspeed-15"]
    assert [c.problems.planning_problem_dict[1].initial_state.velocity for c in built] == [0.0, 15.0]
    assert built[0].opendrive is not None and built[0].sidecar.opendrive.profiles   # its relief kept
    assert str(built[0].scenario.scenario_id).startswith("ZAM_ExitInitialspeed0")

    text = spec.read_text()
    spec.write_text(text.replace('goal: "308:-1:105"', 'goal: ""'))
    with pytest.raises(InputError) as err:
        load_logical(spec).build({})
    assert err.value.field == "fixed.goal"
    spec.write_text(text.replace("Ex_Entry_Exit.xodr", "nowhere.xodr"))
    with pytest.raises(InputError) as err:
        load_logical(spec).build({})
    assert err.value.field == "fixed.file"


@pytest.mark.parametrize("template, arm, agents", [("intersection", 80.0, 3), ("t-junction", 60.0, 3)])
def test_a_junction_template_takes_its_defaults_from_its_builtin_yaml(tmp_path, template, arm, agents):
    """A logical scenario of one's own on a junction template that leaves parameters out gets the
    built-in's defaults (the YAML's, written once), not others of the code's."""
    spec = tmp_path / "mine.yaml"
    spec.write_text(f"name: mine\ntemplate: {template}\nparameters:\n"
                    "  initial_speed: {unit: m/s, min: 0, max: 20, default: 5}\n")
    concrete = load_logical(spec).build({})
    builtin = build_scenario(template, {"initial_speed": 5})
    assert concrete.blueprint.approach_length == builtin.blueprint.approach_length == arm
    assert concrete.blueprint.lane_width == builtin.blueprint.lane_width == 3.5
    assert len(concrete.problems.planning_problem_dict) == agents
    assert concrete.problems.planning_problem_dict[1].initial_state.velocity == 5.0
