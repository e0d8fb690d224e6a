"""Runs, scenarios and search findings as OpenSCENARIO and OpenDRIVE: every file validates against
the schema of the version it declares, parses back with every trajectory vertex within 1 cm, and
its lanes lie where the lanelets are (within 5 cm for generated roads, within the reported fit
deviation for other lanelet networks)."""

from __future__ import annotations

import json
import math
import os
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest
import yaml
from commonroad.geometry.shape import Circle, Rectangle
from commonroad.planning.planning_problem import PlanningProblem, PlanningProblemSet
from commonroad.scenario.obstacle import ObstacleType, StaticObstacle
from commonroad.scenario.state import InitialState
from drawn_bars import drawn, same_stdout
from real_like import box_goal, highway, recorded_car, start
from simgap_command import simgap

from simgap.experiment.search import Budget, run_search
from simgap.experiment.single_run import RunRequest, execute
from simgap.export import checks
from simgap.export.opendrive import Method, UniformRoad, road_network
from simgap.export.opendrive_sampling import sample_roads
from simgap.export.openscenario import OpenScenarioVersion
from simgap.export.write import FITTED_TOLERANCE_M, export_road, export_run
from simgap.record import RunRecord, read_run
from simgap.scenario import build_scenario, write_scenario
from simgap.scenario.files import write_xml
from simgap.scenario.real_maps import map_files, maps_dir, scenario_on_map
from simgap.scenario.relief import RoadTilt


def run_of(scenario_xml: Path, out: Path, backend: str = "ideal", **settings) -> Path:
    execute(RunRequest(scenario=scenario_xml, backend=backend, backend_settings=settings), out)
    return out


def vertices(xosc: Path) -> dict[str, np.ndarray]:
    """Each entity's trajectory vertices (t, x, y), read with ElementTree alone."""
    root = ET.parse(xosc).getroot()
    out = {}
    for group in root.iter("ManeuverGroup"):
        actor = group.find("Actors/EntityRef").get("entityRef")
        out[actor] = np.array([(float(v.get("time")), float(v.find("Position/WorldPosition").get("x")),
                                float(v.find("Position/WorldPosition").get("y"))) for v in group.iter("Vertex")])
    return out


def assert_replays(xosc: Path, run: RunRecord) -> None:
    """Every agent follows exactly what it drove (independently of the export's own check)."""
    got = vertices(xosc)
    for aid, driven in run.history.driven.items():
        v = got[f"agent_{aid}"]
        assert len(v) == len(driven)
        assert np.allclose(v[:, 0], driven.t, atol=1e-9)
        assert np.hypot(v[:, 1] - driven.x, v[:, 2] - driven.y).max() < 0.01


def test_a_curve_with_clothoids_is_written_exactly_with_its_friction(tmp_path):
    concrete = build_scenario("curve", {"radius": 12, "angle": 90, "transition": 6, "lanes": 2})
    xml = write_scenario(concrete, tmp_path / "scenarios", preview=False)
    run_dir = run_of(xml, tmp_path / "run", "dynamic", road_friction=0.6)
    export = export_run(run_dir, tmp_path / "out")
    xodr, xosc = export.files
    assert (xodr.name, xosc.name) == (f"{concrete.name}_dynamic.xodr", f"{concrete.name}_dynamic.xosc")
    assert checks.declared_version(xodr) == ("OpenDRIVE", 1, 7) and checks.schema_errors(xodr)[1] == []
    assert checks.declared_version(xosc) == ("OpenSCENARIO", 1, 2) and checks.schema_errors(xosc)[1] == []
    road = ET.parse(xodr).getroot().find("road")
    kinds = [g[0].tag for g in road.find("planView")]
    assert kinds == ["line", "spiral", "arc", "spiral", "line"]          # the segments, not a fit
    assert float(road.get("length")) == pytest.approx(concrete.blueprint.centre().length)
    lanes = {int(l.get("id")): l for l in road.iter("lane")}
    assert sorted(lanes) == [-2, -1, 0, 1, 2]
    assert {float(l.find("width").get("a")) for i, l in lanes.items() if i} == {3.0}
    assert [lanes[i].find("roadMark").get("type") for i in (-2, -1, 0, 1, 2)] == \
        ["solid", "broken", "solid", "broken", "solid"]
    assert {float(m.get("friction")) for m in road.iter("material")} == {0.6}
    assert export.method is Method.EXACT and export.largest_deviation_m < 0.05
    assert export.trajectory_error_m < 0.01
    assert ET.parse(xosc).getroot().find(".//RoadCondition").get("frictionScaleFactor") == "0.6"
    assert_replays(xosc, read_run(run_dir))
    # other OpenSCENARIO versions on request, each valid against its own schema
    for version in (OpenScenarioVersion.V1_0, OpenScenarioVersion.V1_1, OpenScenarioVersion.V1_3):
        later = export_run(run_dir, tmp_path / version.value, version).files[1]
        assert checks.declared_version(later) == ("OpenSCENARIO", 1, version.minor)
        assert checks.schema_errors(later)[1] == []


