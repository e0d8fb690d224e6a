"""Failure modes on a planted landscape (no simulation: rows made up by a model): a search's
violations grouped by the dimensions they need, what broke and the vehicle, found by probes that
move one dimension back to nominal, resumable; only probed violations reported; the search stops
early enough to follow up what it found."""

from __future__ import annotations

from pathlib import Path

import pytest

from simgap.cosim import Outcome
from simgap.experiment.run_row import RunRow
from simgap.experiment.search import Budget, StrategyRun
from simgap.experiment.search.failure_modes import what_broke
from simgap.experiment.search.follow_up import FollowUp, FollowUpReserve
from simgap.experiment.search.mode_probes import ModeProbes, probe_plan
from simgap.experiment.search.results import SearchResults, summarise
from simgap.experiment.search.space import SearchSpace
from simgap.experiment.search.spec import FailureRule, SearchSpec, checked_search
from simgap.experiment.search.strategies import make_strategy
from simgap.experiment.store import ResultsStore
from simgap.report.search_page import build_search_report
from simgap.scenario.logical import load_logical

LADDER = [{"backend": "ideal"},
          {"backend": "dynamic", "settings": {"integration_step": 0.004, "controller_hz": 50}},
          {"backend": "mujoco"}]


def two_modes(job):
    """In high fidelity: the city car leaves the road on low friction at speed (mode A: needs
    road_friction and initial_speed); every car drifts out of its lane with a long steering delay
    (mode B: needs steer_delay). The ideal world always passes."""
    high = job.backend == "mujoco"
    mu, delay = getattr(job.backend_settings, "road_friction", 1.0), getattr(job.backend_settings, "steer_delay", None)
    off_road = high and job.id.fidelity.vehicle == "city" and mu < 0.35 and job.parameters["initial_speed"] > 15
    drifts = high and delay > 0.07
    return RunRow(job.id, job.parameters, job.vehicle, "ok", outcome=Outcome.OFF_ROAD if off_road else Outcome.GOAL_REACHED,
                  job_time_s=1.0, metrics={"max_lateral_offset_m": 0.1, "max_lane_excursion_m": 0.3 if drifts else 0.0})


def searched(root: Path):
    spec = SearchSpec(name="modes", logical="curve", parameters={"initial_speed": {"min": 0, "max": 25}},
                      knobs={"road_friction": {"min": 0.2, "max": 1.0}, "steer_delay": {"min": 0.0, "max": 0.1}},
                      vehicles=["sedan", "city"], ladder=LADDER, grid_levels=3, strategies=["grid"],
                      failure=FailureRule(above={"max_lane_excursion_m": 0.1}), distinct_radius=0.1)
    space = SearchSpace(spec, load_logical("curve"))
    search = checked_search(spec, space.logical)
    run = StrategyRun(search, space, make_strategy("grid", space, spec), root, Budget(runs=500))
    run.ladder.scenario = lambda c, name=None: "unused.xml"
    run.resume()
    while (job := run.next_job()) is not None:
        run.on_result(job, two_modes(job))
    return search, space


def probe(search, space, root: Path, violations: int | None = None) -> ModeProbes:
    """Probe the first ``violations`` distinct violations found (default: all)."""
    found = summarise(root, "grid", 3, search.spec.distinct_radius)
    probes = ModeProbes(search, space, root)
    probes.ladder.scenario = lambda c, name=None: "unused.xml"
    for v in found.found[:violations]:
        for job in probes.jobs(v.row):
            probes.on_result(job, two_modes(job))
    return probes


