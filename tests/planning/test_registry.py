"""The planner registry: names, installed planners, references, settings — and a planner that raises."""

from __future__ import annotations

from pathlib import Path

import pytest

from simgap.cosim import CosimSettings, Outcome
from simgap.errors import InputError
from simgap.experiment.single_run import RunRequest, execute, parse_planners
from simgap.planning.frenet import FrenetPlanner, FrenetSettings
from simgap.planning.protocol import Planner
from simgap.planning.registry import PlannerChoice, load_planner, planner_names
from simgap.scenario import build_scenario, write_scenario

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "time_gap_planner" / "time_gap_planner" / "planner.py"

FLAKY = '''
from simgap.planning.frenet import FrenetPlanner, FrenetSettings


class Flaky(FrenetPlanner):
    """The Frenet planner, raising between t = 1.0 s and 1.5 s."""

    def plan(self, observed, t, world):
        if 1.0 <= t < 1.45:
            raise ValueError(f"flaky at t = {t:.1f}")
        return super().plan(observed, t, world)


class Unbuildable:
    def __init__(self, setup, settings):
        raise RuntimeError("no map for this road")

    def plan(self, observed, t, world):
        return None


class NoPlan:
    def __init__(self, setup, settings):
        pass


class OneArgument:
    def __init__(self, setup):
        self.setup = setup

    def plan(self, observed, t, world):
        return None


class ThreeArguments:
    def __init__(self, setup, settings, extra):
        pass

    def plan(self, observed, t, world):
        return None


class SettingsNotTaken:
    Settings = FrenetSettings

    def __init__(self, setup):
        pass

    def plan(self, observed, t, world):
        return None
'''

SMALLEST = '''
import math

from simgap.trajectory import State, Trajectory


class StraightOn:
    """Drives straight on at 10 m/s: the smallest planner, no constructor and no settings."""

    def plan(self, observed, t, world):
        c, s = math.cos(observed.yaw), math.sin(observed.yaw)
        return Trajectory.from_states([State(t + k * world.dt, observed.x + 10.0 * k * world.dt * c,
                                             observed.y + 10.0 * k * world.dt * s, observed.yaw, 10.0)
                                       for k in range(31)], world.dt)
'''


@pytest.fixture(scope="module")
def curve_xml(tmp_path_factory) -> Path:
    folder = tmp_path_factory.mktemp("curve")
    return write_scenario(build_scenario("curve", {"radius": 10.0, "angle": 90.0}), folder, preview=False)


@pytest.fixture
def flaky_file(tmp_path) -> Path:
    path = tmp_path / "flaky.py"
    path.write_text(FLAKY)
    return path


def test_builtin_planner_by_name_with_its_settings_model():
    planner = load_planner("frenet")
    assert planner.cls is FrenetPlanner and planner.settings_model is FrenetSettings
    assert planner.settings({"speed": {"cruise_m_s": 8}}).speed.cruise_m_s == 8
    assert planner_names()[:3] == ["frenet", "reactive", "idm"]
    assert load_planner("reactive").settings_model.__name__ == "ReactiveSettings"
    assert load_planner("idm").settings_model.__name__ == "IdmSettings"


@pytest.mark.parametrize("ref, fragments", [
    ("nope", ["unknown planner 'nope'", "frenet", "module:Class"]),
    ("no_such_module_xyz:Planner", ["cannot import 'no_such_module_xyz'", "ModuleNotFoundError"]),
    ("simgap.planning.frenet:Nope", ["has no class 'Nope'", "FrenetPlanner"]),
    ("simgap.trajectory:State", ["is not a planner class", "plan(observed, t, world)"]),
    ("missing/planner.py:Planner", ["no such planner file 'missing/planner.py'"]),
])
def test_bad_references_are_refused_naming_what_is_allowed(ref, fragments):
    with pytest.raises(InputError) as err:
        load_planner(ref, file="spec.yaml", field="planners.1")
    message = str(err.value)
    assert message.startswith("spec.yaml: field 'planners.1'")
    for fragment in fragments:
        assert fragment in message, message