def test_bank_and_grade_become_superelevation_and_elevation(tmp_path):
    concrete = build_scenario("curve", {"radius": 20, "angle": 45})
    roads = road_network(concrete.scenario.lanelet_network, "tilted", concrete.blueprint, UniformRoad(0.8, RoadTilt(road_bank=5.0, road_grade=3.0)))
    path = tmp_path / "tilted.xodr"
    roads.opendrive.write_xml(str(path))
    assert checks.schema_errors(path)[1] == []
    road = ET.parse(path).getroot().find("road")
    assert float(road.find("lateralProfile/superelevation").get("a")) == pytest.approx(math.radians(5.0))
    assert float(road.find("elevationProfile/elevation").get("b")) == pytest.approx(math.tan(math.radians(3.0)))


def _profile(road: ET.Element, path: str, stations: np.ndarray) -> np.ndarray:
    """The cubic records at ``path`` of an OpenDRIVE road, evaluated at ``stations``."""
    records = sorted((float(r.get("s")), *(float(r.get(k)) for k in "abcd")) for r in road.findall(path))
    starts = np.array([r[0] for r in records])
    k = np.clip(np.searchsorted(starts, stations, side="right") - 1, 0, len(records) - 1)
    s0, a, b, c, d = np.array(records)[k].T
    u = stations - s0
    return a + b * u + c * u ** 2 + d * u ** 3


def test_a_roads_relief_becomes_its_elevation_and_superelevation_profiles(tmp_path):
    concrete = build_scenario("s-curve", {"radius": 40, "angle": 60, "grade": 6, "grade_change": -12,
                                          "vertical_radius": 300, "bank": 5})
    xml = write_scenario(concrete, tmp_path / "scenarios", preview=False)
    export = export_road(xml, tmp_path / "out")              # checked: schema, lane centres
    (xodr,) = export.files
    assert export.method is Method.EXACT and checks.schema_errors(xodr)[1] == []
    road = ET.parse(xodr).getroot().find("road")
    relief = concrete.blueprint.relief
    s = np.linspace(0.0, float(road.get("length")), 2001)
    assert len(road.findall("elevationProfile/elevation")) == 3      # a grade, the crest, the grade after it
    assert np.abs(_profile(road, "elevationProfile/elevation", s) - relief.height(s)[0]).max() < 1e-9
    assert np.abs(_profile(road, "lateralProfile/superelevation", s) - relief.bank(s)[0]).max() < 1e-9
    # the knobs' bank and grade add to the relief
    tilted = road_network(concrete.scenario.lanelet_network, "tilted", concrete.blueprint, UniformRoad(1.0, RoadTilt(road_bank=2.0, road_grade=1.0)))
    tilted.opendrive.write_xml(str(tmp_path / "tilted.xodr"))
    assert checks.schema_errors(tmp_path / "tilted.xodr")[1] == []
    road = ET.parse(tmp_path / "tilted.xodr").getroot().find("road")
    assert _profile(road, "elevationProfile/elevation", s) == pytest.approx(
        relief.height(s)[0] + math.tan(math.radians(1.0)) * s, abs=1e-9)
    assert _profile(road, "lateralProfile/superelevation", s) == pytest.approx(
        relief.bank(s)[0] + math.radians(2.0), abs=1e-9)


def test_a_t_junction_with_three_agents_replays_on_its_connecting_roads(tmp_path):
    xml = write_scenario(build_scenario("t-junction", {"agents": 3}), tmp_path / "scenarios", preview=False)
    run_dir = run_of(xml, tmp_path / "run")
    run = read_run(run_dir)
    export = export_run(run_dir, tmp_path / "out")
    xodr, xosc = export.files
    root = ET.parse(xodr).getroot()
    (junction,) = root.findall("junction")
    assert len(junction.findall("connection")) == 6                       # every arm to every other
    connecting = [r for r in root.iter("road") if r.get("junction") != "-1"]
    assert len(connecting) == 6 and {r.find("planView/geometry")[0].tag for r in connecting} == {"line", "paramPoly3"}
    assert export.method is Method.EXACT and len(export.lane_deviation_m) == 9
    assert max(export.lane_deviation_m.values()) < 0.05
    assert export.entities == 3 and export.trajectory_error_m < 0.01
    assert_replays(xosc, run)
    stop = ET.parse(xosc).getroot().find("Storyboard/StopTrigger")
    goals = [c.get("name") for c in stop.iter("Condition") if c.get("name").endswith("_in_goal")]
    assert goals == ["agent_1_in_goal", "agent_2_in_goal", "agent_3_in_goal"]


