"""simgap on a real Ray cluster: a head started with `ray start --head` in a subprocess (its own
ports and temp dir, stopped afterwards whatever happens), simgap as a separate driver through
both address forms: the cluster address HOST:PORT and Ray Client's ray://HOST:PORT."""

from __future__ import annotations

import os
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import threading
import time
from dataclasses import dataclass
from pathlib import Path

import pytest
import simgap_command
import yaml

import simgap
from simgap.errors import InputError
from simgap.experiment.ray_cluster import NodeSoftware, check_nodes, connection_error, disconnect
from simgap.experiment.runner import experiment_status, run_experiment
from simgap.experiment.search import Budget, run_search
from simgap.experiment.store import ResultsStore
from simgap.record import read_run

pytestmark = pytest.mark.cluster

SRC = str(Path(simgap.__file__).resolve().parents[1])     # the simgap under test, for the cluster's workers
SMALL = {"name": "small", "logical": "curve",
         "parameters": {"radius": {"values": [20, 35, 50]}, "angle": {"values": [30]}},
         "fidelities": [{"backend": "ideal"}], "cosim": {"replan_every": 3}}
SEARCH = {"name": "s", "logical": "curve",
          "parameters": {"radius": {"min": 10, "max": 30}, "initial_speed": {"min": 10, "max": 20}},
          "knobs": {"road_friction": {"min": 0.2, "max": 1.0}},
          # a fixed plan latency: with the measured one a planning call that overruns its cycle on a loaded
          # machine delays its plan, and the cluster's run and the local one part
          "ladder": [{"backend": "ideal"}, {"backend": "dynamic", "cosim": {"latency": 0.1}}],
          "failure": {"above": {"peak_grip_use": 0.9}}, "strategies": ["random"], "run_timeout_s": 120}


@dataclass
class Cluster:
    address: str          # HOST:PORT of its GCS
    client: str           # ray://HOST:PORT of its Ray Client server
    process: subprocess.Popen
    temp: Path


def free_ports(n: int) -> list[int]:
    socks = [socket.socket() for _ in range(n)]
    try:
        for s in socks:
            s.bind(("127.0.0.1", 0))
        return [s.getsockname()[1] for s in socks]
    finally:
        for s in socks:
            s.close()


def answers(port: int) -> bool:
    try:
        socket.create_connection(("127.0.0.1", port), timeout=1).close()
        return True
    except OSError:
        return False


def start_head(pythonpath: str, cpus: int = 2) -> Cluster:
    """``ray start --head --block`` in a session of its own: stopping it stops only this cluster."""
    gcs, client, dashboard, agent, agent_grpc, metrics, runtime_env = free_ports(7)
    temp = Path(tempfile.mkdtemp(prefix="sg-ray-", dir="/tmp"))      # short: Ray's socket paths are limited
    command = [str(Path(sys.executable).with_name("ray")), "start", "--head", "--block",
               "--node-ip-address", "127.0.0.1", "--port", str(gcs), "--ray-client-server-port", str(client),
               "--dashboard-port", str(dashboard), "--dashboard-agent-listen-port", str(agent),
               "--dashboard-agent-grpc-port", str(agent_grpc), "--metrics-export-port", str(metrics),
               "--runtime-env-agent-port", str(runtime_env), "--include-dashboard", "false",
               "--num-cpus", str(cpus), "--object-store-memory", str(200_000_000),
               "--temp-dir", str(temp), "--disable-usage-stats"]
    env = dict(os.environ, PYTHONPATH=pythonpath, RAY_USAGE_STATS_ENABLED="0")
    with open(temp / "head.log", "w") as log:
        process = subprocess.Popen(command, stdout=log, stderr=subprocess.STDOUT, env=env, start_new_session=True)
    cluster = Cluster(f"127.0.0.1:{gcs}", f"ray://127.0.0.1:{client}", process, temp)
    deadline = time.monotonic() + 90
    while not (answers(gcs) and answers(client)):
        if process.poll() is not None or time.monotonic() > deadline:
            log_text = (temp / "head.log").read_text()
            stop_head(cluster)
            pytest.fail(f"ray start --head did not come up:\n{log_text[-2000:]}")
        time.sleep(0.2)
    return cluster


def stop_head(cluster: Cluster) -> None:
    """SIGTERM to the session (`ray start --block` then stops its processes), SIGKILL to stragglers."""
    disconnect()
    for sig, wait in ((signal.SIGTERM, 20), (signal.SIGKILL, 5)):
        try:
            os.killpg(cluster.process.pid, sig)
        except ProcessLookupError:
            break
        try:
            cluster.process.wait(timeout=wait)
        except subprocess.TimeoutExpired:
            pass
    shutil.rmtree(cluster.temp, ignore_errors=True)