def test_classes_not_matching_the_protocol_are_refused(flaky_file):
    with pytest.raises(InputError, match="is not a planner class"):
        load_planner(f"{flaky_file}:NoPlan")
    with pytest.raises(InputError, match=r"cannot be constructed as cls\(\), cls\(setup\) or cls\(setup, settings\)"):
        load_planner(f"{flaky_file}:ThreeArguments")
    with pytest.raises(InputError, match=r"cannot be constructed as cls\(setup, settings\), as its Settings model"):
        load_planner(f"{flaky_file}:SettingsNotTaken")


def test_a_constructor_takes_what_its_signature_says(flaky_file):
    setup = object()
    built = load_planner(f"{flaky_file}:OneArgument").build(setup, None)
    assert built.planner.setup is setup, "a class with plan alone is built into the Planner contract"
    assert isinstance(built, Planner) and built.failure_reason == "" and built.report() is None
    built.close()                                   # it has no close: closing it does nothing
    assert load_planner("frenet").arguments == 2


def test_the_smallest_planner_has_no_constructor_and_reaches_its_goal(tmp_path):
    path = tmp_path / "smallest.py"
    path.write_text(SMALLEST)
    straight = write_scenario(build_scenario("curve", {"radius": 50.0, "angle": 0.0}), tmp_path, preview=False)
    planner = load_planner(f"{path}:StraightOn")
    assert planner.arguments == 0 and planner.settings_model is None
    run = execute(RunRequest(scenario=straight, planner=PlannerChoice(planner=f"{path}:StraightOn")))
    assert [a.history.outcome for a in run.agents] == [Outcome.GOAL_REACHED]


def test_a_bad_setting_names_the_file_the_field_and_what_is_allowed(tmp_path):
    config = tmp_path / "planner.yaml"
    config.write_text("time_gap_s: -1\n")
    with pytest.raises(InputError) as err:
        parse_planners(f"{EXAMPLE}:TimeGapPlanner", config)
    assert "planner.yaml: field 'time_gap_s'" in str(err.value) and "greater than 0" in str(err.value)
    config.write_text("speed: {cruse_m_s: 8}\n")
    with pytest.raises(InputError) as err:
        parse_planners("frenet", config)
    assert "field 'speed.cruse_m_s'" in str(err.value) and "cruise_m_s" in str(err.value)


def test_planners_per_agent_and_their_settings_file(tmp_path):
    config = tmp_path / "planners.yaml"
    config.write_text(f"frenet: {{speed: {{cruise_m_s: 7}}}}\n'{EXAMPLE}:TimeGapPlanner': {{time_gap_s: 2.0}}\n")
    planners = parse_planners(f"1=frenet,2={EXAMPLE}:TimeGapPlanner", config)
    assert planners[1] == PlannerChoice(planner="frenet", settings={"speed": {"cruise_m_s": 7}})
    assert planners[2].name == "TimeGapPlanner" and planners[2].settings == {"time_gap_s": 2.0}
    config.write_text("idm: {}\n")
    with pytest.raises(InputError, match="'idm' is not one of them"):
        parse_planners(f"1=frenet,2={EXAMPLE}:TimeGapPlanner", config)


def test_isolate_is_refused_where_no_planner_is_a_class():
    for ref in ("tcp://127.0.0.1:5555", "ipc:///tmp/planner.sock", "exec:python -m my_planner"):
        with pytest.raises(InputError, match="runs in a process of its own already") as refused:
            parse_planners(ref, isolate=True)
        assert refused.value.field == "isolate"
    mixed = parse_planners("1=frenet,2=tcp://127.0.0.1:5555", isolate=True)    # the class in its own process
    assert mixed[1].isolate and not mixed[2].isolate