def recorded_highway(tmp_path: Path) -> Path:
    """A three-lane highway with recorded traffic of every kind: cars, a truck, a cyclist, a
    pedestrian, a parked car."""
    scenario = highway(lanes=3, length=400.0)
    scenario.add_objects(recorded_car(201, 60.0, 0, 12.0, 120))
    scenario.add_objects(recorded_car(202, 20.0, 2, 16.0, 120, shape=Rectangle(12.0, 2.5), kind=ObstacleType.TRUCK))
    scenario.add_objects(recorded_car(203, 90.0, 1, 5.0, 120, shape=Rectangle(1.8, 0.7), kind=ObstacleType.BICYCLE))
    scenario.add_objects(recorded_car(204, 300.0, 2, 1.2, 120, shape=Circle(0.4), kind=ObstacleType.PEDESTRIAN))
    scenario.add_objects(StaticObstacle(205, ObstacleType.PARKED_VEHICLE, Rectangle(4.5, 1.8),
                                        InitialState(position=np.array([350.0, 8.75]), orientation=0.0, time_step=0)))
    problems = PlanningProblemSet([PlanningProblem(1, start(5.0, 0, 10.0), box_goal(200.0, 0, (0, 300)))])
    path = tmp_path / "highway.xml"
    write_xml(scenario, problems, path)
    return path


def test_a_recorded_scenario_with_traffic_is_fitted_and_replays(tmp_path):
    xml = recorded_highway(tmp_path)
    run_dir = run_of(xml, tmp_path / "run")
    export = export_run(run_dir, tmp_path / "out")
    xodr, xosc = export.files
    assert export.method is Method.FITTED and len(export.fit_deviation_m) == 2     # a three-lane road per segment
    assert max(export.fit_deviation_m.values()) < 0.01                              # straight lanes fit exactly
    assert all(export.lane_deviation_m[r] <= export.fit_deviation_m[r] + FITTED_TOLERANCE_M for r in export.lane_deviation_m)
    first, second = ET.parse(xodr).getroot().iter("road")
    assert [int(l.get("id")) for l in first.iter("lane")] == [0, -1, -2, -3]
    assert first.find("link/successor").get("elementId") == second.get("id")         # joined road to road
    assert len(first.findall(".//lane/link/successor")) == 3                        # and lane by lane
    links = export.links
    assert (links.successors_kept, links.neighbours_kept, links.junctions) == (3, 8, 0)
    assert (links.successors, links.neighbours) == (3, 8)
    root = ET.parse(xosc).getroot()
    kinds = {o.get("name"): o[0] for o in root.iter("ScenarioObject")}
    assert kinds["obstacle_202"].get("vehicleCategory") == "truck"
    assert kinds["obstacle_203"].get("vehicleCategory") == "bicycle"
    assert kinds["obstacle_204"].tag == "Pedestrian" and kinds["obstacle_205"].get("vehicleCategory") == "car"
    assert float(kinds["obstacle_202"].find("BoundingBox/Dimensions").get("length")) == 12.0
    got = vertices(xosc)
    assert "obstacle_205" not in got                                                # parked: placed, not moved
    truck = got["obstacle_202"]
    assert len(truck) == 121 and np.allclose(truck[-1, 1:], [20.0 + 16.0 * 12.0, 8.75])
    assert export.trajectory_error_m < 0.01
    assert_replays(xosc, read_run(run_dir))


def test_a_scenario_on_a_real_map_is_fitted_within_its_reported_deviation(tmp_path):
    maps = {p.name: p for p in map_files()}
    if "DEU_AachenFrankenburg-1.xml" not in maps:
        pytest.skip(f"no real maps in {maps_dir()}")
    built = scenario_on_map(maps["DEU_AachenFrankenburg-1.xml"], 0)
    xml = tmp_path / "real.xml"
    write_xml(*built, xml)
    export = export_run(run_of(xml, tmp_path / "run"), tmp_path / "out")
    assert export.method is Method.FITTED and export.entities == 1 + len(built[0].dynamic_obstacles)
    assert all(export.lane_deviation_m[r] <= export.fit_deviation_m[r] + FITTED_TOLERANCE_M for r in export.lane_deviation_m)
    assert np.median(list(export.fit_deviation_m.values())) < 0.1
    assert export.trajectory_error_m < 0.01


def test_a_scenario_exports_its_road_alone(tmp_path):
    xml = write_scenario(build_scenario("intersection", {"agents": 2}), tmp_path, preview=False)
    export = export_road(xml, tmp_path / "road")
    (xodr,) = export.files
    assert xodr.suffix == ".xodr" and export.method is Method.EXACT
    roads = sample_roads(xodr)
    assert len(roads) == 4 + 12 and max(export.lane_deviation_m.values()) < 0.05


