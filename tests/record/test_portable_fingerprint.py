"""A run's fingerprint is its identity on any machine: the same under another BLAS kernel (as CI
machines of some processors set with OPENBLAS_CORETYPE), different for any real change."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from simgap.cosim.history import FINGERPRINT_QUANTA, History, quantised_states
from simgap.record import read_run
from simgap.trajectory import STATE_FIELDS, Trajectory

ROOT = Path(__file__).resolve().parents[2]

# Runs the paper's r = 20 m, 90 degree curve in the three worlds (each 5 s of simulated time, plans
# reaching the car after a fixed 0.1 s: a measured latency depends on the machine's load) and prints
# every run's two fingerprints as JSON.
PROBE = """
import json, sys
from pathlib import Path
from simgap.cosim import CosimSettings
from simgap.experiment.single_run import RunRequest, execute
out = Path(sys.argv[1])
prints = {}
for backend in ("ideal", "dynamic", "mujoco"):
    record = execute(RunRequest(Path(sys.argv[2]), backend=backend, cosim=CosimSettings(max_time_s=5.0, latency=0.1),
                                criticality=False), out / backend)
    prints[backend] = [record.fingerprint, record.machine_fingerprint]
print(json.dumps(prints))
"""


def _kernel(env: dict[str, str]) -> str:
    """The core type OpenBLAS runs under ``env`` (it says so with OPENBLAS_VERBOSE=2)."""
    proc = subprocess.run([sys.executable, "-c", "import numpy"], env=env | {"OPENBLAS_VERBOSE": "2"},
                          capture_output=True, text=True, check=True)
    return next((line.split(":", 1)[1].strip() for line in (proc.stdout + proc.stderr).splitlines()
                 if line.startswith("Core:")), "unknown")


@pytest.fixture(scope="module")
def curve(tmp_path_factory) -> Path:
    folder = tmp_path_factory.mktemp("curve")
    subprocess.run([sys.executable, "-m", "simgap", "generate", "curve", "--set", "radius=20", "--set", "angle=90",
                    "--no-preview", "--out", str(folder)], check=True, capture_output=True,
                   env=dict(os.environ, PYTHONPATH=str(ROOT / "src")))
    return folder / "curve_radius-20_angle-90.xml"


def test_the_fingerprint_is_equal_under_two_blas_kernels_in_every_world(curve, tmp_path):
    plain = {k: v for k, v in os.environ.items() if k not in ("OPENBLAS_CORETYPE", "OPENBLAS_L2_SIZE")}
    plain |= {"PYTHONPATH": str(ROOT / "src"), "MUJOCO_GL": os.environ.get("MUJOCO_GL", "egl")}
    default = _kernel(plain)
    other = plain | {"OPENBLAS_CORETYPE": "Sandybridge" if default.lower() == "haswell" else "Haswell"}
    assert _kernel(other) != default, "the probe needs two different kernels"
    prints = []
    for name, env in (("default", plain), ("other", other)):
        proc = subprocess.run([sys.executable, "-c", PROBE, str(tmp_path / name), str(curve)], env=env,
                              capture_output=True, text=True, timeout=300)
        assert proc.returncode == 0, proc.stderr[-2000:]
        prints.append(json.loads(proc.stdout.strip().splitlines()[-1]))
    for backend in ("ideal", "dynamic", "mujoco"):
        assert prints[0][backend][0] == prints[1][backend][0], (backend, default, other["OPENBLAS_CORETYPE"])
        # and the record on disk says the same as the run did
        assert read_run(tmp_path / "default" / backend).fingerprint == prints[0][backend][0]


def _history(**shifts: float) -> History:
    from simgap.cosim.history import AgentHistory, Outcome
    from simgap.sim.protocol import Realism
    from simgap.vehicles import load_vehicle

    n = 50
    columns = {f: np.linspace(0.0, 1.0 + i, n) for i, f in enumerate(STATE_FIELDS)}
    columns = {f: v + shifts.get(f, 0.0) for f, v in columns.items()}
    agent = AgentHistory(1, load_vehicle("sedan"), Outcome.GOAL_REACHED, Trajectory(0.1, **columns))
    return History("s", "ideal", 0.1, Realism.IDEAL, (agent,))


def test_last_bits_keep_the_fingerprint_and_a_quantum_changes_it():
    base = _history()
    assert _history(x=3e-11, yaw=-2e-11, v=1e-12).fingerprint == base.fingerprint
    assert _history(x=3e-11).machine_fingerprint != base.machine_fingerprint
    for f in STATE_FIELDS:
        assert _history(**{f: 1.5 * FINGERPRINT_QUANTA[f]}).fingerprint != base.fingerprint, f
    moved = replace(base, agents=(replace(base.agents[0], id=2),))
    assert moved.fingerprint != base.fingerprint


def test_the_quantisation_rule():
    q = quantised_states(np.array([0.5, 1.5, 2.5, -2.5, -0.0, 0.0, 0.4999, 2.7]), 1.0)
    assert q.tolist() == [0, 2, 2, -2, 0, 0, 0, 3]              # ties to even, -0 is 0
    special = quantised_states(np.array([np.nan, np.inf, -np.inf, 1e300]), 1e-6)
    assert len(set(special.tolist())) == 1 and special[0] == np.iinfo(np.int64).min
