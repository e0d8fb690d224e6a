"""A recorded lanelet network as OpenDRIVE roads, links and junctions: neighbours become one road,
roads meet with one heading (G1) and without gaps between linked lanes, and every successor
relation where lanelets fork is a junction connection with its lane link."""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest
from commonroad.planning.planning_problem import PlanningProblemSet
from commonroad.scenario.lanelet import Lanelet, LaneletNetwork
from commonroad.scenario.scenario import Scenario

from simgap.export.opendrive import Method
from simgap.export.opendrive_sampling import reference_ends, sample_roads
from simgap.export.write import export_road
from simgap.scenario.files import write_xml
from simgap.scenario.real_maps import map_files, maps_dir

W = 3.5
HEADING_TOLERANCE_DEG = 0.5
GAP_TOLERANCE_M = 0.01


def lanelet(lid: int, left: np.ndarray, right: np.ndarray, **relations) -> Lanelet:
    return Lanelet(left, 0.5 * (left + right), right, lid, **relations)


def polyline(start: np.ndarray, heading_deg: float, length: float, n: int = 12) -> np.ndarray:
    d = np.array([math.cos(math.radians(heading_deg)), math.sin(math.radians(heading_deg))])
    return start + np.linspace(0.0, length, n)[:, None] * d


def right_turn(start: np.ndarray, heading_deg: float, radius: float, n: int = 20) -> np.ndarray:
    h = math.radians(heading_deg)
    centre = start + radius * np.array([math.sin(h), -math.cos(h)])
    angles = h + math.pi / 2 - np.linspace(0.0, math.pi / 2, n)
    return centre + radius * np.column_stack([np.cos(angles), np.sin(angles)])


def forked_road() -> LaneletNetwork:
    """Two lanes (1 left, 2 right) along +x, then two lanes that go on 10 degrees to the left from a
    kink the lanelets share (3, 4), then a fork: both lanes go on (5, 6) and the right lane also
    turns right (7)."""
    y = (W, 0.0, -W)                                    # the bounds, left to right
    a = [polyline(np.array([0.0, v]), 0.0, 30.0) for v in y]
    b = [polyline(p[-1], 10.0, 30.0) for p in a]
    c = [polyline(p[-1], 10.0, 25.0) for p in b]
    turn_left = right_turn(b[1][-1], 10.0, 15.0 + W)
    turn_right = right_turn(b[2][-1], 10.0, 15.0)
    same = dict(adjacent_left_same_direction=True, adjacent_right_same_direction=True)
    return LaneletNetwork.create_from_lanelet_list([
        lanelet(1, a[0], a[1], successor=[3], adjacent_right=2, **same),
        lanelet(2, a[1], a[2], successor=[4], adjacent_left=1, **same),
        lanelet(3, b[0], b[1], predecessor=[1], successor=[5], adjacent_right=4, **same),
        lanelet(4, b[1], b[2], predecessor=[2], successor=[6, 7], adjacent_left=3, **same),
        lanelet(5, c[0], c[1], predecessor=[3], adjacent_right=6, **same),
        lanelet(6, c[1], c[2], predecessor=[4], adjacent_left=5, **same),
        lanelet(7, turn_left, turn_right, predecessor=[4]),
    ])


@pytest.fixture(scope="module")
def forked(tmp_path_factory) -> tuple[Path, object]:
    scenario = Scenario(0.1)
    scenario.add_objects(forked_road())
    xml = tmp_path_factory.mktemp("forked") / "forked.xml"
    write_xml(scenario, PlanningProblemSet(), xml)
    export = export_road(xml, xml.parent / "out")
    return export.files[0], export


def contacts(xodr: Path) -> list[tuple[int, str, int, str]]:
    """Every place where two roads meet: (road, its end, other road, its end), from road links and
    from junction connections (incoming road to connecting road, connecting road to the next)."""
    root = ET.parse(xodr).getroot()
    out = []
    for road in root.iter("road"):
        for way, end in (("successor", "end"), ("predecessor", "start")):
            link = road.find(f"link/{way}")
            if link is not None and link.get("elementType") == "road":
                out.append((int(road.get("id")), end, int(link.get("elementId")), link.get("contactPoint")))
    return out


