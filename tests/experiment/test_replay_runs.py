"""A run replays from its record alone: seeds, and measured latencies as the record keeps them."""

from __future__ import annotations

import json
import os
import subprocess
from pathlib import Path

import pytest
import simgap_command

from simgap.record import read_run

ROOT = Path(__file__).resolve().parents[2]

# the Frenet planner, slow on every third call when the environment says so: as on a loaded machine,
# its plans then reach the car a cycle later (measured latency)
SLOW_PLANNER = """
import os, time
from simgap.planning.frenet import FrenetPlanner

class SometimesSlow(FrenetPlanner):
    def plan(self, observed, t, world):
        if os.environ.get("SIMGAP_TEST_LOADED") and round(t / world.dt) % 3 == 0:
            time.sleep(0.12)
        return super().plan(observed, t, world)
"""


def simgap(*args: str, cwd: Path, loaded: bool = False) -> subprocess.CompletedProcess:
    env = dict(os.environ)
    env.pop("SIMGAP_TEST_LOADED", None)
    if loaded:
        env["SIMGAP_TEST_LOADED"] = "1"
    return simgap_command.simgap(*args, cwd=cwd, env=env)


@pytest.fixture(scope="module")
def folder(tmp_path_factory) -> Path:
    folder = tmp_path_factory.mktemp("replay")
    assert simgap("generate", "curve", "--set", "radius=20", "--set", "angle=90", "--no-preview", "--out", "sc",
                  cwd=folder).returncode == 0
    (folder / "slow.py").write_text(SLOW_PLANNER)
    return folder


def _run(folder: Path, out: str, *extra: str, loaded: bool = False) -> dict:
    proc = simgap("run", "sc/curve_radius-20_angle-90.xml", "--backend", "mujoco", "--max-time", "3", "--no-validate",
                  "--json", "--out", out, *extra, cwd=folder, loaded=loaded)
    assert proc.returncode == 0, proc.stderr
    return json.loads(proc.stdout)


def test_a_seed_gives_one_run_and_another_seed_another(folder):
    fixed = ("--knob", "latency=0.1")          # a measured latency would make two fresh runs depend on the load
    three = _run(folder, "s3", "--seed", "3", *fixed)
    again = _run(folder, "s3-again", "--seed", "3", *fixed)
    four = _run(folder, "s4", "--seed", "4", *fixed)
    assert three["fingerprint"] == again["fingerprint"] != four["fingerprint"]
    assert three["seed"] == 3 and read_run(folder / "s4").settings.seed == 4
    replayed = simgap("replay", "s4", "--json", cwd=folder)
    assert replayed.returncode == 0, replayed.stderr
    verdict = json.loads(replayed.stdout)
    assert verdict["reproduced"] and verdict["replay_fingerprint"] == four["fingerprint"] and verdict["seed"] == 4


def test_a_run_made_on_a_loaded_machine_replays_exactly_on_an_idle_one(folder):
    loaded = _run(folder, "loaded", "--planner", "slow.py:SometimesSlow", "--seed", "1", loaded=True)
    record = read_run(folder / "loaded")
    assert max(record.history.agents[0].plan_latency_s) >= 0.2 - 1e-9      # the slow calls cost a cycle more
    idle = _run(folder, "idle", "--planner", "slow.py:SometimesSlow", "--seed", "1")
    assert idle["fingerprint"] != loaded["fingerprint"]                    # the load changed the run
    replayed = simgap("replay", "loaded", "--out", "replayed", cwd=folder)   # on the idle machine
    assert replayed.returncode == 0 and "reproduced: fingerprint " + loaded["fingerprint"] in replayed.stdout
    assert read_run(folder / "replayed").fingerprint == loaded["fingerprint"]


def test_a_replay_that_differs_says_where_and_exits_1(folder):
    _run(folder, "changed", "--seed", "2")
    run_json = folder / "changed" / "run.json"
    meta = json.loads(run_json.read_text())
    meta["settings"]["seed"] = 5                       # the record no longer says how the run was made
    run_json.write_text(json.dumps(meta))
    proc = simgap("replay", "changed", cwd=folder)
    assert proc.returncode == 1 and "not reproduced" in proc.stdout and "differs by up to" in proc.stdout