def test_violations_group_into_the_planted_modes(tmp_path):
    root = tmp_path / "grid"
    search, space = searched(root)
    probe(search, space, root)
    result = summarise(root, "grid", 3, search.spec.distinct_radius)
    assert result.distinct == 20                     # 3 city cars off road, 9 + 8 drifting
    modes = {(m.vehicle, m.broke, tuple(m.needs)): m for m in result.modes}
    assert set(modes) == {("city", "off_road", ("initial_speed", "road_friction")),
                          ("sedan", "max_lane_excursion_m", ("steer_delay",)),
                          ("city", "max_lane_excursion_m", ("steer_delay",))}
    assert len(result.reported) == 20
    a = modes[("city", "off_road", ("initial_speed", "road_friction"))]
    assert a.count == 3 and a.ranges["road_friction"] == (0.2, 0.2) and a.ranges["steer_delay"] == (0.0, 0.1)
    assert a.representative_values["steer_delay"] == 0.0           # the clearest: no delay it does not need
    b = modes[("sedan", "max_lane_excursion_m", ("steer_delay",))]
    assert b.count == 9 and b.representative_values == {"initial_speed": 0.0, "road_friction": 1.0,
                                                        "steer_delay": 0.1}
    assert [m.count for m in result.modes] == [9, 8, 3]            # the most common first
    # a probe moves one dimension and keeps the rest of its violation
    rows = ResultsStore(root / "probes").rows()
    assert rows and all(r["probe_dim"] in ("initial_speed", "road_friction", "steer_delay") for r in rows)
    # the report lists each mode with its representative
    page = build_search_report(SearchResults(tmp_path, search.spec, [result], {"grid": []})).read_text()
    assert "failure modes" in page and "initial_speed, road_friction" in page
    assert f"c{b.representative:05d}</a>" in page


def test_only_probed_violations_are_reported_and_probing_resumes_without_repeating(tmp_path):
    root = tmp_path / "grid"
    search, space = searched(root)
    probe(search, space, root, violations=4)
    partial = summarise(root, "grid", 3, search.spec.distinct_radius)
    assert [v.candidate for v in partial.reported] == [v.candidate for v in partial.found[:4]]
    assert sum(m.count for m in partial.modes) == 4 and partial.distinct == 20     # the others: no mode, no report
    before = {r["key"]: r["fingerprint"] for r in ResultsStore(root / "probes").rows()}
    again = probe(search, space, root)
    rows = ResultsStore(root / "probes").rows()
    keys = [r["key"] for r in rows]
    assert len(keys) == len(set(keys)) and len(keys) == len(before) + len(again.done) - len(before)
    assert all({r["key"]: r["fingerprint"] for r in rows}[k] == v for k, v in before.items())
    assert len(summarise(root, "grid", 3, search.spec.distinct_radius).modes) == 3


def test_the_search_stops_early_enough_to_follow_up_what_it_found(tmp_path):
    """With the follow-up reserved (probes and a second seed each, no explanation), the search's
    runs plus the follow-up of the violations it found come to its budget, give or take one
    violation's follow-up: not to the budget plus every follow-up."""
    spec = SearchSpec(name="modes", logical="curve", parameters={"initial_speed": {"min": 0, "max": 25}},
                      knobs={"road_friction": {"min": 0.2, "max": 1.0}, "steer_delay": {"min": 0.0, "max": 0.1}},
                      vehicles=["sedan", "city"], ladder=LADDER, grid_levels=3, strategies=["grid"],
                      failure=FailureRule(above={"max_lane_excursion_m": 0.1}), distinct_radius=0.1)
    space = SearchSpace(spec, load_logical("curve"))
    search = checked_search(spec, space.logical)
    budget = Budget(runs=60)
    reserve = FollowUpReserve(probe_plan(search), FollowUp(repeats=2, explain=False), budget, 2,
                              spec.distinct_radius, workers=1)
    root = tmp_path / "grid"
    run = StrategyRun(search, space, make_strategy("grid", space, spec), root, budget, reserve)
    run.ladder.scenario = lambda c, name=None: "unused.xml"
    run.resume()
    while (job := run.next_job()) is not None:
        run.on_result(job, two_modes(job))
    found = summarise(root, "grid", 3, spec.distinct_radius)
    follow = [reserve.runs_of(v.row, v.run_dir) for v in found.found]
    assert found.found and run.runs() < budget.runs
    assert budget.runs <= run.runs() + sum(follow) <= budget.runs + max(follow)
    assert reserve.runs == sum(follow)              # what it reserved, kept up as it went
    planned = reserve.planned(found.found, 0.0, run.runs())
    assert planned == found.found[:len(planned)] and len(planned) >= len(found.found) - 1   # the last one: if it fits
    assert run.runs() + sum(follow[:len(planned) - 1]) < budget.runs                     # each begun within it


@pytest.mark.parametrize("reason, broke", [("goal missed (off_road)", "off_road"), ("collision", "collision"),
                                           ("max_lane_excursion_m 0.3 > 0.1", "max_lane_excursion_m"), ("", "unknown")])
def test_what_broke(reason, broke):
    assert what_broke(reason) == broke