def test_a_search_exports_one_folder_per_distinct_violation(tmp_path):
    spec = tmp_path / "search.yaml"
    spec.write_text(yaml.safe_dump({
        "name": "grip", "logical": "curve", "parameters": {"radius": {"min": 10, "max": 30},
                                                            "initial_speed": {"min": 10, "max": 20}},
        "knobs": {"road_friction": {"min": 0.2, "max": 0.4}},
        "ladder": [{"backend": "ideal"}, {"backend": "dynamic"}], "failure": {"above": {"peak_grip_use": 0.9}},
        "strategies": ["random"], "run_timeout_s": 120}))
    (result,) = run_search(spec, tmp_path / "search", Budget(runs=4), workers=2)
    assert result.distinct >= 1
    env = dict(os.environ, COLUMNS="200", SIMGAP_PROGRESS="always")          # its bars drawn into the captured stderr
    proc = simgap("export", tmp_path / "search", "--violations", "--out", tmp_path / "found", env=env)
    assert proc.returncode == 0, proc.stderr
    bars = drawn(proc.stderr)
    assert bars["violations"][-1]["counts"] == f"{result.distinct}/{result.distinct}"
    assert {"fitting roads", "checking against the schema"} <= set(bars) or {"checking lane centres"} <= set(bars)
    plain = simgap("export", tmp_path / "search", "--violations", "--out", tmp_path / "again",
                   env=env | {"SIMGAP_PROGRESS": "never"})
    assert drawn(plain.stderr) == {}
    same_stdout(proc.stdout.replace(str(tmp_path / "found"), "OUT"), plain.stdout.replace(str(tmp_path / "again"), "OUT"))
    folders = sorted(p for p in (tmp_path / "found").iterdir() if not p.name.startswith("."))   # (and the list of them)
    assert len(folders) == result.distinct and f"{result.distinct} distinct violation" in proc.stdout
    for folder in folders:
        names = sorted(p.name for p in folder.iterdir())
        assert names == sorted(f"{folder.name}{s}" for s in (".xml", ".xodr", ".xosc")) + ["violation.json"]
        facts = json.loads((folder / "violation.json").read_text())
        assert facts["failure"].startswith("peak_grip_use")
        assert facts["high_fidelity"]["metrics"]["peak_grip_use"] > 0.9 >= facts["ideal"]["metrics"]["peak_grip_use"]
        assert {d["name"] for d in facts["dimensions"]} == {"radius", "initial_speed", "road_friction"}
        friction = next(d["value"] for d in facts["dimensions"] if d["name"] == "road_friction")
        xosc = folder / f"{folder.name}.xosc"
        assert float(ET.parse(xosc).getroot().find(".//RoadCondition").get("frictionScaleFactor")) == \
            pytest.approx(friction)
        for path in (xosc, folder / f"{folder.name}.xodr"):
            assert checks.schema_errors(path)[1] == []


@pytest.fixture(scope="module")
def a_run(tmp_path_factory) -> Path:
    tmp = tmp_path_factory.mktemp("a_run")
    return run_of(write_scenario(build_scenario("curve", {"radius": 30, "angle": 30}), tmp, preview=False), tmp / "run")


@pytest.mark.parametrize("args, fragments", [
    (["nowhere"], ["no such file or directory"]),
    (["RUN/run.json"], ["not a run directory"]),
    (["RUN", "--format", "opendrive"], ["field '--format'", "allowed: openscenario"]),
    (["RUN", "--version", "2.0"], ["field '--version'", "1.0, 1.1, 1.2, 1.3"]),
    (["RUN", "--format", "csv"], ["unknown format 'csv'", "openscenario, opendrive"]),
    (["RUN", "--violations"], ["not a search directory"]),
])
def test_bad_input_is_one_line_exit_2_and_writes_nothing(tmp_path, a_run, args, fragments):
    args = [a.replace("RUN", str(a_run)) if a.startswith("RUN") else str(tmp_path / a) if a == "nowhere" else a
            for a in args]
    proc = simgap("export", *args, "--out", tmp_path / "out")
    assert proc.returncode == 2 and "Traceback" not in proc.stderr and len(proc.stderr.strip().splitlines()) == 1
    for fragment in fragments:
        assert fragment in proc.stderr, proc.stderr
    assert not (tmp_path / "out").exists() or not any((tmp_path / "out").iterdir())


def test_an_export_whose_check_fails_leaves_nothing_behind(tmp_path, a_run, monkeypatch):
    monkeypatch.setattr(checks, "trajectory_error", lambda path, expected: 0.5)
    with pytest.raises(checks.CheckFailed, match="parses back 0.5000 m"):
        export_run(a_run, tmp_path / "out")
    assert list((tmp_path / "out").iterdir()) == []