@pytest.fixture(scope="module")
def cluster():
    head = start_head(SRC + os.pathsep + os.environ.get("PYTHONPATH", ""))
    try:
        yield head
    finally:
        stop_head(head)


def spec_file(tmp_path: Path, spec: dict, name: str = "spec.yaml") -> Path:
    path = tmp_path / name
    path.write_text(yaml.safe_dump(spec))
    return path


def store_rows(root: Path) -> dict[str, dict]:
    rows = ResultsStore(root).rows()
    keys = [r["key"] for r in rows]
    assert len(keys) == len(set(keys)), "a run was stored twice"
    return {r["key"]: r for r in rows}


def simgap_cli(*args: str) -> subprocess.CompletedProcess:
    env = dict(os.environ, COLUMNS="200", PYTHONPATH=SRC + os.pathsep + os.environ.get("PYTHONPATH", ""))
    return simgap_command.simgap(*args, env=env, timeout=300)


def test_an_experiment_on_the_cluster_resumes_after_sigkill_and_matches_a_local_run(cluster, tmp_path):
    spec = spec_file(tmp_path, SMALL)
    run_experiment(spec, tmp_path / "local", workers=2)
    local = store_rows(tmp_path / "local")
    assert len(local) == 3 and all(r["status"] == "ok" for r in local.values())

    # the driver, on the cluster address, killed between its first and its last run ...
    out = tmp_path / "cluster"
    env = dict(os.environ, PYTHONPATH=SRC + os.pathsep + os.environ.get("PYTHONPATH", ""))
    proc = simgap_command.start("experiment", "run", spec, "--out", out, "--workers", "1", "--executor", "ray",
                                "--address", cluster.address, "--no-report", "--no-validate", env=env)
    rows_dir = out / "store" / "rows"
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline and not (rows_dir.exists() and any(rows_dir.glob("*.parquet"))):
        time.sleep(0.02)
    os.killpg(proc.pid, signal.SIGKILL)
    proc.wait()
    before = store_rows(out)
    assert 1 <= len(before) < 3, "the kill came after the first and before the last run finished"
    # ... resumes through Ray Client: the runs it had are kept, the others run, none twice
    result = run_experiment(spec, out, workers=None, executor="ray", address=cluster.client)
    assert (result.skipped, result.ran, result.failed) == (len(before), 3 - len(before), 0)
    rows = store_rows(out)
    assert sorted(rows) == sorted(local)
    assert {k: r["fingerprint"] for k, r in rows.items()} == {k: r["fingerprint"] for k, r in local.items()}
    for row in rows.values():                           # the run directories came back to the driver
        record = read_run(out / row["run_dir"])
        assert record.fingerprint == row["fingerprint"]
        assert Path(record.settings.scenario_path).parent == out / "scenarios"
        assert (out / row["run_dir"] / "trajectories.parquet").stat().st_size > 1000
    assert not [p for p in (out / "runs").rglob(".*")]                                 # nothing half-written


def test_a_search_on_the_cluster_matches_a_local_one_through_both_address_forms(cluster, tmp_path):
    spec = spec_file(tmp_path, SEARCH)
    run_search(spec, tmp_path / "local", Budget(runs=2), workers=1)
    local = store_rows(tmp_path / "local" / "random")
    assert len(local) >= 2
    for form, address in (("gcs", cluster.address), ("client", cluster.client)):
        (result,) = run_search(spec, tmp_path / form, Budget(runs=2), workers=1, executor="ray", address=address)
        rows = store_rows(tmp_path / form / "random")
        assert result.runs == 2 and sorted(rows) == sorted(local), form
        assert {k: r["fingerprint"] for k, r in rows.items()} == {k: r["fingerprint"] for k, r in local.items()}


def test_a_worker_lost_mid_study_is_a_failed_run_with_its_reason_and_runs_again_on_resume(cluster, tmp_path):
    spec = spec_file(tmp_path, SMALL | {"parameters": {"radius": {"values": [20]}, "angle": {"values": [30]}},
                                        "fidelities": [{"backend": "mujoco"}]})
    out = tmp_path / "out"

    def kill_the_worker() -> None:        # the worker process running our run, found by its title
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline:
            found = subprocess.run(["pgrep", "-s", str(cluster.process.pid), "-f", "^ray::_ray_job"],
                                   capture_output=True, text=True).stdout.split()
            if found:
                for pid in found:
                    os.kill(int(pid), signal.SIGKILL)
                return
            time.sleep(0.05)

    killer = threading.Thread(target=kill_the_worker)
    killer.start()
    result = run_experiment(spec, out, workers=1, executor="ray", address=cluster.address)
    killer.join()
    (row,) = store_rows(out).values()
    assert result.failed == 1 and row["status"] == "failed" and row["failure"].startswith("worker died"), row
    assert len(experiment_status(out).left) == 1
    # resuming runs it again, now to the end
    again = run_experiment(spec, out, workers=1, executor="ray", address=cluster.address)
    (row,) = store_rows(out).values()
    assert (again.ran, again.failed, again.skipped) == (1, 0, 0) and row["status"] == "ok"