def test_neighbours_are_one_road_and_a_fork_is_a_junction_with_a_connection_per_successor(forked):
    xodr, export = forked
    assert export.method is Method.FITTED
    root = ET.parse(xodr).getroot()
    roads = {int(r.get("id")): r for r in root.iter("road")}
    ordinary = [r for r in roads.values() if r.get("junction") == "-1"]
    assert sorted(len(r.findall(".//right/lane")) for r in ordinary) == [1, 2, 2, 2]   # 1+2, 3+4, 5+6 and 7's rest
    (junction,) = root.findall("junction")
    connections = junction.findall("connection")
    assert len(connections) == 3                                    # 3->5, 4->6, 4->7
    incoming = {int(c.get("incomingRoad")) for c in connections}
    assert len(incoming) == 1                                       # the road of 3 and 4
    for c in connections:
        (link,) = c.findall("laneLink")
        connecting = roads[int(c.get("connectingRoad"))]
        assert connecting.get("junction") == junction.get("id") and link.get("to") == "-1"
        assert connecting.find("link/predecessor").get("elementId") == c.get("incomingRoad")
    assert {l.get("from") for c in connections for l in c.iter("laneLink")} == {"-1", "-2"}
    links = export.links
    assert (links.successors_kept, links.successors) == (5, 5) and links.junction_connections == 3
    assert (links.neighbours_kept, links.neighbours) == (6, 6) and links.junctions == 1


def test_roads_meet_with_one_heading_and_no_gap_between_linked_lanes(forked):
    xodr, export = forked
    ends = reference_ends(xodr)
    samples = {r.road: r for r in sample_roads(xodr)}
    met = contacts(xodr)
    assert len(met) >= 2 * 3 + 2                                   # the direct link both ways, each connecting road
    for road, end, other, other_end in met:
        heading = ends[road][end == "end"][2]
        other_heading = ends[other][other_end == "end"][2]
        if end == other_end:                                        # roads meeting head to head
            other_heading += math.pi
        assert abs(math.degrees(math.remainder(heading - other_heading, 2 * math.pi))) < HEADING_TOLERANCE_DEG
    for road, end, other, other_end in met:                        # lane borders where the lanes are linked
        lanes = ET.parse(xodr).getroot().find(f".//road[@id='{road}']")
        for lane in lanes.iter("lane"):
            way = "successor" if end == "end" else "predecessor"
            for link in lane.findall(f"link/{way}"):
                here = samples[road].lane_borders[int(lane.get("id"))][-1 if end == "end" else 0]
                there = samples[other].lane_borders[int(link.get("id"))][-1 if other_end == "end" else 0]
                assert np.linalg.norm(here - there) < GAP_TOLERANCE_M


def test_a_kinked_joint_is_smoothed_on_both_sides(forked):
    """Lanelets 1 and 3 meet with a 10 degree kink; their roads meet at 5 degrees and stay within
    5 cm of the lanelets (across the lanes)."""
    xodr, export = forked
    ends = reference_ends(xodr)
    kink = [(r, o) for r, e, o, oe in contacts(xodr) if e == "end" and oe == "start" and
            ET.parse(xodr).getroot().find(f".//road[@id='{r}']").get("junction") == "-1" and
            ET.parse(xodr).getroot().find(f".//road[@id='{o}']").get("junction") == "-1"]
    (first, second), = kink
    assert math.degrees(ends[first][1][2]) == pytest.approx(5.0, abs=0.5)
    assert max(export.lane_deviation_m.values()) < 0.05


def test_the_fork_passes_asam_qc(forked, asam_qc):
    xodr, _ = forked
    report = asam_qc(xodr)
    assert (report.errors, report.warnings) == (0, 0), report.rules


def test_a_real_intersection_passes_asam_qc_and_keeps_every_successor(tmp_path, asam_qc):
    maps = {p.stem: p for p in map_files()}
    if "BGR_Intersection-1" not in maps:
        pytest.skip(f"no real maps in {maps_dir()}")
    export = export_road(maps["BGR_Intersection-1"], tmp_path)
    report = asam_qc(export.files[0])
    assert report.errors == 0, report.rules
    header = ET.parse(export.files[0]).getroot().find("header")
    assert float(header.get("east")) > float(header.get("west")) and float(header.get("north")) > float(header.get("south"))
    links = export.links
    assert links.successors_kept == links.successors == 35 and links.junctions >= 1


