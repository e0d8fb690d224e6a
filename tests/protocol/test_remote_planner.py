"""Planners in a process of their own: they drive like any planner, and whatever they do wrong
fails their cycles or their agent with the reason recorded — never the run, never a hang."""

from __future__ import annotations

import json
import socket
import subprocess
import sys
from pathlib import Path

import pytest
from planner_runs import SERVERS, reasons, server

from simgap.cosim import CosimSettings
from simgap.errors import InputError
from simgap.experiment.single_run import RunRequest, execute, parse_planners
from simgap.planning.registry import PlannerChoice
from simgap.planning.remote import ProcessLimits


def run_with(curve_xml: Path, out: Path, planner: str, backend: str = "ideal", **limits):
    choice = PlannerChoice(planner=planner, process=ProcessLimits(**limits))
    run = execute(RunRequest(scenario=curve_xml, backend=backend, planner=choice), out)
    assert (out / "run.json").is_file(), "every run is written"
    return run, json.loads((out / "run.json").read_text())


@pytest.mark.parametrize("backend", ["ideal", "mujoco"])
def test_a_planner_in_its_own_process_drives_to_the_goal(curve_xml, tmp_path, backend):
    run, record = run_with(curve_xml, tmp_path / backend, server("keep_lane"), backend)
    agent = run.agents[0]
    assert agent.history.outcome == "goal_reached"
    assert agent.planner == "servers" and agent.history.planner_failures == 0
    process = record["settings"]["planner"]["process"]
    assert process["protocol_version"] == "1.0" and process["restarts"] == 0 and process["deadline_misses"] == 0


def test_an_isolated_planner_drives_bit_for_bit_as_in_process(curve_xml, tmp_path):
    in_process = execute(RunRequest(scenario=curve_xml, planner=PlannerChoice(planner="frenet")), tmp_path / "in")
    isolated = execute(RunRequest(scenario=curve_xml, planner=PlannerChoice(planner="frenet", isolate=True)),
                       tmp_path / "isolated")
    assert isolated.agents[0].history.outcome == in_process.agents[0].history.outcome == "goal_reached"
    assert isolated.fingerprint == in_process.fingerprint


@pytest.mark.parametrize("behaviour, fragment", [
    ("hang", "missed its deadline: no answer within 0.2 s"),
    ("segfault", "was killed by SIGSEGV"),
    ("exit", "exited with code 3"),
    ("dict", "invalid plan: a dict, not a trajectory"),
    ("nan", "invalid plan: x[5] is nan"),
    ("off_grid", "invalid plan: t[4]"),
    ("late_start", "invalid plan: it starts at"),
    ("huge", "invalid plan: 200000 states"),
])
def test_a_misbehaving_planner_fails_its_agent_with_the_reason(curve_xml, tmp_path, behaviour, fragment):
    run, record = run_with(curve_xml, tmp_path / behaviour, server(behaviour), deadline_s=0.2)
    agent = run.agents[0]
    assert run.failure is None, "the run itself completes"
    assert agent.history.outcome == "planner_failure"
    assert fragment in reasons(run)
    assert record["history"]["agents"][0]["outcome"] == "planner_failure"


def test_a_process_that_dies_is_restarted_then_given_up(curve_xml, tmp_path):
    run, record = run_with(curve_xml, tmp_path / "segfault", server("segfault"), restarts=2)
    text = reasons(run)
    assert text.count("; restarted") == 2 and "no restart left" in text
    assert record["settings"]["planner"]["process"]["restarts"] == 2


def test_a_planner_that_raises_is_recorded_with_its_own_traceback(curve_xml, tmp_path):
    run, _ = run_with(curve_xml, tmp_path / "raise", server("raise"))
    assert run.agents[0].history.outcome == "planner_failure" and run.agents[0].history.planner_exceptions == 10
    error = run.history.planner_errors[0]
    assert error.exception == "RemotePlannerError" and "the planner's own bug" in error.message
    assert "servers.py" in error.traceback and "RuntimeError" in error.traceback


def test_one_late_answer_fails_one_cycle_and_the_drive_goes_on(curve_xml, tmp_path):
    run, record = run_with(curve_xml, tmp_path / "slow", server("slow_once"), deadline_s=0.5)
    assert run.agents[0].history.outcome == "goal_reached"
    assert record["settings"]["planner"]["process"]["deadline_misses"] >= 1
    assert "missed its deadline" in reasons(run)


@pytest.mark.parametrize("behaviour, fragment", [
    ("hang_init", "no answer to Initialize within 1 s"),
    ("refuse_init", "refused Initialize: ValueError: needs settings.map_name"),
    ("garbage_bytes", "not a planner reply"),
])
def test_a_planner_that_never_gets_ready_is_a_recorded_run_that_did_not_start(curve_xml, tmp_path, behaviour,
                                                                            fragment):
    run, _ = run_with(curve_xml, tmp_path / behaviour, server(behaviour), startup_timeout_s=1.0)
    assert run.failure is not None and run.history.planner_errors
    assert fragment in run.history.planner_errors[0].message


