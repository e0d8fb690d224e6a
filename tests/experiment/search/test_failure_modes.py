"""Failure modes on a planted landscape (no simulation: rows made up by a model): a search's
violations grouped by the dimensions they need, what broke and the vehicle, found by probes that
move one dimension back to nominal; budgeted and resumable."""

from __future__ import annotations

from pathlib import Path

import pytest

from simgap.cosim import Outcome
from simgap.experiment.search.failure_modes import what_broke
from simgap.experiment.knobs import knob_value
from simgap.experiment.search.mode_probes import ModeProbes
from simgap.experiment.run_row import RunRow
from simgap.experiment.search import Budget, StrategyRun
from simgap.experiment.search.results import SearchResults, summarise
from simgap.experiment.search.space import SearchSpace
from simgap.experiment.search.spec import FailureRule, SearchSpec, checked_search
from simgap.experiment.store import ResultsStore
from simgap.experiment.search.strategies import make_strategy
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
    mu, delay = knob_value("road_friction", job.backend_settings), knob_value("steer_delay", job.backend_settings)
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


def probe(search, space, root: Path, budget: int) -> ModeProbes:
    found = summarise(root, "grid", 3, search.spec.distinct_radius)
    probes = ModeProbes(search, space, root, [v.row for v in found.found], budget)
    probes.ladder.scenario = lambda c, name=None: "unused.xml"
    while (job := probes.next_job()) is not None:
        probes.on_result(job, two_modes(job))
    return probes


def test_violations_group_into_the_planted_modes(tmp_path):
    root = tmp_path / "grid"
    search, space = searched(root)
    probe(search, space, root, budget=200)
    result = summarise(root, "grid", 3, search.spec.distinct_radius)
    assert result.distinct == 20                     # 3 city cars off road, 9 + 8 drifting
    modes = {(m.vehicle, m.broke, tuple(m.needs)): m for m in result.modes}
    assert set(modes) == {("city", "off_road", ("initial_speed", "road_friction")),
                          ("sedan", "max_lane_excursion_m", ("steer_delay",)),
                          ("city", "max_lane_excursion_m", ("steer_delay",))}
    assert all(m.probed for m in result.modes) and result.probed_modes == 3
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


def test_probes_keep_to_their_budget_and_resume_without_repeating(tmp_path):
    root = tmp_path / "grid"
    search, space = searched(root)
    first = probe(search, space, root, budget=5)
    assert first.made == 5 and len(ResultsStore(root / "probes").rows()) == 5
    partial = summarise(root, "grid", 3, search.spec.distinct_radius)
    assert any(not m.probed for m in partial.modes)              # the rest are grouped, marked not probed
    assert sum(m.count for m in partial.modes) == partial.distinct
    before = {r["key"]: r["fingerprint"] for r in ResultsStore(root / "probes").rows()}
    again = probe(search, space, root, budget=200)
    rows = ResultsStore(root / "probes").rows()
    keys = [r["key"] for r in rows]
    assert len(keys) == len(set(keys)) == again.made
    assert all({r["key"]: r["fingerprint"] for r in rows}[k] == v for k, v in before.items())
    assert summarise(root, "grid", 3, search.spec.distinct_radius).probed_modes == 3


def test_a_small_probe_budget_gives_every_group_its_clearest_member_first(tmp_path):
    """Three groups may be modes here (the city car off the road; each car out of its lane): nine
    probe runs (three dimensions each at most) probe one member of each, the one nearest nominal,
    and every group comes out a probed mode with that member as its representative."""
    root = tmp_path / "grid"
    search, space = searched(root)
    probe(search, space, root, budget=9)
    result = summarise(root, "grid", 3, search.spec.distinct_radius)
    probed = [m for m in result.modes if m.probed]
    assert {(m.vehicle, m.broke) for m in probed} == {("city", "off_road"), ("city", "max_lane_excursion_m"),
                                                     ("sedan", "max_lane_excursion_m")}
    delay = {m.vehicle: m for m in probed if m.broke == "max_lane_excursion_m"}
    assert all(m.needs == ["steer_delay"] and m.representative_values["road_friction"] == 1.0 for m in delay.values())


@pytest.mark.parametrize("reason, broke", [("goal missed (off_road)", "off_road"), ("collision", "collision"),
                                           ("max_lane_excursion_m 0.3 > 0.1", "max_lane_excursion_m"), ("", "unknown")])
def test_what_broke(reason, broke):
    assert what_broke(reason) == broke
