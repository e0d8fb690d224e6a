"""A run as a rerun recording: the file reads back with rerun's own reader, holding the road, every
car posed at each of its driven states (with the record's height, pitch and roll in a 3D world),
each plan at its time, what the planners observed, the ideal twin, traffic and events; bad input
is refused in one line before anything is written."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest
from commonroad.planning.planning_problem import PlanningProblem, PlanningProblemSet
from real_like import box_goal, highway, recorded_car, start
from rerun.chunk import RrdReader

from simgap.cli.main import main
from simgap.cosim.loop import CosimSettings
from simgap.experiment.single_run import RunRequest, execute
from simgap.export.rerun_recording import SIM_TIME, _quaternions, export_recording
from simgap.record import read_run
from simgap.scenario import build_scenario, write_scenario
from simgap.scenario.files import write_xml


def run_of(scenario_xml: Path, out: Path, backend: str = "ideal", seconds: float = 2.0) -> Path:
    execute(RunRequest(scenario=scenario_xml, backend=backend, cosim=CosimSettings(max_time_s=seconds),
                       criticality=False), out)
    return out


def chunks(rrd: Path) -> dict[str, dict[str, list]]:
    """Per entity path, its columns (static and on ``sim_time`` alike), read with rerun's reader."""
    out: dict[str, dict[str, list]] = {}
    for chunk in RrdReader(rrd).stream():
        columns = out.setdefault(chunk.entity_path.lstrip("/"), {})
        assert chunk.is_static or chunk.timeline_names == [SIM_TIME]
        for name, values in chunk.to_record_batch().to_pydict().items():
            columns.setdefault(name, []).extend(values)
    return out


@pytest.fixture(scope="module")
def curve_runs(tmp_path_factory) -> tuple[Path, Path]:
    """The first 2 s of a curve in MuJoCo (3D) and in the ideal world (its twin)."""
    tmp = tmp_path_factory.mktemp("curve")
    xml = write_scenario(build_scenario("curve", {"radius": 20, "angle": 30}), tmp, preview=False)
    return run_of(xml, tmp / "mujoco", "mujoco"), run_of(xml, tmp / "ideal")


def test_a_3d_run_reads_back_pose_for_pose(tmp_path, curve_runs):
    mujoco, ideal = curve_runs
    export = export_recording(mujoco, tmp_path / "c.rrd", ideal_dir=ideal)
    assert export.path == tmp_path / "c.rrd" and list(tmp_path.iterdir()) == [export.path]   # no temporary left
    got = chunks(export.path)
    run, twin = read_run(mujoco), read_run(ideal)
    agent = run.history.agents[0]
    quantities = ["acceleration", "pitch", "roll", "speed", "steering", "yaw_rate"]
    assert sorted(set(got) - {"__properties"}) == export.entities == sorted(
        ["world", "world/road/bounds", "world/road/centre_lines", "world/agent_1/car", "world/agent_1/driven",
         "world/agent_1/plan", "world/agent_1/observed", "world/ideal/agent_1/car", "world/ideal/agent_1/driven"]
        + [f"plots/agent_1/{q}/driven" for q in quantities]
        + [f"plots/agent_1/{q}/ideal" for q in quantities if q not in ("pitch", "roll")]
        + (["events", "world/events"] if run.history.events else []))
    car = got["world/agent_1/car"]
    assert len(car["Transform3D:translation"]) == len(agent.driven) == export.driven_poses["world/agent_1/car"]
    assert len(car["Boxes3D:half_sizes"]) == 1                                     # the box itself: static
    xyz = np.array([p[0] for p in car["Transform3D:translation"]])
    assert np.allclose(xyz, np.column_stack([agent.driven.x, agent.driven.y, [a.z for a in agent.attitudes]]),
                       atol=1e-4)
    assert [t.total_seconds() for t in car[SIM_TIME]] == pytest.approx(list(agent.driven.t), abs=1e-9)
    assert len(got["world/ideal/agent_1/car"]["Transform3D:translation"]) == len(twin.history.agents[0].driven)
    plans = got["world/agent_1/plan"]
    assert [t.total_seconds() for t in plans[SIM_TIME]] == pytest.approx([float(p.t[0]) for p in agent.plans])
    assert [len(s[0]) for s in plans["LineStrips3D:strips"]] == [len(p) for p in agent.plans]
    assert len(got["world/agent_1/observed"]["Points3D:positions"]) == len(agent.observed)
    speed = [v[0] for v in got["plots/agent_1/speed/driven"]["Scalars:scalars"]]
    assert speed == pytest.approx(list(agent.driven.v))
    bounds, centres = (len(got[f"world/road/{k}"]["LineStrips3D:strips"][0]) for k in ("bounds", "centre_lines"))
    assert centres > 0 and bounds == 2 * centres                                    # each lanelet's two bounds