@pytest.mark.parametrize("form, command", [("127.0.0.1:{port}", ["experiment", "run", "EXPERIMENT"]),
                                           ("ray://127.0.0.1:{port}", ["search", "SEARCH", "--budget", "2"])])
def test_an_unreachable_cluster_is_a_one_line_error_before_anything_is_written(tmp_path, form, command):
    (port,) = free_ports(1)
    address = form.format(port=port)
    specs = {"EXPERIMENT": str(spec_file(tmp_path, SMALL)), "SEARCH": str(spec_file(tmp_path, SEARCH, "s.yaml"))}
    proc = simgap_cli(*[specs.get(a, a) for a in command], "--out", str(tmp_path / "out"),
                      "--executor", "ray", "--address", address)
    assert proc.returncode == 2
    assert "Traceback" not in proc.stdout + proc.stderr
    (line,) = proc.stderr.strip().splitlines()
    assert address in line and "nothing answers" in line and "ray start --head" in line
    assert proc.stdout.strip() == ""                                                # nor a progress bar
    assert not (tmp_path / "out").exists()


def test_a_cluster_whose_workers_cannot_import_simgap_is_refused_before_any_run(tmp_path):
    hidden = tmp_path / "hide-simgap"
    hidden.mkdir()
    (hidden / "sitecustomize.py").write_text(
        "import sys\n"
        "class Hide:\n"
        "    def find_spec(self, name, path=None, target=None):\n"
        "        if name == 'simgap' or name.startswith('simgap.'):\n"
        "            raise ModuleNotFoundError(\"No module named 'simgap'\", name=name)\n"
        "sys.meta_path.insert(0, Hide())\n")
    head = start_head(str(hidden), cpus=1)
    try:
        with pytest.raises(InputError) as err:
            run_search(spec_file(tmp_path, SEARCH), tmp_path / "out", Budget(runs=2), workers=1, executor="ray",
                       address=head.address)
    finally:
        stop_head(head)
    line = err.value.describe()
    assert head.address in line and "cannot import simgap" in line and "install simgap" in line, line
    assert not (tmp_path / "out").exists()


DRIVER = NodeSoftware("this driver", "3.11", "2.48.0", {"simgap": "0.1.0", "mujoco": "4.0.0"}, None, "abc")


@pytest.mark.parametrize("node, says", [
    (NodeSoftware("10.0.0.2", "3.10", "2.48.0", DRIVER.packages, None, "abc"), "runs Ray 2.48.0 on Python 3.10"),
    (NodeSoftware("10.0.0.2", "3.11", "2.47.1", DRIVER.packages, None, "abc"), "runs Ray 2.47.1"),
    (NodeSoftware("10.0.0.2", "3.11", "2.48.0", {"simgap": "0.1.0", "mujoco": "3.3.0"}, None, "abc"),
     "has mujoco 3.3.0 where this driver has 4.0.0"),
    (NodeSoftware("10.0.0.2", "3.11", "2.48.0", DRIVER.packages, None, "def"), "other simgap code"),
    (NodeSoftware("10.0.0.2", "3.11", "2.48.0", {}, "ModuleNotFoundError: No module named 'simgap'", ""),
     "cannot import simgap"),
])
def test_a_node_unlike_the_driver_is_refused_naming_it_and_what_to_do(node, says):
    with pytest.raises(InputError) as err:
        check_nodes("ray://head:10001", [DRIVER, node], DRIVER)
    text = err.value.describe()
    assert says in text and "10.0.0.2" in text and "ray://head:10001" in text and "install" in text
    assert "\n" not in text


def test_a_cluster_of_another_ray_or_python_is_refused_naming_both():
    ray_says = RuntimeError("Version mismatch: The cluster was started with:\n    Ray: 2.47.1\n    Python: 3.10.12\n"
                            "This process on node 10.0.0.9 was started with:\n    Ray: 2.48.0\n    Python: 3.11.7\n")
    text = connection_error("10.0.0.1:6379", ray_says).describe()
    assert "10.0.0.1:6379" in text and "runs Ray 2.47.1 on Python 3.10.12, this driver Ray 2.48.0" in text
    assert "install" in text and "\n" not in text


@pytest.mark.parametrize("address", ["head", "ray://head", "head:port", ":6379"])
def test_a_malformed_address_is_refused_naming_the_forms(tmp_path, address):
    with pytest.raises(InputError) as err:
        run_experiment(spec_file(tmp_path, SMALL), tmp_path / "out", workers=1, executor="ray", address=address)
    assert err.value.field == "address" and address in err.value.reason and "ray://HOST:PORT" in err.value.allowed
    assert not (tmp_path / "out").exists()
