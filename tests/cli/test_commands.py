"""The `simgap` command as a user runs it: real processes, real exit codes, no tracebacks."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
import simgap_command

from simgap.record import read_run

SIMGAP = [sys.executable, "-m", "simgap"]


def simgap(*args: str, cwd: Path | None = None) -> subprocess.CompletedProcess:
    return simgap_command.simgap(*args, cwd=cwd, env=dict(os.environ, COLUMNS="120"))


def assert_clean_error(proc: subprocess.CompletedProcess, *fragments: str) -> None:
    assert proc.returncode != 0
    assert "Traceback" not in proc.stderr + proc.stdout
    for fragment in fragments:
        assert fragment in proc.stderr, proc.stderr


def test_generate_with_pins_writes_exactly_one_scenario(tmp_path):
    proc = simgap("generate", "curve", "--set", "radius=10", "--set", "angle=90", "--out", str(tmp_path))
    assert proc.returncode == 0, proc.stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == [".simgap-generate.json",     # what simgap generate wrote there
        "curve_radius-10_angle-90.json", "curve_radius-10_angle-90.png", "curve_radius-10_angle-90.xml"]


def test_generate_list_shows_parameters_units_and_ranges():
    proc = simgap("generate", "--list")
    assert proc.returncode == 0, proc.stderr
    for text in ("curve", "s-curve", "t-junction", "intersection", "radius", "deg", "5 … 1000", "78 scenarios"):
        assert text in proc.stdout


@pytest.mark.parametrize("args, fragments", [
    (["generate", "curve", "--set", "radius=2", "--out", "x"], ["field 'radius'", "5 to 1000 m"]),
    (["generate", "curve", "--set", "bend=3", "--out", "x"], ["unknown parameter 'bend'", "radius, angle"]),
    (["generate", "nowhere", "--out", "x"], ["no built-in logical scenario", "curve"]),
    (["generate", "curve", "--set", "radius=6", "--set", "lanes=2", "--out", "x"], ["too small", "> 7 m"]),
])
def test_generate_refuses_bad_input_clearly(tmp_path, args, fragments):
    assert_clean_error(simgap(*args, cwd=tmp_path), *fragments)
    assert not (tmp_path / "x").exists() or not any((tmp_path / "x").glob("*.xml"))


def test_run_refuses_unreadable_and_problemless_scenarios(tmp_path):
    bad = tmp_path / "bad.xml"
    bad.write_text("<commonRoad><oops")
    assert_clean_error(simgap("run", str(bad), "--out", str(tmp_path / "r1")), "bad.xml", "not a readable")
    assert_clean_error(simgap("run", str(tmp_path / "missing.xml"), "--out", str(tmp_path / "r2")), "no such")
    assert not (tmp_path / "r1").exists() and not (tmp_path / "r2").exists()


def test_run_json_render_and_identical_fingerprints(tmp_path):
    assert simgap("generate", "curve", "--set", "radius=20", "--set", "angle=60", "--no-preview",
                  "--out", str(tmp_path)).returncode == 0
    xml = tmp_path / "curve_radius-20_angle-60.xml"
    first = simgap("run", str(xml), "--no-validate", "--backend", "ideal", "--out", str(tmp_path / "run1"), "--json")
    assert first.returncode == 0, first.stderr
    summary = json.loads(first.stdout)
    assert summary["wall_time_s"] > 0
    (agent,) = summary["agents"]
    assert agent["id"] == 1 and agent["outcome"] == "goal_reached" and agent["time_to_goal_s"] > 5
    # the goal is 10 m x 3 m, 10 m before the end: 90 m + a 20.9 m arc + 85 m from the start
    assert 190 < agent["distance_m"] < 202
    second = json.loads(simgap("run", str(xml), "--no-validate", "--out", str(tmp_path / "run2"), "--json").stdout)
    assert second["fingerprint"] == summary["fingerprint"]
    for name in ("run.json", "trajectories.parquet", "driven.xml"):
        assert (tmp_path / "run1" / name).exists()
    rendered = simgap("render", str(tmp_path / "run1"), "--frame-every", "10")
    assert rendered.returncode == 0, rendered.stderr
    assert (tmp_path / "run1" / "scene.png").stat().st_size > 10_000
    assert (tmp_path / "run1" / "run.gif").stat().st_size > 10_000


def test_compare_two_fidelities_as_json_and_plots(tmp_path):
    assert simgap("generate", "curve", "--set", "radius=10", "--set", "angle=-90", "--no-preview",
                  "--out", str(tmp_path)).returncode == 0
    xml = tmp_path / "curve_radius-10_angle-m90.xml"
    for backend in ("ideal", "dynamic"):
        proc = simgap("run", str(xml), "--no-validate", "--backend", backend, "--replan-every", "3", "--out", str(tmp_path / backend))
        assert proc.returncode == 0, proc.stderr
    proc = simgap("compare", str(tmp_path / "ideal"), str(tmp_path / "dynamic"), "--json", "--out", str(tmp_path / "cmp"))
    assert proc.returncode == 0, proc.stderr
    (agent,) = json.loads(proc.stdout)["agents"]
    d = agent["lateral_displacement"]
    assert set(d) == {"max", "rms", "mean", "p95"}
    assert 0 < d["rms"] <= d["max"] < 0.5
    assert {"straight", "curve"} <= set(agent["lateral_displacement_by_section"])
    assert (tmp_path / "cmp" / "d_over_s_agent1.png").stat().st_size > 10_000
    (scores,) = json.loads(proc.stdout)["scores"]
    assert scores["score_drop"] == pytest.approx(scores["a"]["score"] - scores["b"]["score"])
    assert len(scores["components"]) == 8 and scores["a"]["solution_cost"] > 0 and scores["b"]["solution_cost"] > 0
    regained = [c["regained"] for c in scores["components"]]
    assert regained == sorted(regained, reverse=True)          # the component that lost most first
    # each run's events, with their time and place (in the scenario and along the route)
    events = json.loads(proc.stdout)["events"]
    for side in ("a", "b"):
        (goal,) = [e for e in events[side] if e["kind"] == "goal_reached"]
        assert goal["agent_id"] == 1 and goal["t"] > 5 and abs(goal["d"]) < 0.5 and goal["s"] > 150
    printed = simgap("compare", str(tmp_path / "ideal"), str(tmp_path / "dynamic"))
    assert printed.returncode == 0 and "events" in printed.stdout and printed.stdout.count("goal_reached") == 2


def test_run_mujoco_json_scores_every_agent_and_writes_a_solution_file(tmp_path):
    from commonroad.common.solution import CommonRoadSolutionReader

    simgap("generate", "curve", "--set", "radius=20", "--set", "angle=60", "--no-preview", "--out", str(tmp_path))
    xml = tmp_path / "curve_radius-20_angle-60.xml"
    proc = simgap("run", str(xml), "--backend", "mujoco", "--json", "--out", str(tmp_path / "m"))
    assert proc.returncode == 0, proc.stderr
    summary = json.loads(proc.stdout)
    for agent in summary["agents"]:
        assert 0.0 <= agent["score"] <= 1.0 and len(agent["score_components"]) == 8
        assert isinstance(agent["solution_valid"], bool) and agent["solution_cost"] > 0
        assert agent["solution_benchmark"].startswith("KS2:SM1:")
    assert {"scoring", "validation"} <= set(summary["timings"])
    solution = CommonRoadSolutionReader.open(str(tmp_path / "m" / "solution.xml"))
    assert [p.planning_problem_id for p in solution.planning_problem_solutions] == [a["id"] for a in summary["agents"]]
    quick = json.loads(simgap("run", str(xml), "--no-validate", "--cost-function", "MW1", "--json", "--out",
                              str(tmp_path / "q")).stdout)
    assert quick["agents"][0]["solution_valid"] is None and "validation" not in quick["timings"]
    assert quick["agents"][0]["solution_benchmark"].startswith("KS2:MW1:")


def test_a_bad_score_setting_names_the_file_and_the_field(tmp_path):
    simgap("generate", "curve", "--set", "radius=20", "--set", "angle=60", "--no-preview", "--out", str(tmp_path))
    config = tmp_path / "score.yaml"
    config.write_text("comfort: {max_abs_yaw_rate: -1}\n")
    assert_clean_error(simgap("run", str(tmp_path / "curve_radius-20_angle-60.xml"), "--score-config", str(config),
                              "--out", str(tmp_path / "r")), "score.yaml", "comfort.max_abs_yaw_rate")
    assert_clean_error(simgap("run", str(tmp_path / "curve_radius-20_angle-60.xml"), "--cost-function", "XX9",
                              "--out", str(tmp_path / "r")), "XX9", "SM1")
    assert not (tmp_path / "r").exists()


@pytest.fixture(scope="module")
def two_curves(tmp_path_factory) -> Path:
    """Runs of two scenarios, in ``30/`` and ``60/`` beside their scenario files."""
    folder = tmp_path_factory.mktemp("two-curves")
    for angle in ("30", "60"):
        simgap("generate", "curve", "--set", "radius=50", "--set", f"angle={angle}", "--no-preview", "--out", str(folder))
        simgap("run", str(folder / f"curve_radius-50_angle-{angle}.xml"), "--no-validate", "--replan-every", "3",
               "--out", str(folder / angle))
    return folder


def test_compare_refuses_runs_of_different_scenarios(two_curves):
    assert_clean_error(simgap("compare", str(two_curves / "30"), str(two_curves / "60")), "different scenarios")


def test_outputs_a_command_did_not_write_are_refused_unless_overwritten(two_curves, tmp_path):
    from simgap.cli.outputs import check_run_out
    from simgap.errors import InputError
    from simgap.experiment.single_run import RunRequest

    out = tmp_path / "x"
    shutil.copytree(two_curves / "30", out)
    other = str(two_curves / "curve_radius-50_angle-60.xml")
    proc = simgap("run", other, "--no-validate", "--replan-every", "3", "--out", str(out))
    assert proc.returncode == 2 and len(proc.stderr.strip().splitlines()) == 1
    assert_clean_error(proc, f"{out}: holds a run of curve_radius-50_angle-30 (backend ideal, vehicle sedan, "
                             "planner frenet); not replaced", "--overwrite")
    assert read_run(out).scenario_id == "curve_radius-50_angle-30"         # the first run is kept
    same = RunRequest(scenario=two_curves / "curve_radius-50_angle-30.xml")
    check_run_out(out, same, overwrite=False)                               # the very same run may replace it
    for changed in ({"backend": "dynamic"}, {"vehicles": "suv"}, {"vehicles": {1: "city"}}):
        with pytest.raises(InputError, match="holds a run of"):
            check_run_out(out, RunRequest(scenario=same.scenario, **changed), overwrite=False)
    assert simgap("run", other, "--no-validate", "--replan-every", "3", "--out", str(out), "--overwrite").returncode == 0
    assert read_run(out).scenario_id == "curve_radius-50_angle-60"

    notes = tmp_path / "notes"
    notes.mkdir()
    (notes / "todo.txt").write_text("mine")
    assert_clean_error(simgap("run", other, "--out", str(notes)), "holds todo.txt, not a simgap run")
    (notes / "scene.png").write_bytes(b"mine")
    assert_clean_error(simgap("render", str(out), "--out", str(notes)), "scene.png, which simgap render did not write")
    (notes / "index.html").write_text("<html>mine</html>")
    assert_clean_error(simgap("report", str(two_curves), "--out", str(notes)), "index.html, which simgap report did not write")
    assert (notes / "index.html").read_text() == "<html>mine</html>" and (notes / "scene.png").read_bytes() == b"mine"


def test_unknown_or_missing_backend_and_vehicle_are_refused(tmp_path):
    simgap("generate", "t-junction", "--no-preview", "--out", str(tmp_path))
    xml = str(tmp_path / "t-junction.xml")
    assert_clean_error(simgap("run", xml, "--backend", "nope", "--out", str(tmp_path / "r")), "field 'backend'", "ideal")
    assert_clean_error(simgap("run", xml, "--vehicle", "1=sedan", "--out", str(tmp_path / "r")),
                       "no vehicle given for planning problem 2")
    assert_clean_error(simgap("run", xml, "--vehicle", "tank", "--out", str(tmp_path / "r")), "unknown vehicle 'tank'")
    assert_clean_error(simgap("run", xml, "--vehicle", "0=suv,1=sedan,2=sedan", "--out", str(tmp_path / "r")),
                       "field 'vehicle': agent 0 is not in the scenario", "planning problem ids 1, 2")
    assert_clean_error(simgap("run", xml, "--planner", "1=frenet,1=idm,2=idm", "--out", str(tmp_path / "r")),
                       "field 'planner': agent 1 is given a planner twice")
    assert not (tmp_path / "r").exists()


def test_physics_options_are_refused_where_they_do_not_apply(tmp_path):
    simgap("generate", "curve", "--set", "radius=10", "--set", "angle=90", "--no-preview", "--out", str(tmp_path))
    xml = str(tmp_path / "curve_radius-10_angle-90.xml")
    assert_clean_error(simgap("run", xml, "--road-friction", "0.5", "--out", str(tmp_path / "r")),
                       "--road-friction applies to physics backends only")
    assert_clean_error(simgap("run", xml, "--backend", "mujoco", "--physics-hz", "250", "--out", str(tmp_path / "r")),
                       "backend_settings.physics_hz", "whole multiple")
    assert_clean_error(simgap("run", xml, "--backend", "mujoco", "--road-friction", "3", "--out", str(tmp_path / "r")),
                       "backend_settings.road_friction")
    assert not (tmp_path / "r").exists()


def test_a_tilt_on_a_recorded_map_is_refused_in_one_line_before_anything_is_written(tmp_path):
    from commonroad.planning.planning_problem import PlanningProblem, PlanningProblemSet
    from cosim.real_like import box_goal, highway, start

    from simgap.scenario.files import write_xml

    xml = tmp_path / "recorded.xml"
    write_xml(highway(lanes=1, length=200, segments=1),
              PlanningProblemSet([PlanningProblem(1, start(10, 0, 10.0), box_goal(150, 0, (0, 150)))]), xml)
    proc = simgap("run", str(xml), "--backend", "mujoco", "--knob", "road_bank=4", "--out", str(tmp_path / "r"))
    assert proc.returncode == 2
    assert_clean_error(proc, f"{xml}: field 'road_bank': a uniform bank of 4 deg is laid along a road's reference line",
                       "a generated road")
    assert not (tmp_path / "r").exists()


def test_reality_knobs_on_the_command_line(tmp_path):
    simgap("generate", "curve", "--set", "radius=10", "--set", "angle=90", "--no-preview", "--out", str(tmp_path))
    xml = str(tmp_path / "curve_radius-10_angle-90.xml")
    assert_clean_error(simgap("run", xml, "--knob", "grip=0.3", "--out", str(tmp_path / "r")),
                       "unknown reality knob 'grip'", "road_friction")
    assert_clean_error(simgap("run", xml, "--backend", "dynamic", "--knob", "road_bank=3", "--out", str(tmp_path / "r")),
                       "does not apply to the dynamic backend", "mujoco")
    assert_clean_error(simgap("run", xml, "--backend", "dynamic", "--knob", "steer_delay=2", "--out", str(tmp_path / "r")),
                       "out of range", "0 to 1 s")
    assert not (tmp_path / "r").exists()
    proc = simgap("run", xml, "--no-validate", "--backend", "dynamic", "--knob", "steer_delay=0.05", "--knob",
                  "position_noise=0.05", "--json", "--out", str(tmp_path / "r"))
    assert proc.returncode == 0, proc.stderr
    saved = json.loads((tmp_path / "r" / "run.json").read_text())
    assert saved["settings"]["backend"]["steer_delay"] == 0.05
    assert saved["settings"]["cosim"]["sensing"]["position_noise_m"] == 0.05


@pytest.mark.parametrize("args, fragments", [
    (["search", "curve-gaps", "--budget", "soon", "--out", "s"], ["'soon' is not a budget", "20m"]),
    (["search", "nowhere", "--budget", "5", "--out", "s"], ["unknown search 'nowhere'", "curve-gaps"]),
    (["search-status", "s"], ["not a search directory"]),
])
def test_search_refuses_bad_input_clearly(tmp_path, args, fragments):
    assert_clean_error(simgap(*args, cwd=tmp_path), *fragments)
    assert not (tmp_path / "s" / "search.json").exists()


def test_a_bad_key_in_any_rung_of_a_search_is_refused_before_anything_runs(tmp_path):
    spec = tmp_path / "bad.yaml"
    spec.write_text("name: t\nlogical: curve\nparameters: {radius: {min: 10, max: 50}}\n"
                    "ladder: [{backend: ideal}, {backend: dynamic}, {backend: mujoco, cosim: {replan_evry: 3}}]\n")
    proc = simgap("search", str(spec), "--budget", "4", "--out", str(tmp_path / "s"))
    assert proc.returncode == 2
    assert_clean_error(proc, "bad.yaml: field 'ladder.2.cosim.replan_evry'", "replan_every")
    assert not (tmp_path / "s").exists()


def test_vehicles_lists_the_catalogue_and_shows_one():
    proc = simgap("vehicles")
    assert proc.returncode == 0, proc.stderr
    for name in ("sedan", "suv", "city", "mass [kg]", "rear", "all", "front"):
        assert name in proc.stdout
    proc = simgap("vehicles", "show", "suv")
    assert proc.returncode == 0, proc.stderr
    for text in ("physics.suspension_front.stiffness", "26000", "wheel rate [N/m]", "source:"):
        assert text in proc.stdout
    assert_clean_error(simgap("vehicles", "show", "tank"), "unknown vehicle 'tank'", "sedan")


def test_a_bad_vehicle_file_names_the_file_and_the_field(tmp_path):
    from importlib import resources

    text = (resources.files("simgap.vehicles") / "data" / "sedan.yaml").read_text()
    bad = tmp_path / "wobbly.yaml"
    bad.write_text(text.replace("driven_axles: rear", "driven_axles: middle"))
    proc = simgap("vehicles", "show", str(bad))
    assert_clean_error(proc, "wobbly.yaml", "physics.driven_axles", "front", "rear", "all")


def test_report_refuses_a_directory_without_runs(tmp_path):
    (tmp_path / "empty").mkdir()
    assert_clean_error(simgap("report", str(tmp_path / "empty"), "--out", str(tmp_path / "r")),
                       "no run directories")
    assert_clean_error(simgap("report", str(tmp_path / "missing"), "--out", str(tmp_path / "r")), "no such directory")
    assert not (tmp_path / "r" / "index.html").exists()


def test_experiment_commands_refuse_bad_input_clearly(tmp_path):
    assert_clean_error(simgap("experiment", "run", "nope", "--out", str(tmp_path / "x")),
                       "unknown experiment 'nope'", "paper-curves")
    bad = tmp_path / "bad.yaml"
    bad.write_text("name: b\nlogical: curve\nfidelities: [{backend: ideal}]\nsampler: {kind: lhs}\n")
    assert_clean_error(simgap("experiment", "run", str(bad), "--out", str(tmp_path / "x")),
                       "bad.yaml", "field 'sampler'", "needs 'samples'")
    assert_clean_error(simgap("experiment", "status", str(tmp_path)), "not an experiment directory")
    assert_clean_error(simgap("experiment", "run", "demo", "--out", str(tmp_path / "x"), "--address", "a:1"),
                       "--address is for the ray executor")
    assert not (tmp_path / "x" / "store").exists()


HOSTILE_PLANNERS = '''
import sys
import time


class Exits:
    def plan(self, observed, t, world):
        sys.exit(3)


class ExitsWhenBuilt:
    def __init__(self):
        sys.exit(3)

    def plan(self, observed, t, world):
        return None


class NeverReturns:
    def plan(self, observed, t, world):
        while True:
            time.sleep(0.01)
'''


@pytest.fixture(scope="module")
def hostile(tmp_path_factory) -> tuple[Path, Path]:
    """A curve scenario and a file of planners that exit or never return."""
    from simgap.scenario import build_scenario, write_scenario

    folder = tmp_path_factory.mktemp("hostile")
    (folder / "hostile.py").write_text(HOSTILE_PLANNERS)
    return write_scenario(build_scenario("curve", {"radius": 20.0, "angle": 60.0}), folder, preview=False), \
        folder / "hostile.py"


def test_a_planner_that_calls_sys_exit_fails_its_run_not_the_command(hostile, tmp_path):
    scenario, planners = hostile
    proc = simgap("run", str(scenario), "--no-validate", "--planner", f"{planners}:Exits", "--out", str(tmp_path / "a"))
    assert proc.returncode == 0, proc.stderr
    assert "planner raised SystemExit" in proc.stdout and "Traceback" not in proc.stdout + proc.stderr
    agent = read_run(tmp_path / "a").agents[0]
    assert agent.history.outcome == "planner_failure" and agent.history.planner_exceptions == 10
    built = simgap("run", str(scenario), "--no-validate", "--planner", f"{planners}:ExitsWhenBuilt",
                   "--out", str(tmp_path / "b"))
    assert built.returncode == 1, built.stderr
    assert read_run(tmp_path / "b").failure == "the planner of agent 1 raised SystemExit in its constructor: 3"


def test_a_planner_that_never_returns_ends_the_run_at_its_timeout(hostile, tmp_path):
    scenario, planners = hostile
    proc = simgap("run", str(scenario), "--no-validate", "--planner", f"{planners}:NeverReturns", "--run-timeout", "1",
                  "--out", str(tmp_path / "r"))
    assert proc.returncode == 1, proc.stderr
    record = read_run(tmp_path / "r")
    assert record.failure == "timeout: still running after 1 s of wall time in agent 1's planning call at t = 0.0 s"
    assert record.agents[0].history.outcome == "timeout"


@pytest.mark.parametrize("args, fragments", [
    (["--max-time", "inf"], ["field 'max_time_s'", "finite"]),
    (["--max-time", "1e9"], ["field 'max_time_s'", "less than or equal to 600"]),
    (["--run-timeout", "inf"], ["field 'run-timeout'", "a finite number of seconds > 0"]),
])
def test_run_refuses_limits_that_never_end(hostile, tmp_path, args, fragments):
    scenario, _ = hostile
    proc = simgap("run", str(scenario), *args, "--out", str(tmp_path / "r"))
    assert proc.returncode == 2
    assert_clean_error(proc, *fragments)
    assert not (tmp_path / "r").exists()


@pytest.mark.parametrize("template, fixed, fragments", [
    ("curve", "{straight_length: 1.0e+9, radius: 50, angle: 90}",
     ["field 'straight_length, radius, angle, transition'", "2e+09 m long", "roads up to 20000 m"]),
    ("t-junction", "{approach_length: 1.0e+9}", ["field 'approach_length'", "10 to 20000 m"]),
])
def test_generate_refuses_a_road_longer_than_the_maximum(tmp_path, template, fixed, fragments):
    spec = tmp_path / "long.yaml"
    spec.write_text(f"name: long\ntemplate: {template}\nfixed: {fixed}\n"
                    "parameters:\n  lane_width: {unit: m, min: 2.5, max: 5, default: 3.0}\n")
    proc = simgap("generate", str(spec), "--no-preview", "--out", str(tmp_path / "out"))
    assert proc.returncode == 2
    assert_clean_error(proc, f"{spec}: ", *fragments)


def test_an_out_that_is_a_file_is_refused_by_every_command_before_any_work(tmp_path):
    notes = tmp_path / "notes.txt"
    notes.write_text("mine")
    for command in (["generate", "curve"], ["experiment", "run", "demo"], ["search", "curve-gaps"], ["demo"],
                    ["report", str(tmp_path)]):
        proc = simgap(*command, "--out", str(notes))
        assert proc.returncode == 2 and len(proc.stderr.strip().splitlines()) == 1, command
        assert_clean_error(proc, f"{notes}: is a file")
    assert_clean_error(simgap("generate", "curve", "--out", str(tmp_path / ("d" * 300))), "300 bytes long")
    assert notes.read_text() == "mine" and sorted(p.name for p in tmp_path.iterdir()) == ["notes.txt"]


def test_an_unknown_mujoco_gl_is_refused_in_one_line(tmp_path):
    simgap("generate", "curve", "--set", "radius=50", "--set", "angle=30", "--no-preview", "--out", str(tmp_path))
    xml = str(tmp_path / "curve_radius-50_angle-30.xml")
    run = tmp_path / "run"
    assert simgap("run", xml, "--no-validate", "--replan-every", "3", "--out", str(run)).returncode == 0
    env = dict(os.environ, MUJOCO_GL="bogus")
    for command in (["render", str(run), "--3d", "--out", str(tmp_path / "pictures")],
                    ["run", xml, "--backend", "mujoco", "--out", str(tmp_path / "3d")]):
        proc = subprocess.run(SIMGAP + command, capture_output=True, text=True, env=env, timeout=300)
        assert proc.returncode == 2 and len(proc.stderr.strip().splitlines()) == 1, command
        assert_clean_error(proc, "field 'MUJOCO_GL'", "invalid value for environment variable MUJOCO_GL: bogus")
    assert not (tmp_path / "pictures").exists() and not (tmp_path / "3d").exists()


def test_a_resumed_experiment_says_how_many_runs_failed_earlier_and_how_to_retry_them(tmp_path):
    spec = tmp_path / "spec.yaml"
    spec.write_text("name: slow\nlogical: curve\nparameters: {radius: {values: [50]}, angle: {values: [30]}}\n"
                    "fidelities: [{backend: ideal}]\nrun_timeout_s: 0.5\n")
    out = tmp_path / "out"
    first = simgap("experiment", "run", str(spec), "--out", str(out), "--no-report", "--no-validate")
    assert first.returncode == 0 and "1 ran now (1 failed)" in first.stdout
    resumed = simgap("experiment", "run", str(spec), "--out", str(out), "--no-report", "--no-validate")
    assert "0 ran now (0 failed), 1 finished earlier" in resumed.stdout
    assert (f"1 of the runs that finished earlier failed; to run them again: simgap experiment run {spec} "
            f"--out {out} --retry-failed") in " ".join(resumed.stdout.split())


def test_tables_piped_into_a_file_are_printed_whole():
    env = {k: v for k, v in os.environ.items() if k not in ("COLUMNS", "LINES")}
    proc = subprocess.run(SIMGAP + ["vehicles"], capture_output=True, text=True, env=env, timeout=300)
    assert proc.returncode == 0
    assert "understeer [deg/g]" in proc.stdout and "4.51x1.61" in proc.stdout and "…" not in proc.stdout