def test_traffic_and_events_read_back(tmp_path):
    scenario = highway(lanes=2, length=200.0)
    scenario.add_objects(recorded_car(201, 40.0, 1, 10.0, 30))
    problems = PlanningProblemSet([PlanningProblem(1, start(5.0, 0, 10.0), box_goal(25.0, 0, (0, 100)))])
    xml = tmp_path / "highway.xml"
    write_xml(scenario, problems, xml)
    run = read_run(run_of(xml, tmp_path / "run", seconds=4.0))
    assert run.history.events, "the run should end at its goal"
    export = export_recording(tmp_path / "run", tmp_path / "out")
    assert export.path == tmp_path / "out" / "highway_ideal.rrd"
    got = chunks(export.path)
    assert len(got["world/obstacle_201/car"]["Transform3D:translation"]) == 31      # its recording: 30 steps after 0
    assert got["events"]["TextLog:text"] == [[f"agent {e.agent_id}: {e.kind.value}"] for e in run.history.events]
    goal = next(e for e in run.history.events if e.kind.value == "goal_reached")
    assert got["world/events"]["Points3D:positions"][0][0][:2] == pytest.approx([goal.x, goal.y], abs=1e-3)


def test_pose_quaternions_turn_the_car_as_the_record_says():
    def turn(q, v):
        x, y, z, w = q
        u = np.array([x, y, z])
        return v + 2 * np.cross(u, np.cross(u, v) + w * v)

    yaw, pitch, roll = np.array([0.5, 0.0, 0.0]), np.array([0.0, 0.1, 0.0]), np.array([0.0, 0.0, 0.1])
    q = _quaternions(yaw, pitch, roll)
    assert np.allclose(np.linalg.norm(q, axis=1), 1.0)
    assert turn(q[0], np.array([1.0, 0, 0])) == pytest.approx([np.cos(0.5), np.sin(0.5), 0])
    assert turn(q[1], np.array([1.0, 0, 0]))[2] == pytest.approx(np.sin(0.1))      # nose up
    assert turn(q[2], np.array([0, -1.0, 0]))[2] == pytest.approx(-np.sin(0.1))    # right side down


@pytest.mark.parametrize("args, fragments", [
    (["RUN", "--out", "OUT/x.rrd", "--format", "openscenario"], ["field '--out'", "--format rerun"]),
    (["RUN", "--out", "OUT", "--ideal", "RUN"], ["field '--ideal'", "allowed: --format rerun"]),
    (["SCENARIO", "--out", "OUT/x.rrd"], ["a rerun recording is of one run"]),
    (["RUN", "--out", "OUT/x.rrd", "--ideal", "OUT/nowhere"], ["field '--ideal'", "no such file"]),
    (["RUN", "--out", "OUT/x.rrd", "--ideal", "OTHER"], ["field '--ideal'", "a run of the same scenario"]),
])
def test_bad_input_is_one_line_exit_2_and_writes_nothing(tmp_path, curve_runs, args, fragments, monkeypatch, capsys):
    mujoco, _ = curve_runs
    other = tmp_path / "other"
    if "OTHER" in args:
        scenario = highway(lanes=1, length=100.0)
        xml = tmp_path / "straight.xml"
        write_xml(scenario, PlanningProblemSet([PlanningProblem(1, start(5.0, 0, 5.0), box_goal(50.0, 0, (0, 50)))]),
                  xml)
        run_of(xml, other, seconds=0.5)
    out = tmp_path / "out"
    names = {"RUN": str(mujoco), "SCENARIO": str(next(mujoco.parent.glob("*.xml"))), "OTHER": str(other)}
    args = [names.get(a, a.replace("OUT", str(out))) for a in args]
    monkeypatch.setattr(sys, "argv", ["simgap", "export", *args])
    capsys.readouterr()
    with pytest.raises(SystemExit) as exit:                  # the command line's own handling, in this process
        main()
    stderr = capsys.readouterr().err
    assert exit.value.code == 2 and len(stderr.strip().splitlines()) == 1
    for fragment in fragments:
        assert fragment in stderr, stderr
    assert not out.exists() or not any(out.iterdir())
