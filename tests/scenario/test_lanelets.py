"""Lanelets, markings and relations of generated roads and junctions; XML round trip."""

from __future__ import annotations

import logging

import numpy as np
import pytest
from commonroad.scenario.lanelet import LineMarking
from commonroad_route_planner.route_planner import RoutePlanner

from simgap.scenario import build_scenario, load_scenario, read_sidecar, write_scenario


def by_id(network):
    return {l.lanelet_id: l for l in network.lanelets}


def test_two_lanes_per_direction_relations_and_markings():
    concrete = build_scenario("curve", {"radius": 30, "angle": 90, "lanes": 2})
    lanelets = by_id(concrete.scenario.lanelet_network)
    assert len(lanelets) == 3 * 4                       # 3 sections x 4 lanes
    for l in lanelets.values():
        for succ in l.successor:
            assert np.allclose(lanelets[succ].center_vertices[0], l.center_vertices[-1])
            assert l.lanelet_id in lanelets[succ].predecessor
        if l.adj_left is not None:
            other = lanelets[l.adj_left]
            if l.adj_left_same_direction:
                assert other.adj_right == l.lanelet_id
                assert np.allclose(other.right_vertices, l.left_vertices)
                assert l.line_marking_left_vertices == LineMarking.DASHED
            else:                                       # the opposite lane shares the centre line
                assert other.adj_left == l.lanelet_id
                assert np.allclose(other.left_vertices[::-1], l.left_vertices)
                assert l.line_marking_left_vertices == LineMarking.SOLID
        if l.adj_right is None:
            assert l.line_marking_right_vertices == LineMarking.SOLID   # outer edge
        widths = np.linalg.norm(l.left_vertices - l.right_vertices, axis=1)
        assert widths == pytest.approx(3.0, abs=1e-9)


def test_sections_are_recorded_per_lanelet():
    concrete = build_scenario("curve", {"radius": 10, "angle": 90})
    kinds = sorted(set(concrete.sections.kinds.values()))
    assert kinds == ["curve", "straight"]


@pytest.mark.parametrize("logical, agents", [("t-junction", 3), ("intersection", 4), ("intersection", 2)])
def test_every_junction_agent_has_a_route(logical, agents):
    concrete = build_scenario(logical, {"agents": agents})
    network = concrete.scenario.lanelet_network
    assert len(concrete.problems.planning_problem_dict) == agents
    for problem in concrete.problems.planning_problem_dict.values():
        routes = RoutePlanner(network, problem, logging_level=logging.ERROR).plan_routes()
        assert routes, f"no route for agent {problem.planning_problem_id}"
        assert any(concrete.sections.kind_of(i) == "junction" for i in routes[0].lanelet_ids)


def test_xml_round_trip_reloads_equal(tmp_path):
    concrete = build_scenario("intersection", {"agents": 3})
    xml = write_scenario(concrete, tmp_path, preview=True)
    assert xml.with_suffix(".png").stat().st_size > 10_000
    scenario, problems = load_scenario(xml)
    original = by_id(concrete.scenario.lanelet_network)
    reloaded = by_id(scenario.lanelet_network)
    assert original.keys() == reloaded.keys()
    for lid, l in original.items():
        r = reloaded[lid]
        for attr in ("left_vertices", "center_vertices", "right_vertices"):
            assert np.allclose(getattr(l, attr), getattr(r, attr), atol=1e-8)
        assert (l.predecessor, l.successor, l.adj_left, l.adj_right) == (r.predecessor, r.successor, r.adj_left, r.adj_right)
        assert (l.line_marking_left_vertices, l.line_marking_right_vertices) == \
               (r.line_marking_left_vertices, r.line_marking_right_vertices)
    for pid, p in concrete.problems.planning_problem_dict.items():
        q = problems.planning_problem_dict[pid]
        assert np.allclose(p.initial_state.position, q.initial_state.position, atol=1e-8)
        assert p.initial_state.velocity == q.initial_state.velocity
        assert p.goal.state_list[0].time_step == q.goal.state_list[0].time_step
        g, h = p.goal.state_list[0].position, q.goal.state_list[0].position
        assert type(g) is type(h)
        assert np.allclose(g.vertices, h.vertices, atol=1e-6)
    assert read_sidecar(xml).parameters["agents"] == 3