def two_way_road() -> LaneletNetwork:
    """A two-way road along +x that turns 10 degrees to the left after 30 m: lanes 1 -> 3 go along
    it (right of the centre line), lanes 4 -> 2 come back (left of it); 1|2 and 3|4 are each other's
    opposite-direction left neighbours."""
    centre = polyline(np.array([0.0, 0.0]), 0.0, 30.0)
    centre = np.vstack([centre, polyline(centre[-1], 10.0, 30.0)[1:]])
    d = np.gradient(centre, axis=0)
    normal = np.column_stack([-d[:, 1], d[:, 0]]) / np.linalg.norm(d, axis=1)[:, None]
    right, left = centre - W * normal, centre + W * normal
    a, b = slice(0, 12), slice(11, None)
    opp = {"adjacent_left_same_direction": False}
    return LaneletNetwork.create_from_lanelet_list([
        lanelet(1, centre[a], right[a], successor=[3], adjacent_left=2, **opp),
        lanelet(3, centre[b], right[b], predecessor=[1], adjacent_left=4, **opp),
        lanelet(2, centre[a][::-1], left[a][::-1], predecessor=[4], adjacent_left=1, **opp),
        lanelet(4, centre[b][::-1], left[b][::-1], successor=[2], adjacent_left=3, **opp),
    ])


@pytest.fixture(scope="module")
def two_way(tmp_path_factory) -> tuple[Path, object]:
    scenario = Scenario(0.1)
    scenario.add_objects(two_way_road())
    xml = tmp_path_factory.mktemp("two_way") / "two_way.xml"
    write_xml(scenario, PlanningProblemSet(), xml)
    export = export_road(xml, xml.parent / "out")
    return export.files[0], export


def test_opposite_neighbours_are_one_road_with_left_and_right_lanes(two_way, asam_qc):
    """Opposite-direction neighbours become the left and right lanes of one road (a neighbour
    relation kept across the centre lane), linked road to road lane by lane for both directions,
    G1 and without gaps where they meet; ASAM QC finds nothing."""
    xodr, export = two_way
    root = ET.parse(xodr).getroot()
    roads = root.findall("road")
    assert len(roads) == 2 and not root.findall("junction")
    for road in roads:
        assert len(road.findall(".//left/lane")) == 1 and len(road.findall(".//right/lane")) == 1
    links = export.links
    assert (links.neighbours_kept, links.neighbours) == (4, 4)
    assert (links.successors_kept, links.successors) == (2, 2)
    assert max(export.lane_deviation_m.values()) < 0.05
    ends = reference_ends(xodr)
    samples = {r.road: r for r in sample_roads(xodr)}
    met = contacts(xodr)
    assert len(met) == 2
    for road, end, other, other_end in met:
        heading = ends[road][end == "end"][2]
        other_heading = ends[other][other_end == "end"][2] + (math.pi if end == other_end else 0.0)
        assert abs(math.degrees(math.remainder(heading - other_heading, 2 * math.pi))) < HEADING_TOLERANCE_DEG
        for lane in root.find(f".//road[@id='{road}']").iter("lane"):
            for link in lane.findall(f"link/{'successor' if end == 'end' else 'predecessor'}"):
                here = samples[road].lane_borders[int(lane.get("id"))][-1 if end == "end" else 0]
                there = samples[other].lane_borders[int(link.get("id"))][-1 if other_end == "end" else 0]
                assert np.linalg.norm(here - there) < GAP_TOLERANCE_M
    report = asam_qc(xodr)
    assert (report.errors, report.warnings) == (0, 0), report.rules


def test_a_real_two_way_network_keeps_its_opposite_neighbours_and_lane_centres(tmp_path, asam_qc):
    """DEU_AachenFrankenburg-1's 48 neighbour relations are all between opposite directions (kept: 0
    before left lanes were written); all are kept (the askew pair 133|137, 1.9 m long, ends 0.75 m
    apart along the road, is one road: a direct link's joint takes the skew), and the lane centres lie within 0.1 m of the
    lanelets' centre lines (read back every 0.1 m)."""
    maps = {p.stem: p for p in map_files()}
    if "DEU_AachenFrankenburg-1" not in maps:
        pytest.skip(f"no real maps in {maps_dir()}")
    export = export_road(maps["DEU_AachenFrankenburg-1"], tmp_path)
    links = export.links
    assert links.successors_kept == links.successors == 52
    assert (links.neighbours_kept, links.neighbours) == (48, 48)
    assert export.largest_deviation_m <= 0.1
    report = asam_qc(export.files[0])
    assert report.errors == 0, report.rules