def test_a_planner_that_runs_on_its_own_serves_run_after_run(curve_xml, tmp_path):
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    address = f"tcp://127.0.0.1:{port}"
    process = subprocess.Popen([sys.executable, str(SERVERS), f"serve_at={address}"])
    try:
        for k in range(2):
            run, _ = run_with(curve_xml, tmp_path / f"run{k}", address, startup_timeout_s=20)
            assert run.agents[0].history.outcome == "goal_reached"
        assert process.poll() is None, "a planner on its own is not ended by simgap"
    finally:
        process.kill()
        process.wait()


def test_isolation_keeps_a_planner_that_ends_the_process_from_ending_simgap(curve_xml, tmp_path):
    planner = tmp_path / "exits.py"
    planner.write_text("import os\nclass Exits:\n    def plan(self, observed, t, world):\n        os._exit(7)\n")
    run = execute(RunRequest(scenario=curve_xml, planner=PlannerChoice(planner=f"{planner}:Exits", isolate=True),
                             cosim=CosimSettings()), tmp_path / "run")
    assert run.agents[0].history.outcome == "planner_failure"
    assert "exited with code 7" in reasons(run)


def test_commands_and_addresses_are_one_planner_for_every_agent_and_are_checked():
    choice = parse_planners(f"exec:{sys.executable} -c 'a=1,2'")
    assert isinstance(choice, PlannerChoice) and choice.planner.endswith("'a=1,2'")
    with pytest.raises(InputError, match="no program 'no-such-planner-program'"):
        parse_planners("exec:no-such-planner-program --x")
    with pytest.raises(InputError, match="names no command"):
        parse_planners("exec:  ")
    with pytest.raises(InputError, match="isolate is for planner classes"):
        PlannerChoice(planner="tcp://127.0.0.1:5555", isolate=True).load()


def test_a_batch_with_hostile_planners_records_every_run_and_finishes(tmp_path):
    from simgap.experiment.store import ResultsStore

    spec = tmp_path / "hostile.yaml"
    planners = "\n".join(f'  - {{planner: "exec:{sys.executable} {SERVERS} {b}", label: {b}, '
                         f'process: {{deadline_s: 0.2}}}}' for b in ("keep_lane", "hang", "segfault", "dict"))
    spec.write_text(f"name: hostile\nlogical: curve\nparameters:\n  radius: {{values: [30]}}\n"
                    f"  angle: {{values: [45]}}\nsampler: {{kind: grid}}\nfidelities:\n  - backend: ideal\n"
                    f"planners:\n{planners}\n")
    out = tmp_path / "experiment"
    done = subprocess.run([sys.executable, "-m", "simgap", "experiment", "run", str(spec), "--out", str(out),
                           "--workers", "2", "--no-report", "--no-validate"], capture_output=True, text=True,
                          timeout=300)
    assert done.returncode == 0, done.stderr[-2000:]
    rows = {r["planner"]: r for r in ResultsStore(out).rows()}
    assert sorted(rows) == ["dict", "hang", "keep_lane", "segfault"] and len(ResultsStore(out).rows()) == 4
    assert all(r["status"] == "ok" for r in rows.values())
    assert rows["keep_lane"]["outcome"] == "goal_reached"
    assert {rows[b]["outcome"] for b in ("hang", "segfault", "dict")} == {"planner_failure"}
    assert len(list((out / "runs").rglob("run.json"))) == 4


def test_experiments_stored_before_planners_had_process_settings_still_resume(tmp_path):
    """A spec's results hash (what a stored experiment resumes by) is unchanged by the planner fields
    `isolate` and `process` at their defaults; set, they count."""
    from simgap.experiment.spec import load_spec

    spec = tmp_path / "spec.yaml"
    body = ("name: h\nlogical: curve\nparameters:\n  radius: {values: [30]}\n  angle: {values: [45]}\n"
            "sampler: {kind: grid}\nfidelities:\n  - backend: ideal\nplanners:\n")
    spec.write_text(body + "  - frenet\n  - {planner: idm, label: traffic}\n")
    assert load_spec(spec).spec.results_hash() == "ab73a6ac35f8f042"     # as stored by simgap before them
    spec.write_text(body + "  - {planner: frenet, isolate: true}\n  - {planner: idm, label: traffic}\n")
    assert load_spec(spec).spec.results_hash() != "ab73a6ac35f8f042"


def test_a_planner_process_s_own_traceback_is_kept_with_the_error():
    from simgap.cosim import PlannerError
    from simgap.planning.remote import RemotePlannerError

    error = PlannerError.of(RemotePlannerError("KeyError", "'lane'", "File planner.py, line 3: KeyError"), 1, 0.5)
    assert (error.exception, error.message) == ("RemotePlannerError", "KeyError: 'lane'")
    assert error.traceback.endswith("The planner's process reported:\nFile planner.py, line 3: KeyError")
    assert "reported" not in PlannerError.of(ValueError("x"), 1, 0.5).traceback
