"""What a planner in its own process sends is checked before simgap keeps it: its protocol version,
each reply's id, the size of replies, names and reasons; and nothing it starts outlives it."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time

import pytest
from planner_runs import reasons, server
from simgap_planner.server import compatible

from simgap.errors import InputError
from simgap.experiment.single_run import RunRequest, execute, parse_planners
from simgap.planning.registry import PlannerChoice
from simgap.planning.remote import MAX_NAME, MAX_REASON, ProcessLimits


def run_raw(curve_xml, out, options: str, **limits):
    choice = PlannerChoice(planner=server("raw," + options), process=ProcessLimits(**limits))
    return execute(RunRequest(scenario=curve_xml, planner=choice, run_timeout_s=60), out)


@pytest.mark.parametrize("version", ["2.0", "banana", "", "1"])
def test_a_planner_of_another_major_version_or_none_is_refused(curve_xml, tmp_path, version):
    run = run_raw(curve_xml, tmp_path / "run", f"version={version}")
    assert run.failure is not None and run.history.planner_errors
    message = run.history.planner_errors[0].message
    assert f"speaks protocol version '{version}'" in message and "another major version" in message


def test_a_reply_with_another_id_is_not_a_plan(curve_xml, tmp_path):
    run = run_raw(curve_xml, tmp_path / "run", "id_shift=7")
    assert run.agents[0].history.outcome == "planner_failure"
    assert "invalid plan: a reply with the id" in reasons(run)


def test_long_names_and_reasons_are_kept_short(curve_xml, tmp_path):
    run = run_raw(curve_xml, tmp_path / "run", "name_chars=1000000,reason_chars=1000000")
    assert run.agents[0].history.outcome == "planner_failure"
    record = json.loads((tmp_path / "run" / "run.json").read_text())
    assert len(record["settings"]["planner"]["process"]["planner"]) < MAX_NAME + 50
    assert max(len(e["detail"]) for e in record["history"]["events"]) < MAX_REASON + 200
    assert (tmp_path / "run" / "run.json").stat().st_size < 500_000


def test_a_reply_over_the_size_limit_is_not_read_and_the_run_goes_on(curve_xml, tmp_path):
    started = time.perf_counter()
    run = run_raw(curve_xml, tmp_path / "run", "reason_chars=20000000", deadline_s=0.2)
    assert run.failure is None and run.agents[0].history.outcome == "planner_failure"
    assert "missed its deadline: no answer within 0.2 s; its connection dropped meanwhile (a reply over 16 MiB drops it" \
        in reasons(run)
    assert time.perf_counter() - started < 40


def test_the_end_of_a_long_output_is_kept_of_a_planner_that_ends(curve_xml, tmp_path):
    run = run_raw(curve_xml, tmp_path / "run", "output_bytes=50000000,exit_code=5")
    assert run.failure is not None
    message = run.history.planner_errors[0].message
    assert "exited with code 5; its output ends: " in message and "xthe last line of the output" in message
    assert len(message) < 3000


def alive(pid: int) -> bool:
    try:
        with open(f"/proc/{pid}/stat") as stat:
            return stat.read().rpartition(")")[2].split()[0] != "Z"
    except OSError:
        return False


def started_pids(folder, timeout_s: float = 30.0) -> list[int]:
    """The pids `fork_and_daemon` wrote, once both are there."""
    end = time.monotonic() + timeout_s
    files = [folder / "child.pid", folder / "daemon.pid"]
    while not all(f.is_file() and f.read_text() for f in files):
        assert time.monotonic() < end, "the planner did not start"
        time.sleep(0.05)
    return [int(f.read_text()) for f in files]


def all_ended(pids: list[int], timeout_s: float = 10.0) -> bool:
    end = time.monotonic() + timeout_s
    while any(alive(p) for p in pids) and time.monotonic() < end:
        time.sleep(0.05)
    return not any(alive(p) for p in pids)


def test_what_a_planner_forks_ends_with_it(curve_xml, tmp_path, monkeypatch):
    monkeypatch.setenv("SIMGAP_TEST_PIDS", str(tmp_path))
    run = execute(RunRequest(scenario=curve_xml, planner=PlannerChoice(planner=server("fork_and_daemon"))),
                  tmp_path / "run")
    assert run.agents[0].history.outcome == "goal_reached"
    assert all_ended(started_pids(tmp_path)), "its forked child and its setsid daemon are ended"


@pytest.mark.parametrize("signum", [signal.SIGTERM, signal.SIGKILL], ids=["SIGTERM", "SIGKILL"])
def test_a_killed_simgap_leaves_no_planner_process_or_folder(curve_xml, tmp_path, signum):
    env = {**os.environ, "SIMGAP_TEST_PIDS": str(tmp_path), "TMPDIR": str(tmp_path)}
    simgap = subprocess.Popen([sys.executable, "-m", "simgap", "run", str(curve_xml), "--out", str(tmp_path / "run"),
                               "--no-validate", "--planner", server("fork_and_daemon")], env=env,
                              stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        pids = started_pids(tmp_path)
        simgap.send_signal(signum)
        simgap.wait(10)
    finally:
        simgap.kill()
    assert all_ended(pids, timeout_s=30.0), "the planner's forked child and setsid daemon end with simgap"
    end = time.monotonic() + 5
    while list(tmp_path.glob("simgap-planner-*")) and time.monotonic() < end:
        time.sleep(0.05)
    assert not list(tmp_path.glob("simgap-planner-*")), "its temporary folder is removed"


@pytest.mark.parametrize("text, field, fragment", [
    ("when: 2024-01-01\n", "when", "2024-01-01 (a date) is not a JSON value"),
    ("speed: .inf\n", "speed", "inf is not a finite number"),
    ("a:\n  b: [1, .nan]\n", "a.b[1]", "nan is not a finite number"),
    ("2024-01-01: x\n", None, "Input should be a valid string"),
])
def test_settings_that_are_not_json_are_refused_before_any_run(tmp_path, text, field, fragment):
    config = tmp_path / "settings.yaml"
    config.write_text(text)
    with pytest.raises(InputError) as refused:
        parse_planners(server("keep_lane"), config)
    assert field is None or refused.value.field == field
    assert fragment in str(refused.value)


def test_the_command_refuses_a_date_in_a_planners_settings_in_one_line(curve_xml, tmp_path):
    config = tmp_path / "settings.yaml"
    config.write_text("when: 2024-01-01\n")
    done = subprocess.run([sys.executable, "-m", "simgap", "run", str(curve_xml), "--out", str(tmp_path / "run"),
                           "--planner", server("keep_lane"), "--planner-config", str(config)],
                          capture_output=True, text=True, timeout=120)
    assert done.returncode == 2 and "Traceback" not in done.stderr
    assert len(done.stderr.strip().splitlines()) == 1 and "settings.yaml" in done.stderr and "when" in done.stderr
    assert not (tmp_path / "run").exists()


@pytest.mark.parametrize("version, speaks", [("1.0", True), ("1.12", True), ("2.0", False), ("banana", False),
                                             ("", False), ("1", False), ("1.x", False), ("1.0.0", False)])
def test_only_major_minor_of_the_same_major_version_is_compatible(version, speaks):
    assert compatible(version) is speaks