def _askew_two_way(skew: float, joined: bool) -> LaneletNetwork:
    """A 20 m two-way road along +x (lanelet 1 eastbound, 2 westbound, sharing y = 0) whose
    eastbound lane's right bound runs ``skew`` metres past the rest at the east end; where
    ``joined``, both lanelets continue there (3 after 1, 2 after 4)."""
    x = np.linspace(0.0, 20.0, 11)
    centre = np.column_stack([x, np.zeros_like(x)])
    outer_east = np.column_stack([np.linspace(0.0, 20.0 + skew, 11), np.full_like(x, -W)])
    outer_west = np.column_stack([x, np.full_like(x, W)])[::-1]
    east = lanelet(1, centre, outer_east, adjacent_left=2, adjacent_left_same_direction=False,
                   successor=[3] if joined else None)
    west = lanelet(2, centre[::-1], outer_west, adjacent_left=1, adjacent_left_same_direction=False,
                   predecessor=[4] if joined else None)
    lanelets = [east, west]
    if joined:
        on = np.column_stack([np.linspace(20.0, 40.0, 11), np.zeros(11)])
        lanelets += [lanelet(3, on, np.column_stack([np.linspace(20.0 + skew, 40.0, 11), np.full(11, -W)]),
                             predecessor=[1]),
                     lanelet(4, on[::-1], np.column_stack([np.linspace(40.0, 20.0, 11), np.full(11, W)]),
                             successor=[2])]
    network = LaneletNetwork()
    for l in lanelets:
        network.add_lanelet(l)
    return network


@pytest.mark.parametrize(("skew", "joined"), [(1.0, False), (3.0, True), (12.0, False)])
def test_opposite_neighbours_ending_askew_are_one_road(skew, joined):
    """Opposite neighbours whose lanes end askew (beyond the square guard: 2 m, a quarter of the
    road) are still one road where the lanelets continue at that end (a link's joint or a junction's
    cut takes the skew) and at an open end, where no link can part (CHN_Roundabout-1's 111|109,
    12 m askew on a 16.5 m road: two roads and the relation lost before)."""
    from simgap.export import road_topology

    roads = road_topology.strips(_askew_two_way(skew, joined))
    assert any(s.left == 1 and set(s.lanelets) == {1, 2} for s in roads)


def test_open_askew_two_way_road_keeps_both_neighbour_relations_qc_clean(tmp_path, asam_qc):
    """The two-way road ending 12 m askew with nothing beyond, written: one road whose file keeps
    both neighbour relations; ASAM QC finds nothing."""
    scenario = Scenario(0.1)
    scenario.add_objects(_askew_two_way(12.0, False))
    xml = tmp_path / "askew.xml"
    write_xml(scenario, PlanningProblemSet(), xml)
    export = export_road(xml, tmp_path / "out")
    assert (export.links.neighbours_kept, export.links.neighbours) == (2, 2)
    report = asam_qc(export.files[0])
    assert (report.errors, report.warnings) == (0, 0), report.rules


def _malformed_pair() -> LaneletNetwork:
    """Two eastbound lanes along +x: 1 on the left (0 < y < W), well formed; 2 on its right, whose
    left bound starts 0.3 m right of 1's right bound and meets it at the east end, and whose right
    bound doubles back at its last vertex (malformed, as DEU_Kackertstrasse-1's 44 beside 43)."""
    x = np.linspace(0.0, 20.0, 11)
    shared = np.column_stack([x, np.zeros_like(x)])
    apart = np.column_stack([x, -0.3 * (1.0 - x / 20.0)])
    outer = np.column_stack([np.append(x[:-1], 17.0), np.full_like(x, -W)])
    same = dict(adjacent_left_same_direction=True, adjacent_right_same_direction=True)
    network = LaneletNetwork()
    network.add_lanelet(lanelet(1, np.column_stack([x, np.full_like(x, W)]), shared, adjacent_right=2, **same))
    network.add_lanelet(lanelet(2, apart, outer, adjacent_left=1, **same))
    return network


def test_a_malformed_lanelet_and_its_near_neighbour_are_one_road_on_the_neighbours_bound(tmp_path, asam_qc):
    """Same-direction neighbours whose common bound differs by more than 0.1 m at one end are one
    road where one of them is malformed: the border is the well-formed lanelet's bound (its lane
    stays on its centre), both neighbour relations are kept and ASAM QC finds nothing."""
    from simgap.export import road_topology

    network = _malformed_pair()
    roads = road_topology.strips(network)
    assert [s.lanelets for s in roads] == [(1, 2)]
    assert road_topology._malformed(network.find_lanelet_by_id(2))
    assert np.allclose(roads[0].bounds[1], network.find_lanelet_by_id(1).right_vertices)
    assert np.allclose(roads[0].centres[0], network.find_lanelet_by_id(1).center_vertices)
    scenario = Scenario(0.1)
    scenario.add_objects(network)
    xml = tmp_path / "malformed.xml"
    write_xml(scenario, PlanningProblemSet(), xml)
    export = export_road(xml, tmp_path / "out")
    assert (export.links.neighbours_kept, export.links.neighbours) == (2, 2)
    report = asam_qc(export.files[0])
    assert (report.errors, report.warnings) == (0, 0), report.rules
