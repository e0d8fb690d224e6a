"""Issue 41's study on 3D roads: a crest's MuJoCo run climbs and falls with the road while its
ideal twin stays flat and plans the same; the peak grip use on the relief is a run metric; the
built-in search `road-3d-gaps` loads; a tilt (``road_bank``, ``road_grade``) on a recorded map,
which has no reference line to lay it along, is refused before the run writes anything."""

from __future__ import annotations

import numpy as np
import pytest
from commonroad.planning.planning_problem import PlanningProblem, PlanningProblemSet
from cosim.real_like import box_goal, highway, start

from simgap.errors import InputError
from simgap.experiment.search.spec import load_search_spec
from simgap.experiment.single_run import RunRequest, execute
from simgap.scenario import build_scenario, read_sidecar, write_scenario
from simgap.scenario.files import write_xml
from simgap.scenario.ground import ground_of


@pytest.fixture(scope="module")
def crest(tmp_path_factory):
    out = tmp_path_factory.mktemp("crest")
    xml = write_scenario(build_scenario("crest-curve", {"radius": 50, "vertical_radius": 75}), out, preview=False)
    return xml, execute(RunRequest(scenario=xml, backend="ideal")), execute(RunRequest(scenario=xml, backend="mujoco"))


def test_mujoco_drives_over_the_crest_while_the_ideal_world_stays_flat(crest):
    xml, ideal, mujoco = crest
    assert ideal.agents[0].history.outcome == "goal_reached" and mujoco.agents[0].history.outcome == "goal_reached"
    assert not ideal.agents[0].history.attitudes                     # the planner's flat world has no height
    z = np.array([a.z for a in mujoco.agents[0].history.attitudes])
    pitch = np.array([a.pitch for a in mujoco.agents[0].history.attitudes])
    top = int(np.argmax(z))
    assert z[top] - z[0] > 5.0 and z[top] - z[-1] > 5.0     # up 8 %, over the crest, down 8 %
    assert 0 < top < len(z) - 1
    # the surface's height under the car where it is, and nose up before the top, nose down after
    relief = ground_of(read_sidecar(xml))
    driven = mujoco.history.driven[1]
    ground = relief.surface(driven.x, driven.y).z
    assert np.max(np.abs(z - ground)) < 1.0
    assert np.median(pitch[:top]) > 0.03 and np.median(pitch[top:]) < -0.03


def test_the_flat_plan_asks_more_grip_of_the_crest_than_of_a_plane(crest):
    _, ideal, mujoco = crest
    assert ideal.evaluation.metrics["peak_grip_use_3d"] != ideal.evaluation.metrics["peak_grip_use"]
    for run in (ideal, mujoco):
        assert np.isfinite(run.evaluation.metrics["peak_grip_use_3d"]) and run.evaluation.metrics["peak_grip_use_3d"] > 0


def test_the_road_3d_search_spec_loads():
    search = load_search_spec("road-3d-gaps")
    assert search.spec.logical == "curve-3d"
    assert set(search.spec.parameters) == {"radius", "grade", "bank", "initial_speed"}
    assert [r.backend for r in search.spec.ladder] == ["ideal", "mujoco"]


def test_a_tilt_on_a_recorded_map_is_refused_before_the_run_writes_anything(tmp_path):
    problems = PlanningProblemSet([PlanningProblem(1, start(10, 0, 10.0), box_goal(150, 0, (0, 150)))])
    xml = tmp_path / "recorded.xml"
    write_xml(highway(lanes=1, length=200, segments=1), problems, xml)
    with pytest.raises(InputError, match="a uniform grade of 3 deg is laid along a road's reference line") as refused:
        execute(RunRequest(scenario=xml, backend="mujoco", backend_settings={"road_grade": 3.0}), tmp_path / "run")
    assert (refused.value.file, refused.value.field) == (str(xml), "road_grade")
    assert not (tmp_path / "run").exists()
