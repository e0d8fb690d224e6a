"""OpenDRIVE in: the reference line's geometry, lanelets within 0.05 m of the lanes they stand for,
links through lane sections, roads and junctions, neighbours, the relief kept, and refusals — on
public files no one here wrote (tests/scenario/opendrive_roads, see its README)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
import shapely
from scipy.integrate import quad
from shapely.geometry import LineString

from simgap.errors import InputError
from simgap.scenario.opendrive.document import Geometry, read_document
from simgap.scenario.opendrive.lanes import lane_edges, road_pieces
from simgap.scenario.opendrive.network import opendrive_network
from simgap.scenario.opendrive.reference_line import geometry_poses, reference_poses

ROADS = Path(__file__).parent / "opendrive_roads"
FILES = sorted(ROADS.glob("*.xodr"))


@pytest.fixture(scope="module", params=FILES, ids=[p.stem for p in FILES])
def imported(request):
    return opendrive_network(request.param)


def _integrated(heading, length: float) -> tuple[float, float]:
    """The end of a curve from the origin whose heading along its arc length is ``heading``."""
    return (quad(lambda u: math.cos(heading(u)), 0.0, length, limit=200)[0],
            quad(lambda u: math.sin(heading(u)), 0.0, length, limit=200)[0])


@pytest.mark.parametrize("geometry, heading", [
    (Geometry("arc", 0, 0, 0, 0.3, 40.0, (-0.05,)), lambda u: 0.3 - 0.05 * u),
    (Geometry("spiral", 0, 0, 0, 0.3, 60.0, (0.01, -0.03)), lambda u: 0.3 + 0.01 * u - 0.02 / 60.0 * u * u),
])
def test_arcs_and_spirals_end_where_their_curvature_takes_them(geometry, heading):
    end = geometry_poses(geometry, np.array([geometry.length]))
    x, y = _integrated(heading, geometry.length)
    assert math.hypot(end.x[0] - x, end.y[0] - y) < 1e-6
    assert end.hdg[0] == pytest.approx(heading(geometry.length), abs=1e-9)


@pytest.mark.parametrize("kind, values, p_end", [
    ("paramPoly3", (0.0, 30.0, 2.0, -1.0, 0.0, 0.0, 6.0, -2.0, 1.0), 1.0),      # normalised parameter
    ("paramPoly3", (0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 0.004, -5e-5, 0.0), 30.0),    # parameter about the arc length
    ("poly3", (0.0, 0.0, 0.004, -5e-5), None),
])
def test_polynomial_curves_are_evaluated_by_arc_length(kind, values, p_end):
    """The station along a poly3 or paramPoly3 is the arc length along its curve: equal steps in s
    are equal steps along the curve, which ends where its polynomials end."""
    if kind == "poly3":
        u_end = 30.0
        length = quad(lambda u: math.hypot(1.0, 2 * values[2] * u + 3 * values[3] * u * u), 0, u_end)[0]
        end = (u_end, sum(c * u_end ** k for k, c in enumerate(values)))
    else:
        du = lambda p: values[1] + 2 * values[2] * p + 3 * values[3] * p * p      # noqa: E731
        dv = lambda p: values[5] + 2 * values[6] * p + 3 * values[7] * p * p      # noqa: E731
        length = quad(lambda p: math.hypot(du(p), dv(p)), 0, p_end)[0] if p_end == 1.0 else p_end
        end = tuple(sum(c * p_end ** k for k, c in enumerate(values[i:i + 4])) for i in (0, 4))
    g = Geometry(kind, 0.0, 0.0, 0.0, 0.0, length, values)
    poses = geometry_poses(g, np.linspace(0.0, length, 301))
    steps = np.hypot(np.diff(poses.x), np.diff(poses.y))
    assert np.allclose(steps, steps.mean(), rtol=1e-3)
    assert (poses.x[-1], poses.y[-1]) == pytest.approx(end, abs=1e-6)
    if p_end != 30.0:       # a parameter range of the curve's own length: s is the arc length
        assert steps.sum() == pytest.approx(length, rel=1e-4)


@pytest.mark.parametrize("path", FILES, ids=[p.stem for p in FILES])
def test_each_geometry_ends_where_the_file_starts_the_next(path):
    """The files state where every geometry starts: evaluating the one before it lands there."""
    worst = 0.0
    for road in read_document(path).roads.values():
        for g, nxt in zip(road.geometries, road.geometries[1:]):
            end = geometry_poses(g, np.array([g.length]))
            worst = max(worst, math.hypot(end.x[0] - nxt.x, end.y[0] - nxt.y))
            assert math.remainder(end.hdg[0] - nxt.hdg, 2 * math.pi) == pytest.approx(0.0, abs=1e-4)
    assert worst < 1e-3


def test_every_lanelet_centre_lies_within_5_cm_of_its_lane_centre(imported):
    """Each lane's centre evaluated every 5 cm lies within 0.05 m of its lanelet's centre line."""
    network, roads = imported.lanelets, imported.document.roads
    worst = 0.0
    for lanelet_id, place in imported.origin.lanelets.items():
        road = roads[place.road]
        s = np.linspace(place.s_start, place.s_end, max(2, int((place.s_end - place.s_start) / 0.05)))
        low, high = lane_edges(road, road.sections[place.section], s)[place.lane]
        poses = reference_poses(road.geometries, s)
        t = 0.5 * (low + high)
        roll = np.zeros_like(s)
        for r in road.superelevation:       # the cross section rolled by the superelevation
            u = s - r.s
            roll = np.where(u >= 0, r.a + u * (r.b + u * (r.c + u * r.d)), roll)
        t = t * np.cos(roll)
        points = np.column_stack([poses.x - t * np.sin(poses.hdg), poses.y + t * np.cos(poses.hdg)])
        centre = LineString(network.find_lanelet_by_id(lanelet_id).center_vertices)
        worst = max(worst, float(shapely.distance(centre, shapely.points(points)).max()))
    assert worst < 0.05


def test_lanelets_follow_their_lanes_and_neighbours_share_their_bounds(imported):
    network = imported.lanelets
    for lanelet in network.lanelets:
        for bound in (lanelet.left_vertices, lanelet.right_vertices):
            assert np.all(np.linalg.norm(np.diff(bound, axis=0), axis=1) <= 1.0 + 1e-6)
        if lanelet.adj_left is not None:
            left = network.find_lanelet_by_id(lanelet.adj_left)
            shared = left.right_vertices if lanelet.adj_left_same_direction else left.left_vertices[::-1]
            assert np.allclose(shared, lanelet.left_vertices, atol=1e-9)
    assert imported.links.kept == imported.links.source


def _lanelet(imported, road: str, lane: int, s: float) -> int:
    return next(i for i, p in imported.origin.lanelets.items()
                if p.road == road and p.lane == lane and p.s_start <= s <= p.s_end)


def test_a_junction_links_each_incoming_lane_to_every_turn_and_each_turn_onwards():
    """esmini's four-way junction: from every arm, a left turn, straight on and a right turn, each
    a lanelet of the intersection that leads onto the outgoing lane of its arm."""
    imported = opendrive_network(ROADS / "fabriksgatan.xodr")
    network = imported.lanelets
    incoming = _lanelet(imported, "2", -1, 300.0)           # the long arm, towards the junction
    turns = network.find_lanelet_by_id(incoming).successor
    assert len(turns) == 3
    onwards = {imported.origin.lanelets[network.find_lanelet_by_id(t).successor[0]].road for t in turns}
    assert onwards == {"0", "1", "3"}
    assert all(imported.sections.kind_of(t) == "junction" and network.find_lanelet_by_id(t).predecessor == [incoming]
               for t in turns)
    assert len([s for s in imported.sections.kinds.values() if s == "junction"]) == 12


def test_an_exit_forks_the_lane_and_a_merge_joins_two():
    exits = opendrive_network(ROADS / "Ex_Entry_Exit.xodr")
    fork = exits.lanelets.find_lanelet_by_id(_lanelet(exits, "300", -3, 300.0))
    assert {exits.origin.lanelets[s].road for s in fork.successor} == {"305", "308"}   # on, or off the motorway
    merge = opendrive_network(ROADS / "two_plus_one.xodr")
    joined = merge.lanelets.find_lanelet_by_id(_lanelet(merge, "1", -1, 400.0))
    assert [merge.origin.lanelets[p].lane for p in joined.predecessor] == [-2]        # the right lane goes on


def test_two_way_lanes_are_opposite_neighbours_and_same_way_lanes_same():
    imported = opendrive_network(ROADS / "velodrome.xodr")
    network = imported.lanelets
    middle = network.find_lanelet_by_id(_lanelet(imported, "1", -2, 100.0))
    assert (middle.adj_left, middle.adj_left_same_direction) == (_lanelet(imported, "1", -1, 100.0), True)
    assert (middle.adj_right, middle.adj_right_same_direction) == (_lanelet(imported, "1", -3, 100.0), True)
    crest = opendrive_network(ROADS / "crest-curve.xodr")
    right = crest.lanelets.find_lanelet_by_id(_lanelet(crest, "0", -1, 50.0))
    assert (right.adj_left, right.adj_left_same_direction) == (_lanelet(crest, "0", 1, 50.0), False)
    # the closed loop: the road's end runs on into its own start
    last = network.find_lanelet_by_id(_lanelet(imported, "1", -2, 1999.0))
    assert last.successor == [_lanelet(imported, "1", -2, 1.0)]


def test_left_hand_traffic_drives_the_lanes_the_other_way(tmp_path):
    text = (ROADS / "crest-curve.xodr").read_text().replace('junction="-1">', 'junction="-1" rule="LHT">', 1)
    (tmp_path / "lht.xodr").write_text(text)
    rht, lht = (opendrive_network(p) for p in (ROADS / "crest-curve.xodr", tmp_path / "lht.xodr"))
    for imported, along in ((rht, True), (lht, False)):
        lanelet = imported.lanelets.find_lanelet_by_id(_lanelet(imported, "0", -1, 50.0))
        assert bool(lanelet.center_vertices[-1][0] > lanelet.center_vertices[0][0]) is along


def test_sidewalks_borders_and_shoulders_are_left_out():
    imported = opendrive_network(ROADS / "fabriksgatan.xodr")
    kinds = {(p.road, p.lane) for p in imported.origin.lanelets.values()}
    lanes = {(r.id, l.id): l.type for r in imported.document.roads.values() for sec in r.sections for l in sec.lanes}
    assert {lanes[k] for k in kinds} == {"driving"}
    assert "sidewalk" in lanes.values()


def test_the_relief_is_kept_per_road_and_per_lanelet_bound():
    crest = opendrive_network(ROADS / "crest-curve.xodr")
    assert set(crest.origin.profiles) == {"0"}
    top = crest.origin.lanelets[_lanelet(crest, "0", -1, 270.0)]
    assert max(top.left_z) == pytest.approx(6.0, abs=0.01)          # the crest, 6 m up at s = 270 m
    banked = opendrive_network(ROADS / "velodrome.xodr")
    curve = banked.origin.lanelets[_lanelet(banked, "1", -1, 700.0)]
    lanelet = banked.lanelets.find_lanelet_by_id(_lanelet(banked, "1", -1, 700.0))
    width_in_plane = np.linalg.norm(lanelet.left_vertices - lanelet.right_vertices, axis=1)
    rise = np.array(curve.left_z) - np.array(curve.right_z)
    # banked at 60 degrees: the lane's width w lies w cos 60 across and w sin 60 up (the inside lower)
    assert np.allclose(np.hypot(width_in_plane, rise), 3.0, atol=1e-4)
    assert rise.min() == pytest.approx(-3.0 * math.sin(math.radians(60)), abs=1e-4)
    assert all(p.left_z is None for p in opendrive_network(ROADS / "fabriksgatan.xodr").origin.lanelets.values())


def test_pieces_follow_the_reference_lines_kinds():
    road = read_document(ROADS / "crest-curve.xodr").roads["0"]
    assert [(p.kind, p.s_start, p.s_end) for p in road_pieces(road)] == [("straight", 0.0, 100.0),
                                                                        ("clothoid", 100.0, 400.0)]


@pytest.mark.parametrize("change, element, allowed", [
    ('<spiral curvStart="0.0" curvEnd="-0.02"/>', "<cubicSpline/>", "line, arc, spiral, poly3, paramPoly3"),
    ('<lateralProfile/>', '<lateralProfile><shape s="0" t="0" a="0" b="0" c="0" d="0"/></lateralProfile>',
     "superelevation"),
    ('<width sOffset="0.0" a="3.2" b="0.0" c="0.0" d="0.0"/>', '<border sOffset="0" a="3.2" b="0" c="0" d="0"/>',
     "lanes given by <width>"),
    ('<planView>', '<planView><geometry s="0" x="0" y="0" hdg="0" length="x"><line/></geometry>', "a number"),
    ('length="400"', 'length="4e7"', "roads longer than 0 m and up to 20000 m"),
])
def test_what_is_not_read_is_refused_naming_the_file_the_element_and_what_is_supported(tmp_path, change, element,
                                                                                      allowed):
    path = tmp_path / "road.xodr"
    path.write_text((ROADS / "crest-curve.xodr").read_text().replace(change, element, 1))
    with pytest.raises(InputError) as refused:
        opendrive_network(path)
    message = refused.value.describe()
    assert str(path) in message and "line " in message and f"(allowed: {allowed})" in message
    assert "\n" not in message


@pytest.mark.parametrize("text, reason", [("<OpenDRIVE><header/></OpenDRIVE>", "no road"),
                                          ("<roads/>", "root element"), ("<OpenDRIVE>", "not readable as XML")])
def test_a_file_that_is_no_road_network_is_refused(tmp_path, text, reason):
    path = tmp_path / "bad.xodr"
    path.write_text(text)
    with pytest.raises(InputError, match=reason):
        opendrive_network(path)
