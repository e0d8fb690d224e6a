"""An experiment stopped from outside: SIGTERM ends the command in one line with a non-zero exit and
its workers with it; SIGKILL of the driver alone ends its workers too (no orphan finishes its run
and prints a BrokenPipeError later); a run stopped half-way is run again on resume."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
import yaml

from simgap.experiment.runner import experiment_status

ONE_RUN = {"name": "one", "logical": "curve", "parameters": {"radius": {"values": [50]}, "angle": {"values": [30]}},
           "fidelities": [{"backend": "dynamic"}], "cosim": {"replan_every": 1}}

pytestmark = pytest.mark.skipif(not Path("/proc/self/task").is_dir(), reason="reads children from /proc (Linux)")


def children(pid: int) -> list[int]:
    found = []
    for task in Path(f"/proc/{pid}/task").glob("*"):
        found += [int(c) for c in (task / "children").read_text().split()] if (task / "children").exists() else []
    return found


def cmdline(pid: int) -> str:
    try:
        return Path(f"/proc/{pid}/cmdline").read_text(errors="replace")
    except OSError:
        return ""


def alive(pid: int) -> bool:
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except OSError:
        return False
    return state != "Z"


def started_experiment(tmp_path: Path) -> tuple[subprocess.Popen, list[int], Path]:
    """``simgap experiment run`` with its one worker at work, the worker's pid and its stderr file."""
    spec, out, err = tmp_path / "spec.yaml", tmp_path / "out", tmp_path / "stderr.txt"
    spec.write_text(yaml.safe_dump(ONE_RUN))
    driver = subprocess.Popen([sys.executable, "-m", "simgap", "experiment", "run", str(spec), "--out", str(out),
                               "--workers", "1", "--no-report", "--no-validate"], stdout=subprocess.DEVNULL,
                              stderr=err.open("w"), start_new_session=True)
    deadline = time.monotonic() + 120
    workers: list[int] = []
    while time.monotonic() < deadline and not workers and driver.poll() is None:
        time.sleep(0.2)
        workers = [c for c in children(driver.pid) if "multiprocessing" in cmdline(c)]
    assert workers, f"the pool's worker started (driver exit {driver.poll()}: {err.read_text()[-300:]})"
    time.sleep(1.0)                                    # at work on its run
    return driver, workers, err


def gone_within(pids: list[int], seconds: float) -> bool:
    deadline = time.monotonic() + seconds
    while time.monotonic() < deadline:
        if not any(alive(p) for p in pids):
            return True
        time.sleep(0.1)
    return False


def test_sigterm_ends_an_experiment_in_one_line_and_its_worker_with_it(tmp_path):
    driver, workers, err = started_experiment(tmp_path)
    driver.send_signal(signal.SIGTERM)
    assert driver.wait(timeout=30) == 128 + signal.SIGTERM
    lines = err.read_text().strip().splitlines()
    assert len(lines) == 1 and "stopped by SIGTERM" in lines[0], lines
    assert gone_within(workers, 10)
    assert len(experiment_status(tmp_path / "out").left) == 1          # not done: it runs again on resume


def test_a_killed_driver_takes_its_worker_with_it_and_nothing_is_printed_later(tmp_path):
    driver, workers, err = started_experiment(tmp_path)
    os.kill(driver.pid, signal.SIGKILL)                # the driver alone, as the OOM killer would
    driver.wait(timeout=30)
    assert gone_within(workers, 10)
    time.sleep(0.5)
    assert "Traceback" not in err.read_text() and "BrokenPipeError" not in err.read_text()