def test_a_planner_that_raises_fails_its_cycles_and_the_run_goes_on(curve_xml, flaky_file, tmp_path):
    request = RunRequest(scenario=curve_xml, planner=PlannerChoice(planner=f"{flaky_file}:Flaky"),
                         cosim=CosimSettings(planning_budget_s=10.0))
    execute(request, tmp_path / "run")
    from simgap.record import read_run

    run = read_run(tmp_path / "run")          # as recorded
    agent = run.agents[0]
    assert agent.history.outcome == Outcome.GOAL_REACHED          # the loop's fallback, then the planner again
    assert agent.history.planner_exceptions == 5 and agent.history.planner_failures == 5
    errors = run.history.planner_errors
    assert errors[0].exception == "ValueError" and errors[0].t == pytest.approx(1.0)
    assert "in plan" in errors[0].traceback and "flaky at t = 1.0" in errors[0].traceback
    # (the mean is no invariant below the p95: with cycles of ~2 ms, one slow first call lifts it above)
    assert agent.evaluation.planning_calls > 100 and 0 < agent.evaluation.planning_p95_s <= agent.evaluation.planning_max_s
    assert 0 < agent.evaluation.planning_mean_s <= agent.evaluation.planning_max_s
    assert agent.evaluation.planning_over_budget == 0
    assert run.settings.planner.name == "Flaky"
    assert run.settings.planner.settings["speed"]["cruise_m_s"] == 10.0      # the full settings


def test_a_planner_raising_in_its_constructor_is_a_recorded_failed_run(curve_xml, flaky_file, tmp_path):
    run = execute(RunRequest(scenario=curve_xml, planner=PlannerChoice(planner=f"{flaky_file}:Unbuildable")),
                  tmp_path / "run")
    assert run.failure and "RuntimeError in its constructor: no map for this road" in run.failure
    assert run.agents[0].history.outcome == Outcome.PLANNER_FAILURE
    assert "raise RuntimeError" in run.history.planner_errors[0].traceback and run.history.planner_errors[0].t is None
    assert (tmp_path / "run" / "run.json").exists()


def test_calls_over_the_planning_budget_are_counted(curve_xml):
    run = execute(RunRequest(scenario=curve_xml, cosim=CosimSettings(planning_budget_s=1e-6, max_time_s=2.0)))
    agent = run.agents[0]
    assert agent.evaluation.planning_over_budget == agent.evaluation.planning_calls == 20


def test_a_planner_per_agent(tmp_path):
    """The planner under test among traffic driven by another planner: each agent is built by its own."""
    xml = write_scenario(build_scenario("t-junction", {}), tmp_path, preview=False)
    gap = PlannerChoice(planner=f"{EXAMPLE}:TimeGapPlanner", settings={"time_gap_s": 2.0})
    run = execute(RunRequest(scenario=xml, planner={1: PlannerChoice(), 2: gap, 3: gap},
                             cosim=CosimSettings(max_time_s=2.0)))
    assert [a.planner for a in run.agents] == ["frenet", "TimeGapPlanner", "TimeGapPlanner"]
    assert run.settings.planner.name == "1=frenet,2=TimeGapPlanner,3=TimeGapPlanner"
    assert run.settings.planner.agents[2].settings["time_gap_s"] == 2.0
    assert all(a.evaluation.planning_calls == 20 for a in run.agents)
    with pytest.raises(InputError, match="no planner given for planning problem 3"):
        execute(RunRequest(scenario=xml, planner={1: PlannerChoice(), 2: gap}))


def test_a_planner_file_that_exits_while_imported_is_refused(tmp_path):
    exits = tmp_path / "exits.py"
    exits.write_text("import sys\nsys.exit(4)\n\nclass Planner:\n    def plan(self, observed, t, world):\n        return None\n")
    with pytest.raises(InputError) as err:
        load_planner(f"{exits}:Planner", file="spec.yaml", field="planners.1")
    assert "cannot import" in str(err.value) and "SystemExit: 4" in str(err.value)
