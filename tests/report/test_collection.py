"""Runs gathered for a report: fidelity labels, one run per scenario and fidelity, lane departure."""

from __future__ import annotations

import re
import shutil

import pytest

from simgap.errors import InputError
from simgap.experiment.single_run import RunRequest, execute
from simgap.report.collection import collect
from simgap.scenario import build_scenario
from simgap.scenario.files import write_scenario


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    root = tmp_path_factory.mktemp("runs")
    xml = write_scenario(build_scenario("curve", {"radius": 10, "angle": 90}), root / "scenarios", preview=False)
    execute(RunRequest(scenario=xml, backend="ideal"), root / "runs" / "ideal")
    # on a slippery road the suv cannot make the sharp turn the planner assumes
    execute(RunRequest(scenario=xml, backend="mujoco", vehicles="suv",
                       backend_settings={"controller": "stanley", "road_friction": 0.3}), root / "runs" / "suv")
    return root / "runs"


def test_runs_are_labelled_compared_and_a_lane_departure_is_measured(runs):
    (group,) = collect(runs)
    assert sorted(group.runs) == ["ideal", "mujoco/suv/stanley"]
    suv = group.runs["mujoco/suv/stanley"]
    outcome = suv.run.agents[0]
    assert outcome.history.outcome == "off_road"
    # leaving the road means leaving the lane first, by at least as much
    assert outcome.evaluation.tracking.lane_excursion_m >= outcome.evaluation.max_road_excursion_m > 0.0
    assert group.runs["ideal"].run.agents[0].evaluation.tracking.lane_excursion_m == 0.0
    (comparison,) = group.comparisons["mujoco/suv/stanley"]
    assert comparison.lateral_displacement.max > 0.1       # the run ends where it left the road
    assert group.largest_gap() == (comparison.lateral_displacement.max, "mujoco/suv/stanley")


def test_runs_that_differ_in_nothing_are_refused_all_at_once(runs, tmp_path):
    shutil.copytree(runs, tmp_path / "runs")
    shutil.copytree(runs / "ideal", tmp_path / "runs" / "ideal-again")
    shutil.copytree(runs / "suv", tmp_path / "runs" / "suv-again")
    with pytest.raises(InputError, match="2 pairs of runs differ in nothing") as refused:
        collect(tmp_path / "runs")
    assert "ideal-again" in str(refused.value) and "suv-again" in str(refused.value)


def test_variants_of_one_fidelity_sit_side_by_side_labelled_by_what_differs(runs, tmp_path):
    from simgap.cosim import CosimSettings
    from simgap.report.site import build_report

    shutil.copytree(runs, tmp_path / "runs")
    xml = next((runs.parent / "scenarios").glob("*.xml"))
    suv = {"controller": "stanley", "road_friction": 0.3}
    execute(RunRequest(scenario=xml, backend="mujoco", vehicles="suv", backend_settings=suv,
                       cosim=CosimSettings(latency=0.0)), tmp_path / "runs" / "suv-no-latency")
    execute(RunRequest(scenario=xml, backend="ideal", seed=3), tmp_path / "runs" / "ideal-seed-3")
    (group,) = collect(tmp_path / "runs")
    assert sorted(group.runs) == ["ideal", "ideal seed=3", "mujoco/suv/stanley latency=0.0",
                                  "mujoco/suv/stanley latency=measured"]
    assert group.reference.run_dir.name == "ideal"
    assert sorted(group.comparisons) == ["ideal seed=3", "mujoco/suv/stanley latency=0.0",
                                         "mujoco/suv/stanley latency=measured"]
    page = next((build_report(tmp_path / "runs", tmp_path / "report").parent / "scenarios").glob("*.html")).read_text()
    assert "mujoco/suv/stanley latency=0.0" in page and "mujoco/suv/stanley latency=measured" in page


def test_runs_of_other_planners_are_compared_within_their_planner(runs, tmp_path):
    """A second planner's runs of the same scenario form their own group (compared with their own
    ideal run), and the report puts the planners side by side."""
    from pathlib import Path

    from simgap.planning.registry import PlannerChoice
    from simgap.report.site import build_report

    example = Path(__file__).resolve().parents[2] / "examples" / "time_gap_planner" / "time_gap_planner" / "planner.py"
    shutil.copytree(runs, tmp_path / "runs")
    xml = next((runs.parent / "scenarios").glob("*.xml"))
    gap = PlannerChoice(planner=f"{example}:TimeGapPlanner", label="time_gap")
    execute(RunRequest(scenario=xml, backend="ideal", planner=gap), tmp_path / "runs" / "ideal@time_gap")
    execute(RunRequest(scenario=xml, backend="mujoco", planner=gap), tmp_path / "runs" / "sedan@time_gap")
    frenet, time_gap = collect(tmp_path / "runs")
    assert (frenet.planner, time_gap.planner) == ("frenet", "time_gap")
    assert sorted(time_gap.runs) == ["ideal", "mujoco/sedan"] and list(time_gap.comparisons) == ["mujoco/sedan"]
    assert time_gap.comparisons["mujoco/sedan"][0].lateral_displacement.max < 0.5     # against its own ideal run
    index = build_report(tmp_path / "runs", tmp_path / "report").read_text()
    for text in ("2 planners (frenet, time_gap)", "Time per planning call", "time_gap · mujoco/sedan"):
        assert text in index
    scenarios = tmp_path / "report" / "scenarios"
    assert (scenarios / "curve_radius-10_angle-90-time_gap.html").exists()
    # one page puts every planner and fidelity of the scenario on shared axes, linked from both planners' pages
    both = (scenarios / "curve_radius-10_angle-90-all-planners.html").read_text()
    rows = re.findall(r"<tr><td class=\"text\"><a href='[^']+'>(\w+)</a></td><td class=\"text\">([^<]+)</td>", both)
    assert sorted(rows) == [("frenet", "ideal"), ("frenet", "mujoco/suv/stanley"), ("time_gap", "ideal"),
                            ("time_gap", "mujoco/sedan")]
    for name in ("d_over_s_1.png", "v_over_t_1.png", "paths.png"):
        assert (tmp_path / "report" / "assets" / "curve_radius-10_angle-90-all-planners" / name).exists()
    for planner_page in ("curve_radius-10_angle-90.html", "curve_radius-10_angle-90-time_gap.html"):
        assert "href='curve_radius-10_angle-90-all-planners.html'" in (scenarios / planner_page).read_text()
    assert "scenarios/curve_radius-10_angle-90-all-planners.html" in index
