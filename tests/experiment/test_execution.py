"""Running experiments: resume after SIGKILL, failures and timeouts recorded per run, Ray."""

from __future__ import annotations

import multiprocessing as mp
import os
import signal
import subprocess
import sys
import threading
import time

import pytest
import simgap_command
import yaml

from simgap.errors import InputError
from simgap.experiment.runner import experiment_status, run_experiment
from simgap.experiment.store import ResultsStore
from simgap.report.site import build_experiment_report

SMALL = {"name": "small", "logical": "curve",
         "parameters": {"radius": {"values": [20, 50]}, "angle": {"values": [30, 90]}},
         "fidelities": [{"backend": "ideal"}], "cosim": {"replan_every": 3}}


def spec_file(tmp_path, name="spec.yaml", **changes):
    path = tmp_path / name
    path.write_text(yaml.safe_dump(SMALL | changes))
    return path


def rows_by_key(root):
    rows = ResultsStore(root).rows()
    return {r["key"]: r for r in rows}, [r["key"] for r in rows]


def test_a_killed_experiment_resumes_without_losing_or_repeating_a_run(tmp_path):
    spec = spec_file(tmp_path)
    out = tmp_path / "killed"
    proc = simgap_command.start("experiment", "run", spec, "--out", out, "--workers", "2", "--no-report", "--no-validate")
    rows_dir = out / "store" / "rows"
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline and not (rows_dir.exists() and any(rows_dir.glob("*.parquet"))):
        time.sleep(0.05)
    os.killpg(proc.pid, signal.SIGKILL)          # the whole process group: driver and workers
    proc.wait()
    before, _ = rows_by_key(out)
    assert 1 <= len(before) < 4, "the kill came after the first and before the last run finished"

    result = run_experiment(spec, out, workers=2)
    assert result.skipped == len(before) and result.ran == 4 - len(before) and result.failed == 0
    after, keys = rows_by_key(out)
    assert len(keys) == len(set(keys)) == 4
    assert all(after[k]["fingerprint"] == before[k]["fingerprint"] for k in before)   # kept, not rerun
    assert not list(out.rglob(".*.tmp")) and not [p for p in (out / "runs").rglob(".*") if p.is_dir()]

    clean = tmp_path / "clean"
    run_experiment(spec, clean, workers=2)
    uninterrupted, _ = rows_by_key(clean)
    assert {k: r["fingerprint"] for k, r in uninterrupted.items()} == {k: r["fingerprint"] for k, r in after.items()}
    status = experiment_status(out)
    assert (len(status.ok), len(status.failed), len(status.left)) == (4, 0, 0)


def test_a_failing_run_is_recorded_with_its_reason_and_the_rest_succeed(tmp_path):
    # 125 Hz divides the physics rate (the spec is valid) but not the scenario's 0.1 s step: the run fails
    spec = spec_file(tmp_path, fidelities=[{"backend": "ideal"},
                                           {"backend": "mujoco", "settings": {"controller_hz": 125}}],
                     parameters={"radius": {"values": [50]}, "angle": {"values": [30]}})
    result = run_experiment(spec, tmp_path / "out", workers=2)
    report = build_experiment_report(tmp_path / "out")
    rows, _ = rows_by_key(tmp_path / "out")
    assert result.total == 2 and result.failed == 1
    assert "not a whole number of controller periods" in report.read_text()   # the report lists it
    assert rows["curve_radius-50_angle-30/ideal"]["status"] == "ok"
    failed = rows["curve_radius-50_angle-30/mujoco/sedan"]
    assert failed["status"] == "failed" and "not a whole number of controller periods" in failed["failure"]
    # a failed run is finished too: resuming does not run it again, unless asked to
    resumed = run_experiment(spec, tmp_path / "out", workers=1)
    assert (resumed.ran, resumed.skipped, resumed.skipped_failed) == (0, 2, 1)
    again = run_experiment(spec, tmp_path / "out", workers=1, retry_failed=True)
    assert (again.ran, again.failed, again.skipped, again.skipped_failed) == (1, 1, 1, 0)
    assert len(ResultsStore(tmp_path / "out").rows()) == 2


