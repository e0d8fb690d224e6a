"""Deadlines of a planner in its own process hold for every answer: a late one is a miss, never
accepted, and a late one followed by silence fails cycles instead of hanging the run."""

from __future__ import annotations

import time

from planner_runs import reasons, server

from simgap.experiment.single_run import RunRequest, execute
from simgap.planning.registry import PlannerChoice
from simgap.planning.remote import ProcessLimits


def run_late(curve_xml, out, behaviour: str):
    choice = PlannerChoice(planner=server(behaviour), process=ProcessLimits(deadline_s=0.2))
    started = time.perf_counter()
    run = execute(RunRequest(scenario=curve_xml, planner=choice, run_timeout_s=60), out)
    return run, time.perf_counter() - started


def test_a_planner_late_once_then_silent_fails_its_cycles_and_does_not_hang(curve_xml, tmp_path):
    run, took = run_late(curve_xml, tmp_path / "silent", "late_then_silent")
    assert run.failure is None, "the run completes, its agent fails"
    agent = run.agents[0]
    assert agent.history.outcome == "planner_failure"
    assert "missed its deadline" in reasons(run)
    assert took < 30, "ten missed deadlines of 0.2 s, not the run's wall-time limit"


def test_every_late_answer_is_a_miss_none_is_accepted(curve_xml, tmp_path):
    run, _ = run_late(curve_xml, tmp_path / "late", "always_late")
    agent = run.agents[0]
    assert agent.history.outcome == "planner_failure"
    process = run.settings.planner.process
    assert process.deadline_misses == agent.history.planner_failures, "every failed cycle is a missed deadline"