def test_a_run_whose_worker_dies_is_recorded_with_the_reason_and_runs_again_on_resume(tmp_path):
    spec = spec_file(tmp_path, fidelities=[{"backend": "mujoco"}],
                     parameters={"radius": {"values": [20]}, "angle": {"values": [90]}})
    out = tmp_path / "out"

    def kill_the_worker() -> None:           # the pool's one worker, once the run is under way (it takes seconds)
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline and not mp.active_children():
            time.sleep(0.05)
        time.sleep(1.0)
        for child in mp.active_children():
            os.kill(child.pid, signal.SIGKILL)

    killer = threading.Thread(target=kill_the_worker)
    killer.start()
    result = run_experiment(spec, out, workers=1)
    killer.join()
    (row,) = ResultsStore(out).rows()
    assert result.failed == 1 and row["failure"] == "worker died (signal 9)"
    assert len(experiment_status(out).left) == 1
    again = run_experiment(spec, out, workers=1)
    (row,) = ResultsStore(out).rows()
    assert (again.ran, again.failed, again.skipped) == (1, 0, 0) and row["status"] == "ok"


def test_a_run_over_its_time_limit_is_stopped_and_recorded(tmp_path):
    spec = spec_file(tmp_path, run_timeout_s=0.5, parameters={"radius": {"values": [50]}, "angle": {"values": [30]}})
    start = time.monotonic()
    result = run_experiment(spec, tmp_path / "out", workers=1)
    assert time.monotonic() - start < 30
    (row,) = ResultsStore(tmp_path / "out").rows()
    assert result.failed == 1 and row["status"] == "failed" and row["failure"].startswith("timeout")


def test_a_changed_spec_is_refused_on_the_same_directory(tmp_path):
    out = tmp_path / "out"
    run_experiment(spec_file(tmp_path, parameters={"radius": {"values": [50]}, "angle": {"values": [30]}}),
                   out, workers=1)
    changed = spec_file(tmp_path, "changed.yaml", parameters={"radius": {"values": [50]}, "angle": {"values": [30]}},
                        cosim={"replan_every": 1})
    with pytest.raises(InputError, match=r"different spec \(changed: cosim.replan_every\)"):
        run_experiment(changed, out, workers=1)


def test_the_ray_executor_fills_the_same_store_as_the_local_one(tmp_path):
    pytest.importorskip("ray")
    spec = spec_file(tmp_path, parameters={"radius": {"values": [20, 50]}, "angle": {"values": [30]}})
    run_experiment(spec, tmp_path / "local", workers=2)
    run_experiment(spec, tmp_path / "ray", workers=2, executor="ray")
    local, _ = rows_by_key(tmp_path / "local")
    remote, _ = rows_by_key(tmp_path / "ray")
    assert sorted(local) == sorted(remote) and len(local) == 2
    for key in local:
        for column in ("status", "outcome", "fingerprint", "time_to_goal_max_s", "distance_m"):
            assert local[key][column] == remote[key][column], (key, column)


def test_temporaries_of_a_writer_killed_mid_write_are_removed_when_the_store_is_prepared(tmp_path):
    from simgap.files import atomic_write_text
    child = subprocess.Popen([sys.executable, "-c",
                              "import os, sys; from simgap.files import atomic_write;"
                              "atomic_write(sys.argv[1], lambda tmp: (tmp.write_text('half'), os.kill(os.getpid(), 9)))",
                              str(tmp_path / "budget.json")])
    child.wait()
    assert child.returncode == -signal.SIGKILL
    left = list(tmp_path.rglob(".*.tmp*"))
    assert len(left) == 1 and not (tmp_path / "budget.json").exists()
    atomic_write_text(tmp_path / "kept.json", "{}")
    ResultsStore(tmp_path).prepare()
    assert not list(tmp_path.rglob(".*.tmp*")) and (tmp_path / "kept.json").read_text() == "{}"
