"""Hostile-input sweep: what a careless or hostile user gives simgap, and what simgap does.

Every case builds what it needs in a folder of its own (scenario, spec, vehicle and planner files,
mutated as the case says), runs the real `simgap` command as a subprocess with a wall-time limit,
and sorts the outcome into one verdict:

    refusal        exit 2, one line on stderr naming the file/field, no traceback
    messy-refusal  exit 2, but several lines or the file/field not named
    recorded       the run (or experiment) was written with the failure's reason, exit 0/1
    handled        the case's expected good outcome was checked and holds (a capped plan, a
                   rerun after a deleted run, a whole report after SIGKILL, ...)
    traceback      a Python traceback reached the user
    hang           still running at the case's time limit (killed)
    silent-accept  exit 0 (or a result written) where the input should have been refused or failed
    data-loss      a result missing, half-written or lost (where checkable)
    other          anything else (see the note)
    skipped        the case could not be set up on this machine (e.g. no tmpfs mounts)

Each case has a short name and the number of the kind of hostile input it belongs to (its item). The sweep prints a table
(case, item, verdict, seconds, note), the counts per verdict, writes them as JSON with --json, and
exits 0: it is a benchmark, not a test.

Usage (from the repository root; run it niced, one case at a time):

    PYTHONPATH=src MUJOCO_GL=egl nice -n 5 python bench/robustness/hostile_inputs.py [--json FILE]
        [--only SUBSTRING ...] [--timeout 120] [--keep DIR] [--list]

--only runs the cases whose name contains one of the substrings; --keep leaves every case's
folder (stdout, stderr, files) in DIR; --list prints the cases and exits. Cases with a full or
read-only disk mount a small tmpfs (root only; skipped otherwise).
Every command runs under an 8 GB data limit (RLIMIT_DATA), so a memory bomb ends that command
and not the machine's other work.
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import os
import re
import resource
import shutil
import signal
import subprocess
import sys
import tempfile
import textwrap
import threading
import time
import xml.etree.ElementTree as ET
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import asdict, dataclass
from pathlib import Path

from simgap.files import BenchmarkResults

REPO = Path(__file__).resolve().parents[2]
SRC = REPO / "src"
TIMEOUT_S = 120.0
MEMORY_LIMIT_GB = 8.0      # each command's data limit: a memory bomb fails it instead of the machine

REFUSAL, MESSY, RECORDED, HANDLED = "refusal", "messy-refusal", "recorded", "handled"
TRACEBACK, HANG, SILENT, LOSS, OTHER, SKIPPED = "traceback", "hang", "silent-accept", "data-loss", "other", "skipped"
VERDICTS = (REFUSAL, MESSY, RECORDED, HANDLED, TRACEBACK, HANG, SILENT, LOSS, OTHER, SKIPPED)


# --------------------------------------------------------------------------------------------
# running the command

@dataclass
class Proc:
    """One finished (or killed) `simgap` process."""

    args: list[str]
    rc: int | None
    stdout: str
    stderr: str
    seconds: float
    timed_out: bool = False
    max_rss_mb: float = 0.0

    def stderr_lines(self) -> list[str]:
        return [line for line in self.stderr.splitlines() if line.strip()]


class Child:
    """A `simgap` process started in a session of its own (so a timeout kills its workers too)."""

    counter = 0

    def __init__(self, args: list[str], cwd: Path, env: dict | None = None, umask: int | None = None):
        Child.counter += 1
        self.args, self.cwd = [str(a) for a in args], cwd
        self.out_file = cwd / f".stdout-{Child.counter}"
        self.err_file = cwd / f".stderr-{Child.counter}"
        environment = dict(os.environ, PYTHONPATH=str(SRC))
        environment.setdefault("MUJOCO_GL", "egl")
        environment.update(env or {})
        environment = {k: v for k, v in environment.items() if v is not None}     # None: unset it
        self.start = time.monotonic()
        with self.out_file.open("w") as out, self.err_file.open("w") as err:
            self.popen = subprocess.Popen([sys.executable, "-m", "simgap", *self.args], cwd=cwd, stdout=out,
                                          stderr=err, env=environment, start_new_session=True,
                                          preexec_fn=lambda: _limits(umask))
        self.killed = False

    def kill(self) -> None:
        """SIGKILL the process and everything it started (its own process group)."""
        self.killed = True
        try:
            os.killpg(self.popen.pid, signal.SIGKILL)
        except ProcessLookupError:
            pass

    def wait(self, timeout: float | None = None) -> Proc:
        timer = threading.Timer(timeout or TIMEOUT_S, self.kill)
        timer.start()
        try:
            _, status, usage = os.wait4(self.popen.pid, 0)
        finally:
            timer.cancel()
        self.popen.returncode = rc = os.waitstatus_to_exitcode(status)
        return Proc(self.args, rc, self.out_file.read_text(errors="replace"), self.err_file.read_text(errors="replace"),
                    time.monotonic() - self.start, timed_out=self.killed, max_rss_mb=usage.ru_maxrss / 1024)


def _limits(umask: int | None) -> None:
    """In the child, before simgap starts: the memory limit, and the umask if asked."""
    limit = int(MEMORY_LIMIT_GB * 2**30)
    resource.setrlimit(resource.RLIMIT_DATA, (limit, limit))
    if umask is not None:
        os.umask(umask)


def simgap(*args, cwd: Path, env: dict | None = None, timeout: float | None = None, umask: int | None = None) -> Proc:
    return Child(list(args), cwd, env, umask).wait(timeout)


# --------------------------------------------------------------------------------------------
# judging an outcome

@dataclass
class Outcome:
    verdict: str
    note: str = ""
    stderr: str = ""
    seconds: float = 0.0


def problem(p: Proc) -> Outcome | None:
    """The verdict every case shares: a hang or a traceback, whatever was expected."""
    if p.timed_out:
        return Outcome(HANG, f"killed after {p.seconds:.0f} s", p.stderr)
    text = p.stdout + "\n" + p.stderr
    if "Traceback" in text:
        tail = [line for line in text.splitlines() if line.strip()]
        return Outcome(TRACEBACK, tail[-1][:200] if tail else "", p.stderr)
    return None


def refused(p: Proc, names: tuple[str, ...] = ()) -> Outcome | None:
    """Exit 2: a clean refusal when one line names every one of ``names``, messy otherwise."""
    if p.rc != 2:
        return None
    lines = p.stderr_lines()
    missing = [n for n in names if n not in p.stderr]
    if len(lines) == 1 and not missing:
        return Outcome(REFUSAL, lines[0][:160], p.stderr)
    why = f"{len(lines)} lines on stderr" if len(lines) != 1 else f"does not name {', '.join(missing)}"
    return Outcome(MESSY, f"{why}: {' '.join(lines)[:160]}", p.stderr)


def expect_refusal(p: Proc, *names: str) -> Outcome:
    """The input should have been refused (exit 2, one line naming ``names``)."""
    verdict = problem(p) or refused(p, names)
    if verdict:
        return verdict
    if p.rc == 0:
        return Outcome(SILENT, "exit 0: accepted", p.stderr)
    return Outcome(OTHER, f"exit {p.rc}: {' '.join(p.stderr_lines())[:160]}", p.stderr)


def run_record(out: Path) -> dict | None:
    """The run's record as `simgap run --json` prints it, with its events (None: none that reads)."""
    from simgap.errors import InputError
    from simgap.record import read_run
    try:
        record = read_run(out)
    except (InputError, OSError, ValueError):
        return None
    return record.summary() | {"events": [asdict(e) for e in record.history.events]}


def failure_reason(record: dict) -> str | None:
    """Why a run failed, as its record says (None when it records no failure)."""
    if record.get("failure"):
        return str(record["failure"])
    for agent in record.get("agents", []):
        if agent.get("outcome") != "goal_reached" or agent.get("planner_failures"):
            detail = next((e.get("detail") for e in record.get("events", []) if e.get("detail")), "")
            return f"agent {agent['id']} {agent.get('outcome')}: {detail}"
    return None


def expect_record(p: Proc, out: Path) -> Outcome:
    """The run should be written with the failure's reason (or refused before it ran)."""
    verdict = problem(p) or refused(p)
    if verdict:
        return verdict
    record = run_record(out)
    if record is None:
        return Outcome(LOSS, f"exit {p.rc}, no run.json written; stdout: {p.stdout.strip()[:80]!r}", p.stderr)
    reason = failure_reason(record)
    if reason:
        return Outcome(RECORDED, f"exit {p.rc}: {reason[:150]}", p.stderr)
    return Outcome(SILENT, f"exit {p.rc}: run recorded without a failure", p.stderr)


def expect(p: Proc, ok: bool, good: str, bad_verdict: str, bad: str) -> Outcome:
    """A case-specific check: HANDLED when ``ok``, else ``bad_verdict``."""
    verdict = problem(p)
    if verdict:
        return verdict
    return Outcome(HANDLED, good, p.stderr) if ok else Outcome(bad_verdict, bad, p.stderr)


# --------------------------------------------------------------------------------------------
# what the cases are built from

PLANNERS = '''
"""Hostile planners: each returns (or does) one thing a planner should not."""
import math
import os
import sys
import time

import numpy as np

from simgap.trajectory import State, Trajectory


def columns(observed, t, dt, n=31, speed=10.0):
    """A straight plan at ``speed`` along the car's heading, as mutable arrays."""
    k = np.arange(n, dtype=float)
    s = speed * dt * k
    return dict(t=t + dt * k, x=observed.x + s * math.cos(observed.yaw), y=observed.y + s * math.sin(observed.yaw),
                yaw=np.full(n, observed.yaw), v=np.full(n, speed), a=np.zeros(n), yaw_rate=np.zeros(n),
                steer=np.zeros(n))


def mutated(observed, t, dt, change, n=31, plan_dt=None):
    c = columns(observed, t, plan_dt or dt, n)
    change(c)
    return Trajectory(plan_dt or dt, **c)


class NaN:
    def plan(self, observed, t, world):
        return mutated(observed, t, world.dt, lambda c: c["x"].__setitem__(1, float("nan")))

class Inf:
    def plan(self, observed, t, world):
        return mutated(observed, t, world.dt, lambda c: c["v"].__setitem__(-1, float("inf")))

class Dict:
    def plan(self, observed, t, world):
        return {"x": [1, 2], "y": [0, 0]}

class Str:
    def plan(self, observed, t, world):
        return "forward"

class List:
    def plan(self, observed, t, world):
        return [observed, observed]

class Array:
    def plan(self, observed, t, world):
        return np.zeros((31, 8))

class NoneAlways:
    def plan(self, observed, t, world):
        return None

class OneState:
    def plan(self, observed, t, world):
        return mutated(observed, t, world.dt, lambda c: None, n=1)

class StartsLate:
    def plan(self, observed, t, world):
        return mutated(observed, t + 1.0, world.dt, lambda c: None)

class OtherGrid:
    def plan(self, observed, t, world):
        return mutated(observed, t, world.dt, lambda c: None, plan_dt=2 * world.dt)

class OffGrid:
    def plan(self, observed, t, world):
        return mutated(observed, t, world.dt, lambda c: c["t"].__setitem__(slice(10, None), c["t"][10:] + 0.37 * world.dt))

class Backwards:
    def plan(self, observed, t, world):
        return mutated(observed, t, world.dt, lambda c: None, plan_dt=-world.dt)

class Teleport:
    def plan(self, observed, t, world):
        return mutated(observed, t, world.dt, lambda c: c["x"].__setitem__(slice(1, None), 1e300))

class Lightspeed:
    def plan(self, observed, t, world):
        return mutated(observed, t, world.dt, lambda c: c["v"].__setitem__(slice(None), 1e300))

class Huge:
    def plan(self, observed, t, world):
        return mutated(observed, t, world.dt, lambda c: None, n=1_000_000)

class Raises:
    def plan(self, observed, t, world):
        raise ValueError("hostile planner")

class Recurses:
    def plan(self, observed, t, world):
        return self.plan(observed, t, world)

class Exits:
    def plan(self, observed, t, world):
        sys.exit(3)

class HardExit:
    def plan(self, observed, t, world):
        os._exit(0)

class Interrupts:
    def plan(self, observed, t, world):
        raise KeyboardInterrupt

class ExitsWhenBuilt:
    def __init__(self):
        sys.exit(3)
    def plan(self, observed, t, world):
        return None

class CustomBase(BaseException):
    pass

class RaisesBase:
    def plan(self, observed, t, world):
        raise CustomBase("not an Exception")

class NeverReturns:
    def plan(self, observed, t, world):
        while True:
            time.sleep(0.01)

class BusyForever:
    def plan(self, observed, t, world):
        while True:
            pass

class Slow:
    def plan(self, observed, t, world):
        time.sleep(1.0)
        return mutated(observed, t, world.dt, lambda c: None)

class Stands:
    def plan(self, observed, t, world):
        return Trajectory(world.dt, **columns(observed, t, world.dt, speed=0.0))

def not_a_class(observed, t, world):
    return None
'''

SPEC_TWO_RUNS = """name: two
logical: curve
parameters: {radius: {values: [50, 100]}, angle: {values: [30]}}
fidelities: [{backend: ideal}]
cosim: {replan_every: 3}
"""

ALIAS_BOMB = "\n".join(["a0: &a0 [lol, lol, lol, lol, lol, lol, lol, lol, lol]"]
                       + [f"a{i}: &a{i} [{', '.join([f'*a{i - 1}'] * 9)}]" for i in range(1, 12)]) + "\n"


class Stock:
    """What many cases share, built once in the sweep's folder: a scenario, the planners, a run,
    the sedan's data file."""

    def __init__(self, root: Path):
        self.root = root
        self._scenario: Path | None = None
        self._run: Path | None = None

    @property
    def scenario(self) -> Path:
        if self._scenario is None:
            folder = self.root / "stock"
            folder.mkdir(exist_ok=True)
            p = simgap("generate", "curve", "--set", "radius=50", "--set", "angle=30", "--no-preview",
                       "--out", folder / "scenarios", cwd=folder)
            assert p.rc == 0, p.stderr
            self._scenario = folder / "scenarios" / "curve_radius-50_angle-30.xml"
        return self._scenario

    @property
    def run(self) -> Path:
        if self._run is None:
            out = self.root / "stock" / "run"
            p = simgap("run", self.scenario, "--no-validate", "--replan-every", "3", "--out", out, cwd=self.root)
            assert p.rc == 0, p.stderr
            self._run = out
        return self._run

    def planners(self, folder: Path) -> Path:
        path = folder / "hostile.py"
        path.write_text(PLANNERS)
        return path

    @staticmethod
    def sedan_text() -> str:
        return (SRC / "simgap" / "vehicles" / "data" / "sedan.yaml").read_text()


def mutate_xml(source: Path, target: Path, change: Callable[[ET.Element], None]) -> Path:
    tree = ET.parse(source)
    change(tree.getroot())
    tree.write(target, encoding="UTF-8", xml_declaration=True)
    return target


def set_text(path: str, value: str) -> Callable[[ET.Element], None]:
    def change(root: ET.Element) -> None:
        root.find(path).text = value
    return change


def set_attr(name: str, value: str) -> Callable[[ET.Element], None]:
    return lambda root: root.set(name, value)


def zero_width_lanelet(root: ET.Element) -> None:
    lanelet = root.find("lanelet")
    right = lanelet.find("rightBound")
    for point, left in zip(right.findall("point"), lanelet.find("leftBound").findall("point")):
        point.find("x").text, point.find("y").text = left.find("x").text, left.find("y").text


def start_after_goal(root: ET.Element) -> None:
    root.find("planningProblem/initialState/time/exact").text = "700"


def goal_window_huge(root: ET.Element) -> None:
    root.find("planningProblem/goalState/time/intervalEnd").text = "2000000000"


def static_obstacles(count: int, far: bool = True) -> Callable[[ET.Element], None]:
    def change(root: ET.Element) -> None:
        problem_at = list(root).index(root.find("planningProblem"))
        for i in range(count):
            x, y = (5000.0 + 10 * (i % 200), 5000.0 + 10 * (i // 200)) if far else (150.0 + i, 60.0)
            obstacle = ET.fromstring(
                f"<staticObstacle id='{5_000_000 + i}'><type>parkedVehicle</type><shape><rectangle>"
                f"<length>4.0</length><width>2.0</width></rectangle></shape><initialState><position><point>"
                f"<x>{x}</x><y>{y}</y></point></position><orientation><exact>0.0</exact></orientation>"
                f"<time><exact>0</exact></time><velocity><exact>0.0</exact></velocity><acceleration><exact>0.0"
                f"</exact></acceleration><yawRate><exact>0.0</exact></yawRate><slipAngle><exact>0.0</exact>"
                f"</slipAngle></initialState></staticObstacle>")
            root.insert(problem_at + i, obstacle)
    return change


INITIAL = "planningProblem/initialState"
XML_CASES = [  # name, item, change, what the refusal should name
    ("dt-zero", 2, set_attr("timeStepSize", "0"), ("timeStepSize",)),
    ("dt-negative", 2, set_attr("timeStepSize", "-0.1"), ("timeStepSize",)),
    ("dt-nan", 2, set_attr("timeStepSize", "nan"), ("timeStepSize",)),
    ("dt-inf", 2, set_attr("timeStepSize", "inf"), ("timeStepSize",)),
    ("dt-text", 2, set_attr("timeStepSize", "fast"), ()),
    ("v0-nan", 3, set_text(f"{INITIAL}/velocity/exact", "nan"), ("velocity",)),
    ("v0-negative", 3, set_text(f"{INITIAL}/velocity/exact", "-5"), ("velocity",)),
    ("v0-1e300", 3, set_text(f"{INITIAL}/velocity/exact", "1e300"), ("velocity",)),
    ("v0-inf", 3, set_text(f"{INITIAL}/velocity/exact", "inf"), ("velocity",)),
    ("yaw0-nan", 3, set_text(f"{INITIAL}/orientation/exact", "nan"), ("orientation",)),
    ("x0-nan", 3, set_text(f"{INITIAL}/position/point/x", "nan"), ("position",)),
    ("start-after-goal-window", 3, start_after_goal, ("time",)),
    ("zero-width-lanelet", 3, zero_width_lanelet, ("lanelet",)),
    ("lanelet-nan-coordinate", 3, set_text("lanelet/leftBound/point/x", "nan"), ("lanelet",)),
]

VEHICLE_CASES = [  # name, old text, new text, field the refusal should name, backend
    ("vehicle-width-400", "width: 1.610", "width: 400", "width", "ideal"),
    ("vehicle-power-1e15", "max_power: 115000.0", "max_power: 1.0e15", "max_power", "dynamic"),
    ("vehicle-rear-axle-50", "rear_axle_to_center: 1.4227", "rear_axle_to_center: 50", "rear_axle_to_center",
     "mujoco"),
    ("vehicle-mass-nan", "mass: 1093.3", "mass: .nan", "mass", "dynamic"),
    ("vehicle-mass-negative", "mass: 1093.3", "mass: -1000", "mass", "dynamic"),
    ("vehicle-wheelbase-40", "wheelbase: 2.578766", "wheelbase: 40", "wheelbase", "ideal"),
    ("vehicle-top-speed-1e300", "max_speed: 50.8", "max_speed: 1.0e300", "max_speed", "ideal"),
]

PLANNER_CASES = [  # name, item, class, extra run options, what is expected
    ("plan-nan", 1, "NaN", (), "record"),
    ("plan-inf", 1, "Inf", (), "record"),
    ("plan-dict", 1, "Dict", (), "record"),
    ("plan-string", 1, "Str", (), "record"),
    ("plan-list", 1, "List", (), "record"),
    ("plan-ndarray", 1, "Array", (), "record"),
    ("plan-none", 1, "NoneAlways", (), "record"),
    ("plan-one-state", 1, "OneState", (), "record"),
    ("plan-starts-late", 1, "StartsLate", (), "record"),
    ("plan-other-grid", 1, "OtherGrid", (), "record"),
    ("plan-off-grid", 1, "OffGrid", (), "record"),
    ("plan-backwards-dt", 1, "Backwards", (), "record"),
    ("plan-teleport-1e300", 1, "Teleport", (), "record"),
    ("plan-speed-1e300", 1, "Lightspeed", (), "record"),
    ("plan-raises", 1, "Raises", (), "record"),
    ("plan-recursion", 1, "Recurses", (), "record"),
    ("planner-sys-exit", 9, "Exits", (), "record"),
    ("planner-os-exit-0", 9, "HardExit", (), "record"),
    ("planner-keyboard-interrupt", 9, "Interrupts", (), "record"),
    ("planner-exit-in-constructor", 9, "ExitsWhenBuilt", (), "record"),
    ("planner-base-exception", 9, "RaisesBase", (), "record"),
    ("plan-never-returns", 4, "NeverReturns", ("--run-timeout", "3"), "record"),
    ("plan-never-returns-budget", 4, "NeverReturns", ("--planning-budget", "0.1", "--run-timeout", "3"), "record"),
    ("plan-busy-loop", 4, "BusyForever", ("--run-timeout", "3"), "record"),
    ("plan-slow", 4, "Slow", ("--run-timeout", "4"), "record"),
]

RUN_OPTION_CASES = [  # name, item, options, what the refusal should name
    ("max-time-inf", 4, ("--max-time", "inf"), ("max_time",)),
    ("max-time-nan", 4, ("--max-time", "nan"), ("max_time",)),
    ("max-time-1e9", 4, ("--max-time", "1e9"), ("max_time",)),
    ("max-time-negative", 4, ("--max-time", "-1"), ("max_time",)),
    ("run-timeout-inf", 4, ("--run-timeout", "inf"), ("run-timeout",)),
    ("run-timeout-zero", 4, ("--run-timeout", "0"), ("run-timeout",)),
    ("run-timeout-nan", 4, ("--run-timeout", "nan"), ("run-timeout",)),
    ("planning-budget-nan", 4, ("--planning-budget", "nan"), ("planning_budget",)),
    ("knob-friction-nan", 3, ("--backend", "dynamic", "--knob", "road_friction=nan"), ("road_friction",)),
    ("road-friction-negative", 3, ("--backend", "mujoco", "--road-friction", "-1"), ("road_friction",)),
    ("controller-hz-inf", 3, ("--backend", "dynamic", "--controller-hz", "inf"), ("controller_hz",)),
    ("planner-map-twice", 5, ("--planner", "1=frenet,1=idm"), ("planner",)),
    ("planner-map-no-agent", 5, ("--planner", "7=idm"), ("planner",)),
    ("vehicle-map-agent-0", 5, ("--vehicle", "0=suv,1=sedan"), ("vehicle",)),
    ("vehicle-map-twice", 5, ("--vehicle", "1=sedan,1=suv"), ("vehicle",)),
]

LOGICAL = """name: hostile
template: curve
fixed: {fixed}
parameters:
  radius: {{unit: m, min: 10, max: 100, default: 50}}
  angle: {{unit: deg, min: -90, max: 90, default: 30}}
"""
LOGICAL_CASES = [  # name, item, logical YAML, what the refusal should name
    ("logical-dt-zero", 2, LOGICAL.format(fixed="{dt: 0, straight_length: 100}"), ("dt",)),
    ("logical-dt-negative", 2, LOGICAL.format(fixed="{dt: -0.1, straight_length: 100}"), ("dt",)),
    ("logical-dt-nan", 2, LOGICAL.format(fixed="{dt: .nan, straight_length: 100}"), ("dt",)),
    ("road-1e9-m", 4, LOGICAL.format(fixed="{straight_length: 1.0e+9}"), ("straight_length",)),
    ("junction-approach-1e9-m", 4, "name: long\ntemplate: t-junction\nfixed: {approach_length: 1.0e+9}\n"
     "parameters:\n  lane_width: {unit: m, min: 2.5, max: 5, default: 3.0}\n", ("approach_length",)),
    ("logical-duplicate-key", 5, LOGICAL.format(fixed="{straight_length: 100}") + "name: again\n", ("twice",)),
    ("logical-alias-bomb", 8, ALIAS_BOMB, ("alias",)),
    ("logical-python-tag", 8, "name: !!python/object/apply:os.system ['echo pwned > pwned.txt']\n"
     "template: curve\n", ()),
    ("logical-name-dotdot", 8, LOGICAL.format(fixed="{straight_length: 100}").replace("name: hostile",
                                                                                     "name: ../../escaped"), ()),
]

SPEC_CASES = [  # name, item, experiment spec YAML, what the refusal should name
    ("spec-fidelity-twice", 5, SPEC_TWO_RUNS.replace("[{backend: ideal}]", "[{backend: ideal}, {backend: ideal}]"),
     ("fidelities",)),
    ("spec-vehicle-twice", 5, SPEC_TWO_RUNS.replace("[{backend: ideal}]",
                                                   "[{backend: dynamic, vehicles: [sedan, sedan]}]"), ("fidelities",)),
    ("spec-duplicate-key", 5, SPEC_TWO_RUNS + "name: again\n", ("twice",)),
    ("spec-duplicate-nested-key", 5, SPEC_TWO_RUNS.replace("{replan_every: 3}", "{replan_every: 3, replan_every: 1}"),
     ("twice",)),
    ("spec-alias-bomb", 8, ALIAS_BOMB, ("alias",)),
    ("spec-random-100000", 8, SPEC_TWO_RUNS.replace("parameters: {radius: {values: [50, 100]}, angle: {values: [30]}}",
                                                    "sampler: {kind: random, samples: 100000}"), ("samples",)),
    ("spec-grid-40000", 8, SPEC_TWO_RUNS.replace(
        "{radius: {values: [50, 100]}, angle: {values: [30]}}",
        json.dumps({"radius": {"values": [10 + i * 0.4 for i in range(200)]},       # JSON: YAML's flow form
                    "angle": {"values": [-80 + i * 0.8 for i in range(200)]}})),
     ()),
    ("spec-run-timeout-inf", 4, SPEC_TWO_RUNS + "run_timeout_s: .inf\n", ("run_timeout_s",)),
    ("spec-repeats-1e9", 8, SPEC_TWO_RUNS + "repeats: 1000000000\n", ("repeats",)),
]

QUERY_CASES = [  # name, SQL, a file it must not have written (relative to the case folder)
    ("query-copy-to", "COPY runs TO '{folder}/leak.csv'", "leak.csv"),
    ("query-read-csv", "SELECT * FROM read_csv('/etc/passwd')", None),
    ("query-read-text", "SELECT * FROM read_text('/etc/hostname')", None),
    ("query-attach", "ATTACH '{folder}/other.db' AS other", "other.db"),
    ("query-create-table", "CREATE TABLE t AS SELECT 1 AS x", None),
    ("query-bad-sql", "SELEKT nothing", None),
]


# --------------------------------------------------------------------------------------------
# the cases

@dataclass
class Case:
    name: str
    item: int
    run: Callable[[Path, Stock], Outcome]


CASES: list[Case] = []


def case(name: str, item: int):
    def register(fn: Callable[[Path, Stock], Outcome]) -> Callable[[Path, Stock], Outcome]:
        CASES.append(Case(name, item, fn))
        return fn
    return register


def _xml_case(change, names):
    def run(folder: Path, stock: Stock) -> Outcome:
        xml = mutate_xml(stock.scenario, folder / "hostile.xml", change)
        return expect_refusal(simgap("run", xml, "--no-validate", "--out", folder / "r", cwd=folder),
                              "hostile.xml", *names)
    return run


def _vehicle_case(old, new, field_name, backend):
    def run(folder: Path, stock: Stock) -> Outcome:
        text = stock.sedan_text()
        assert old in text, old
        (folder / "absurd.yaml").write_text(text.replace(old, new, 1))
        return expect_refusal(simgap("run", stock.scenario, "--backend", backend, "--no-validate", "--vehicle",
                                     folder / "absurd.yaml", "--out", folder / "r", cwd=folder),
                              "absurd.yaml", field_name)
    return run


def _planner_case(cls, options):
    def run(folder: Path, stock: Stock) -> Outcome:
        planners = stock.planners(folder)
        p = simgap("run", stock.scenario, "--no-validate", "--planner", f"{planners}:{cls}", *options,
                   "--out", folder / "r", cwd=folder)
        return expect_record(p, folder / "r")
    return run


def _option_case(options, names):
    def run(folder: Path, stock: Stock) -> Outcome:
        return expect_refusal(simgap("run", stock.scenario, "--no-validate", *options, "--out", folder / "r",
                                     cwd=folder), *names)
    return run


def _logical_case(text, names):
    def run(folder: Path, stock: Stock) -> Outcome:
        (folder / "logical.yaml").write_text(text)
        p = simgap("generate", folder / "logical.yaml", "--no-preview", "--out", folder / "out", cwd=folder)
        if (folder / "pwned.txt").exists():
            return Outcome(SILENT, "the YAML tag ran a command", p.stderr, p.seconds)
        escaped = [x for x in folder.parent.glob("*escaped*")]
        if escaped:
            return Outcome(LOSS, f"wrote outside --out: {escaped[0]}", p.stderr, p.seconds)
        return expect_refusal(p, "logical.yaml", *names)
    return run


def _spec_case(text, names):
    def run(folder: Path, stock: Stock) -> Outcome:
        (folder / "spec.yaml").write_text(text)
        p = simgap("experiment", "run", folder / "spec.yaml", "--out", folder / "exp", "--workers", "1",
                   "--no-report", "--no-validate", cwd=folder, timeout=60)
        outcome = expect_refusal(p, "spec.yaml", *names)
        written = list((folder / "exp" / "scenarios").glob("*.xml")) if (folder / "exp").exists() else []
        if written and outcome.verdict not in (REFUSAL, MESSY):
            outcome.note += f"; {len(written)} scenario files written"
        return outcome
    return run


def _store_state(exp: Path) -> dict:
    return {str(f): (f.stat().st_size, f.stat().st_mtime_ns) for f in exp.rglob("*") if f.is_file()}


def _query_case(sql, forbidden):
    def run(folder: Path, stock: Stock) -> Outcome:
        exp = experiment(folder)
        stored = _store_state(exp)
        p = simgap("experiment", "query", exp, sql.format(folder=folder), cwd=folder)
        if forbidden and (folder / forbidden).exists():
            return Outcome(SILENT, f"the query wrote {forbidden}", p.stderr, p.seconds)
        if p.rc == 0 and not forbidden and "passwd" not in sql and stored == _store_state(exp):
            return Outcome(HANDLED, "exit 0, ran in memory only: the store's files are unchanged", p.stderr, p.seconds)
        if "passwd" in sql and "root:" in p.stdout:
            return Outcome(SILENT, "the query read /etc/passwd", p.stderr, p.seconds)
        return expect_refusal(p, "SQL")
    return run


for _name, _item, _change, _names in XML_CASES:
    case(_name, _item)(_xml_case(_change, _names))
for _name, _old, _new, _field, _backend in VEHICLE_CASES:
    case(_name, 3)(_vehicle_case(_old, _new, _field, _backend))
for _name, _item, _cls, _options, _ in PLANNER_CASES:
    case(_name, _item)(_planner_case(_cls, _options))
for _name, _item, _options, _names in RUN_OPTION_CASES:
    case(_name, _item)(_option_case(_options, _names))
for _name, _item, _text, _names in LOGICAL_CASES:
    case(_name, _item)(_logical_case(_text, _names))
for _name, _item, _text, _names in SPEC_CASES:
    case(_name, _item)(_spec_case(_text, _names))
for _name, _sql, _forbidden in QUERY_CASES:
    case(_name, 10)(_query_case(_sql, _forbidden))


def experiment(folder: Path, spec: str = SPEC_TWO_RUNS, name: str = "exp") -> Path:
    """A finished two-run ideal experiment in ``folder/name``."""
    (folder / "spec.yaml").write_text(spec)
    p = simgap("experiment", "run", folder / "spec.yaml", "--out", folder / name, "--workers", "1", "--no-report",
               "--no-validate", cwd=folder)
    assert p.rc == 0, p.stderr
    return folder / name


# ---- item 1: a plan that is long but valid is cut, not stored whole

@case("plan-1e6-states", 1)
def _(folder: Path, stock: Stock) -> Outcome:
    planners = stock.planners(folder)
    p = simgap("run", stock.scenario, "--no-validate", "--planner", f"{planners}:Huge", "--max-time", "3",
               "--out", folder / "r", cwd=folder)
    size = sum(f.stat().st_size for f in (folder / "r").glob("*")) / 1e6 if (folder / "r").exists() else 0
    small = run_record(folder / "r") is not None and size < 50 and p.max_rss_mb < 4000
    return expect(p, small, f"run of {size:.1f} MB, peak RSS {p.max_rss_mb:.0f} MB", SILENT,
                  f"exit {p.rc}: run of {size:.1f} MB, peak RSS {p.max_rss_mb:.0f} MB")


# ---- item 4: runs without an end

@case("goal-window-2e9-steps", 4)
def _(folder: Path, stock: Stock) -> Outcome:
    xml = mutate_xml(stock.scenario, folder / "long.xml", goal_window_huge)
    planners = stock.planners(folder)
    p = simgap("run", xml, "--no-validate", "--planner", f"{planners}:Stands", "--replan-every", "10",
               "--out", folder / "r", cwd=folder)
    record = run_record(folder / "r")
    return expect(p, record is not None, f"ended by itself after {p.seconds:.0f} s: {failure_reason(record or {})}",
                  LOSS, f"exit {p.rc}, no run.json")


@case("obstacles-20000-far", 4)
def _(folder: Path, stock: Stock) -> Outcome:
    xml = mutate_xml(stock.scenario, folder / "crowded.xml", static_obstacles(20000))
    p = simgap("run", xml, "--no-validate", "--replan-every", "3", "--max-time", "20", "--out", folder / "r",
               cwd=folder)
    record = run_record(folder / "r")
    return expect(p, record is not None, f"ran in {p.seconds:.0f} s", LOSS, f"exit {p.rc}, no run.json")


@case("dt-1e-9", 2)
def _(folder: Path, stock: Stock) -> Outcome:
    xml = mutate_xml(stock.scenario, folder / "tiny.xml", set_attr("timeStepSize", "1e-9"))
    p = simgap("run", xml, "--no-validate", "--out", folder / "r", cwd=folder)
    verdict = problem(p) or refused(p)
    if verdict:
        return verdict
    record = run_record(folder / "r")
    if record is None:
        return Outcome(LOSS, f"exit {p.rc}, no run.json", p.stderr)
    return Outcome(SILENT if p.rc == 0 else RECORDED, f"exit {p.rc}: ran a 1 ns step: {failure_reason(record)}",
                   p.stderr)


@case("experiment-planner-hang", 4)
def _(folder: Path, stock: Stock) -> Outcome:
    planners = stock.planners(folder)
    spec = SPEC_TWO_RUNS + f"run_timeout_s: 2\nplanners: ['{planners}:NeverReturns']\n"
    (folder / "spec.yaml").write_text(spec)
    p = simgap("experiment", "run", folder / "spec.yaml", "--out", folder / "exp", "--workers", "1", "--no-report",
               "--no-validate", cwd=folder)
    ok = "2 ran now (2 failed)" in " ".join(p.stdout.split())
    return expect(p, ok, "both runs recorded as failed", OTHER, f"exit {p.rc}: {' '.join(p.stdout.split())[:160]}")


# ---- item 5: the store

def _truncate_first_row(exp: Path) -> Path:
    row = sorted((exp / "store" / "rows").glob("*.parquet"))[0]
    row.write_bytes(row.read_bytes()[:100])
    return row


@case("store-truncated-row-status", 5)
def _(folder: Path, stock: Stock) -> Outcome:
    exp = experiment(folder)
    row = _truncate_first_row(exp)
    p = simgap("experiment", "status", exp, cwd=folder)
    ok = p.rc == 0 and row.name in p.stdout and "1 done" in p.stdout and "1 left" in p.stdout
    return expect(p, ok, "named the row, counted its run as left", OTHER, f"exit {p.rc}: {p.stdout.strip()[:160]}")


@case("store-truncated-row-query", 5)
def _(folder: Path, stock: Stock) -> Outcome:
    exp = experiment(folder)
    row = _truncate_first_row(exp)
    p = simgap("experiment", "query", exp, "SELECT count(*) AS n FROM runs", cwd=folder)
    ok = p.rc == 0 and row.name in p.stdout + p.stderr
    return expect(p, ok, "named the row, queried the rest", OTHER, f"exit {p.rc}: {p.stderr.strip()[:160]}")


@case("store-truncated-row-resume", 5)
def _(folder: Path, stock: Stock) -> Outcome:
    exp = experiment(folder)
    _truncate_first_row(exp)
    p = simgap("experiment", "run", folder / "spec.yaml", "--out", exp, "--workers", "1", "--no-report",
               "--no-validate", cwd=folder)
    after = simgap("experiment", "status", exp, cwd=folder)
    ok = "1 ran now" in " ".join(p.stdout.split()) and "2 done" in after.stdout
    return expect(p, ok, "reran the run of the cut row; 2 done", LOSS, f"exit {p.rc}: {after.stdout.strip()[:160]}")


@case("store-deleted-run-dir", 5)
def _(folder: Path, stock: Stock) -> Outcome:
    exp = experiment(folder)
    gone = sorted((exp / "runs").iterdir())[0]
    shutil.rmtree(gone)
    status = simgap("experiment", "status", exp, cwd=folder)
    p = simgap("experiment", "run", folder / "spec.yaml", "--out", exp, "--workers", "1", "--no-validate",
               cwd=folder)
    report = exp / "report" / "index.html"
    ok = "1 left" in status.stdout and any(gone.rglob("run.json")) and report.exists()
    return expect(p, ok, "status saw it, resume reran it, report whole", LOSS,
                  f"status: {status.stdout.strip()[:100]}; run.json back: {any(gone.rglob('run.json'))}")


@case("store-two-writers", 5)
def _(folder: Path, stock: Stock) -> Outcome:
    spec = SPEC_TWO_RUNS.replace("[50, 100]", "[20, 50, 100]").replace("[30]", "[30, 60]")
    (folder / "spec.yaml").write_text(spec)
    args = ("experiment", "run", folder / "spec.yaml", "--out", folder / "exp", "--workers", "1", "--no-report",
            "--no-validate")
    first = Child(list(args), folder)
    deadline = time.monotonic() + 30
    while not (folder / "exp" / "runs").exists() and time.monotonic() < deadline:
        time.sleep(0.2)
    second = simgap(*args, cwd=folder)
    done = first.wait()
    verdict = problem(done) or problem(second)
    if verdict:
        return verdict
    ran = " ".join(done.stdout.split())
    if "6 ran now" not in ran:
        return Outcome(LOSS, f"first run: {ran[:120]}", done.stderr)
    return refused(second, ("another",)) or Outcome(SILENT, f"second run exit {second.rc}: "
                                                    f"{' '.join(second.stdout.split())[:120]}", second.stderr)


@case("search-strategy-twice", 5)
def _(folder: Path, stock: Stock) -> Outcome:
    (folder / "search.yaml").write_text(
        "name: t\nlogical: curve\nparameters: {radius: {min: 10, max: 50}}\n"
        "ladder: [{backend: ideal}, {backend: dynamic}]\nstrategies: [grid, grid]\n")
    return expect_refusal(simgap("search", folder / "search.yaml", "--budget", "2", "--out", folder / "s",
                                 "--no-report", cwd=folder, timeout=60), "search.yaml", "strategies")


@case("planner-config-duplicate-key", 5)
def _(folder: Path, stock: Stock) -> Outcome:
    (folder / "planner.yaml").write_text("speed: {cruise_m_s: 8}\nspeed: {cruise_m_s: 12}\n")
    return expect_refusal(simgap("run", stock.scenario, "--planner-config", folder / "planner.yaml", "--out",
                                 folder / "r", cwd=folder), "planner.yaml", "twice")


# ---- item 6: outputs and environment

OUT_IS_FILE = [  # name, the command before --out (STOCK_RUN / SCENARIO stand for the stock's)
    ("out-file-generate", ["generate", "curve"]),
    ("out-file-experiment", ["experiment", "run", "demo"]),
    ("out-file-search", ["search", "curve-gaps", "--budget", "2"]),
    ("out-file-demo", ["demo"]),
    ("out-file-report", ["report", "STOCK_RUN"]),
    ("out-file-run", ["run", "SCENARIO", "--no-validate"]),
    ("out-file-render", ["render", "STOCK_RUN"]),
    ("out-file-compare", ["compare", "STOCK_RUN", "STOCK_RUN"]),
    ("out-file-export", ["export", "STOCK_RUN"]),
]


def _out_is_file(command):
    def run(folder: Path, stock: Stock) -> Outcome:
        notes = folder / "notes.txt"
        notes.write_text("mine")
        args = [stock.run if a == "STOCK_RUN" else stock.scenario if a == "SCENARIO" else a for a in command]
        p = simgap(*args, "--out", notes, cwd=folder, timeout=60)
        if notes.read_text() != "mine":
            return Outcome(LOSS, "the user's file was overwritten", p.stderr, p.seconds)
        return expect_refusal(p, "notes.txt")
    return run


for _name, _command in OUT_IS_FILE:
    case(_name, 6)(_out_is_file(_command))


@case("out-300-char-name-generate", 6)
def _(folder: Path, stock: Stock) -> Outcome:
    return expect_refusal(simgap("generate", "curve", "--out", folder / ("d" * 300), cwd=folder), "300")


@case("out-300-char-name-run", 6)
def _(folder: Path, stock: Stock) -> Outcome:
    return expect_refusal(simgap("run", stock.scenario, "--out", folder / ("d" * 300), cwd=folder), "300")


@case("mujoco-gl-bogus-render-3d", 6)
def _(folder: Path, stock: Stock) -> Outcome:
    p = simgap("render", stock.run, "--3d", "--out", folder / "pictures", cwd=folder, env={"MUJOCO_GL": "bogus"})
    outcome = expect_refusal(p, "MUJOCO_GL")
    if (folder / "pictures").exists() and outcome.verdict == REFUSAL:
        return Outcome(LOSS, "refused but left an output folder", p.stderr, p.seconds)
    return outcome


@case("mujoco-gl-bogus-run", 6)
def _(folder: Path, stock: Stock) -> Outcome:
    return expect_refusal(simgap("run", stock.scenario, "--backend", "mujoco", "--out", folder / "r", cwd=folder,
                                 env={"MUJOCO_GL": "bogus"}), "MUJOCO_GL")


@contextmanager
def tmpfs(path: Path, options: str) -> Iterator[bool]:
    """``path`` as a tmpfs mounted with ``options``; yields False when it cannot be mounted."""
    path.mkdir(parents=True, exist_ok=True)
    mounted = os.geteuid() == 0 and subprocess.run(["mount", "-t", "tmpfs", "-o", options, "tmpfs", str(path)],
                                                   capture_output=True).returncode == 0
    try:
        yield mounted
    finally:
        if mounted:
            subprocess.run(["umount", str(path)], capture_output=True)


def _disk_case(options: str, command: Callable[[Path, Stock, Path], list], fragment: str):
    def run(folder: Path, stock: Stock) -> Outcome:
        disk = folder / "disk"
        _ = stock.scenario, stock.run                                   # built before the mount
        with tmpfs(disk, options) as mounted:
            if not mounted:
                return Outcome(SKIPPED, "cannot mount a tmpfs here")
            p = simgap(*command(folder, stock, disk / "out"), cwd=folder)
            leftovers = sorted(str(f.relative_to(disk)) for f in disk.rglob("*"))
        verdict = problem(p)
        if verdict:
            return verdict
        one_line = len(p.stderr_lines()) == 1 and fragment in p.stderr
        if p.rc in (1, 2, 3) and one_line:          # 3: the machine failed (`simgap.cli.exit_codes`)
            if leftovers and not any(f.endswith("run.json") for f in leftovers):
                return Outcome(LOSS, f"one line, but left {leftovers[:3]}", p.stderr)
            return Outcome(REFUSAL, p.stderr_lines()[0][:160], p.stderr)
        return Outcome(OTHER if p.rc else SILENT, f"exit {p.rc}: {' '.join(p.stderr_lines())[:160]}", p.stderr)
    return run


case("out-read-only-run", 6)(_disk_case("ro,size=1m", lambda f, s, out: ["run", s.scenario, "--no-validate",
                                                                          "--out", out], "read-only"))
case("out-read-only-generate", 6)(_disk_case("ro,size=1m", lambda f, s, out: ["generate", "curve", "--set",
                                                                               "radius=50", "--set", "angle=30",
                                                                               "--out", out], "read-only"))
case("out-full-disk-run", 6)(_disk_case("size=64k", lambda f, s, out: ["run", s.scenario, "--no-validate",
                                                                       "--out", out], "space"))
case("out-full-disk-generate", 6)(_disk_case("size=32k", lambda f, s, out: ["generate", "curve", "--set",
                                                                            "radius=50", "--set", "angle=30",
                                                                            "--out", out], "space"))


# ---- item 7: killed half-way

def _killed_report(fraction: float):
    def run(folder: Path, stock: Stock) -> Outcome:
        exp = experiment(folder, SPEC_TWO_RUNS.replace("[50, 100]", "[20, 50, 100]"))
        clock = simgap("report", exp / "runs", "--out", folder / "timing", cwd=folder)
        child = Child(["report", exp / "runs", "--out", folder / "rep"], folder)
        time.sleep(fraction * clock.seconds)
        child.kill()
        child.wait()
        rep = folder / "rep"
        whole = not rep.exists() or (rep / "index.html").exists()
        again = simgap("report", exp / "runs", "--out", rep, cwd=folder)
        note = f"killed at {fraction * clock.seconds:.1f} s: folder {'absent' if not rep.exists() else 'whole'}" \
            if whole else f"killed at {fraction * clock.seconds:.1f} s: assets without index.html"
        if not whole:
            return Outcome(LOSS, note, again.stderr)
        return expect(again, again.rc == 0, note + "; rerun wrote it", LOSS,
                      note + f"; rerun exit {again.rc}: {' '.join(again.stderr_lines())[:100]}")
    return run


case("sigkill-report-early", 7)(_killed_report(0.8))
case("sigkill-report-late", 7)(_killed_report(0.95))


@case("sigkill-run", 7)
def _(folder: Path, stock: Stock) -> Outcome:
    child = Child(["run", stock.scenario, "--out", folder / "r"], folder)
    time.sleep(4.0)
    child.kill()
    child.wait()
    out = folder / "r"
    whole = not out.exists() or run_record(out) is not None
    again = simgap("run", stock.scenario, "--no-validate", "--out", out, cwd=folder)
    if not whole:
        return Outcome(LOSS, f"left {sorted(f.name for f in out.iterdir())} without run.json", again.stderr)
    return expect(again, again.rc == 0, f"folder {'whole' if out.exists() else 'absent'} after the kill; rerun wrote it",
                  LOSS, f"rerun exit {again.rc}: {' '.join(again.stderr_lines())[:100]}")


@case("sigkill-experiment-resume", 7)
def _(folder: Path, stock: Stock) -> Outcome:
    spec = SPEC_TWO_RUNS.replace("[50, 100]", "[20, 50, 100]").replace("[30]", "[30, 60]")
    (folder / "spec.yaml").write_text(spec)
    args = ["experiment", "run", folder / "spec.yaml", "--out", folder / "exp", "--workers", "1", "--no-report",
            "--no-validate"]
    child = Child(args, folder)
    deadline = time.monotonic() + 60
    while len(list((folder / "exp" / "store" / "rows").glob("*.parquet"))) < 2 and time.monotonic() < deadline:
        time.sleep(0.1)
    child.kill()
    child.wait()
    p = simgap(*args, cwd=folder)
    status = simgap("experiment", "status", folder / "exp", cwd=folder)
    ok = "6 done, 0 failed, 0 left" in status.stdout
    return expect(p, ok, f"resumed: {' '.join(p.stdout.split())[:90]}", LOSS, f"status: {status.stdout.strip()[:120]}")


@case("render-corrupt-run", 7)
def _(folder: Path, stock: Stock) -> Outcome:
    run = folder / "run"
    shutil.copytree(stock.run, run)
    (run / "run.json").write_text((run / "run.json").read_text()[:500])
    p = simgap("render", run, "--out", folder / "pictures", cwd=folder)
    outcome = expect_refusal(p, "run.json")
    if (folder / "pictures").exists():
        outcome = Outcome(LOSS, f"left a folder: {sorted(x.name for x in (folder / 'pictures').iterdir())}",
                          p.stderr, p.seconds)
    return outcome


# ---- item 8: memory bombs in other YAML inputs, and XML

def _bomb_case(option: str):
    def run(folder: Path, stock: Stock) -> Outcome:
        (folder / "bomb.yaml").write_text(ALIAS_BOMB)
        backend = ["--backend", "dynamic"] if option == "--backend-config" else []
        p = simgap("run", stock.scenario, *backend, option, folder / "bomb.yaml", "--out", folder / "r",
                   cwd=folder, timeout=60)
        outcome = expect_refusal(p, "bomb.yaml")
        outcome.note += f" (peak RSS {p.max_rss_mb:.0f} MB)"
        return outcome
    return run


case("planner-config-alias-bomb", 8)(_bomb_case("--planner-config"))
case("backend-config-alias-bomb", 8)(_bomb_case("--backend-config"))
case("score-config-alias-bomb", 8)(_bomb_case("--score-config"))
case("vehicle-file-alias-bomb", 8)(_bomb_case("--vehicle"))


@case("xml-billion-laughs", 8)
def _(folder: Path, stock: Stock) -> Outcome:
    text = stock.scenario.read_text()
    entities = '<!DOCTYPE commonRoad [<!ENTITY l0 "lol">' + "".join(
        f'<!ENTITY l{i} "{f"&l{i - 1};" * 10}">' for i in range(1, 10)) + "]>"
    text = text.replace("?>", "?>" + entities, 1).replace("<scenarioTags/>", "<scenarioTags/><!-- &l9; -->", 1)
    text = text.replace('author="simgap"', 'author="&l9;"', 1)
    (folder / "laughs.xml").write_text(text)
    p = simgap("run", folder / "laughs.xml", "--no-validate", "--out", folder / "r", cwd=folder, timeout=60)
    outcome = expect_refusal(p, "laughs.xml")
    outcome.note += f" (peak RSS {p.max_rss_mb:.0f} MB)"
    return outcome


@case("xml-external-entity", 8)
def _(folder: Path, stock: Stock) -> Outcome:
    text = stock.scenario.read_text().replace("?>", '?><!DOCTYPE commonRoad [<!ENTITY xxe SYSTEM '
                                              '"file:///etc/passwd">]>', 1)
    (folder / "xxe.xml").write_text(text.replace('author="simgap"', 'author="&xxe;"', 1))
    p = simgap("run", folder / "xxe.xml", "--no-validate", "--out", folder / "r", cwd=folder)
    written = [f.read_text(errors="replace") for f in (folder / "r").glob("*")] if (folder / "r").exists() else []
    if "root:" in p.stdout + p.stderr + "".join(written):
        return Outcome(SILENT, "the entity was expanded: /etc/passwd in the output", p.stderr, p.seconds)
    verdict = problem(p) or refused(p, ("xxe.xml",))
    return verdict or Outcome(HANDLED, f"exit {p.rc}: entity not expanded", p.stderr)


# ---- item 9: a planner's hard exit inside an experiment

@case("experiment-planner-os-exit", 9)
def _(folder: Path, stock: Stock) -> Outcome:
    planners = stock.planners(folder)
    (folder / "spec.yaml").write_text(SPEC_TWO_RUNS + f"planners: ['{planners}:HardExit']\n")
    p = simgap("experiment", "run", folder / "spec.yaml", "--out", folder / "exp", "--workers", "1", "--no-report",
               "--no-validate", cwd=folder)
    status = simgap("experiment", "status", folder / "exp", cwd=folder)
    records = [run_record(run.parent) for run in (folder / "exp").rglob("run.json")]
    refused_exit = len(records) == 2 and all("ProcessExitRefused" in (failure_reason(r) or "") for r in records if r)
    ok = "2 failed" in status.stdout or "2 done" in status.stdout and refused_exit     # (os._exit fails the cycle)
    how = "with their agents' os._exit refused" if refused_exit else "failed"
    return expect(p, ok, f"both recorded {how}: {' '.join(status.stdout.split())[:120]}", LOSS,
                  f"exit {p.rc}; status: {' '.join(status.stdout.split())[:120]}")


@case("planner-not-a-class", 9)
def _(folder: Path, stock: Stock) -> Outcome:
    planners = stock.planners(folder)
    return expect_refusal(simgap("run", stock.scenario, "--planner", f"{planners}:not_a_class", "--out",
                                 folder / "r", cwd=folder), "not_a_class")


@case("planner-file-syntax-error", 9)
def _(folder: Path, stock: Stock) -> Outcome:
    (folder / "broken.py").write_text("class Broken(:\n    pass\n")
    return expect_refusal(simgap("run", stock.scenario, "--planner", f"{folder / 'broken.py'}:Broken", "--out",
                                 folder / "r", cwd=folder), "broken.py")


@case("planner-import-exits", 9)
def _(folder: Path, stock: Stock) -> Outcome:
    (folder / "exits.py").write_text("import sys\nsys.exit(4)\nclass P:\n    pass\n")
    p = simgap("run", stock.scenario, "--planner", f"{folder / 'exits.py'}:P", "--out", folder / "r", cwd=folder)
    return expect_refusal(p, "exits.py")


# ---- item 10: smaller

@case("experiment-out-users-folder", 10)
def _(folder: Path, stock: Stock) -> Outcome:
    mine = folder / "mine"
    mine.mkdir()
    (mine / "thesis.tex").write_text("mine")
    (folder / "spec.yaml").write_text(SPEC_TWO_RUNS)
    p = simgap("experiment", "run", folder / "spec.yaml", "--out", mine, "--workers", "1", "--no-report",
               "--no-validate", cwd=folder)
    outcome = expect_refusal(p, "thesis.tex")
    if outcome.verdict == SILENT:
        outcome.note = f"wrote into the user's folder: {sorted(x.name for x in mine.iterdir())}"
    return outcome


@case("piped-table-whole", 10)
def _(folder: Path, stock: Stock) -> Outcome:
    p = simgap("vehicles", cwd=folder, env={"COLUMNS": None, "LINES": None})
    ok = p.rc == 0 and "…" not in p.stdout
    return expect(p, ok, "no column cut", SILENT, "a table cut with '…' when piped")


@case("run-dir-permissions-umask", 10)
def _(folder: Path, stock: Stock) -> Outcome:
    p = simgap("run", stock.scenario, "--no-validate", "--replan-every", "3", "--out", folder / "r", cwd=folder,
               umask=0o022)
    mode = (folder / "r").stat().st_mode & 0o777 if (folder / "r").exists() else None
    return expect(p, mode == 0o755, "0755 under umask 022", OTHER, f"mode {oct(mode) if mode else None}")


@case("resume-says-failed-earlier", 10)
def _(folder: Path, stock: Stock) -> Outcome:
    planners = stock.planners(folder)
    (folder / "spec.yaml").write_text(SPEC_TWO_RUNS + f"run_timeout_s: 1\nplanners: ['{planners}:NeverReturns']\n")
    args = ["experiment", "run", folder / "spec.yaml", "--out", folder / "exp", "--workers", "1", "--no-report",
            "--no-validate"]
    first = simgap(*args, cwd=folder)
    again = simgap(*args, cwd=folder)
    ok = "--retry-failed" in again.stdout and "2 of the runs" in " ".join(again.stdout.split())
    return problem(first) or expect(again, ok, "said 2 failed earlier and how to retry", OTHER,
                                    " ".join(again.stdout.split())[:160])


# --------------------------------------------------------------------------------------------
# the sweep

def run_case(c: Case, root: Path, stock: Stock) -> Outcome:
    folder = root / c.name
    folder.mkdir(parents=True)
    start = time.monotonic()
    try:
        outcome = c.run(folder, stock)
    except Exception as exc:                     # the sweep's own failure to build the case
        outcome = Outcome(OTHER, f"sweep error: {type(exc).__name__}: {exc}"[:200])
    outcome.seconds = time.monotonic() - start
    outcome.note = outcome.note.replace(f"{folder}/", "")            # paths relative to the case's folder
    return outcome


def print_table(results: list[dict]) -> None:
    width = max(len(r["case"]) for r in results)
    print(f"{'case':<{width}}  item  {'verdict':<13} {'s':>6}  note")
    for r in results:
        print(f"{r['case']:<{width}}  {r['item']:>4}  {r['verdict']:<13} {r['seconds']:>6.1f}  {r['note']}")
    counts = {v: sum(r["verdict"] == v for r in results) for v in VERDICTS}
    print("\n" + ", ".join(f"{v}: {n}" for v, n in counts.items() if n) + f" ({len(results)} cases)")
    flagged = [r for r in results if r["verdict"] not in (REFUSAL, RECORDED, HANDLED)]
    for r in flagged:
        lines = [line for line in r["stderr"].splitlines() if line.strip()][:3]
        print(f"\n{r['case']} (item {r['item']}): {r['verdict']}: {r['note']}")
        for line in lines:
            print("    " + textwrap.shorten(line, 200))


# --- round 5, h2-roads-input: OpenDRIVE in (issue 54 item 5), 3D relief and template names (item 6)

def _exported_road(stock: Stock, template: str) -> str:
    """simgap's own road of ``template`` (curve r = 50 m, 30 deg; or the T-junction) exported as
    OpenDRIVE, once per sweep: the text the OpenDRIVE cases mutate."""
    folder = stock.root / "stock" / f"exported-{template}"
    if not folder.exists():
        sets = ("--set", "radius=50", "--set", "angle=30") if template == "curve" else ()
        p = simgap("generate", template, *sets, "--no-preview", "--out", folder / "scenarios", cwd=stock.root)
        assert p.rc == 0, p.stderr
        (xml,) = (folder / "scenarios").glob("*.xml")
        p = simgap("export", xml, "--format", "opendrive", "--out", folder / "xodr", cwd=stock.root)
        assert p.rc == 0, p.stderr
    (road,) = (folder / "xodr").glob("*.xodr")
    return road.read_text()


def _replaced(text: str, old: str, new: str, after: str = "") -> str:
    """``text`` with the first ``old`` after ``after`` replaced by ``new``."""
    at = text.index(after) if after else 0
    assert old in text[at:], old
    return text[:at] + text[at:].replace(old, new, 1)


T_ROUTE = ("--start", "2:1:30", "--goal", "1:-1:30")     # road 2 into the junction, out on road 1
ODR_REFUSED = [  # name, road, old, new, encoding, what the refusal should name
    ("odr-latin1-declared-utf8", "curve", 'name="curve', 'name="Straße curve', "latin-1", ("encoding",)),
    ("odr-zero-length-geometry-gap", "curve", 'length="100.0">', 'length="0">', "utf-8", ("geometry 0",)),
    ("odr-negative-lane-width", "curve", '<width a="3.0"', '<width a="-3.0"', "utf-8", ("lane 1", "width")),
    ("odr-curvature-1e6", "curve", 'curvature="0.02"', 'curvature="1e6"', "utf-8", ("geometry 1", "curvature")),
    ("odr-parampoly3-all-zero", "curve", '<arc curvature="0.02" />', '<paramPoly3 aU="0" bU="0" cU="0" dU="0" '
     'aV="0" bV="0" cV="0" dV="0" pRange="normalized" />', "utf-8", ("geometry 1", "paramPoly3")),
    ("odr-poly3-1e200", "curve", '<arc curvature="0.02" />', '<poly3 a="0" b="0" c="1e200" d="1e200" />', "utf-8",
     ("geometry 1", "poly3")),
    ("odr-elevation-1e200", "curve", "<elevationProfile />", '<elevationProfile><elevation s="0" a="0" b="0" c="0" '
     'd="1e200" /></elevationProfile>', "utf-8", ("elevationProfile",)),
    ("odr-duplicate-road-id", "t-junction", 'id="2" junction="-1"', 'id="1" junction="-1"', "utf-8", ("road 1",)),
]
ODR_DROPPED = [  # name, old, new, after, the warning's kind
    ("odr-link-to-missing-road", '<successor elementType="road" elementId="2"',
     '<successor elementType="road" elementId="99"', "", "road links to roads that are not in the file: 1 dropped"),
    ("odr-link-to-missing-junction", '<predecessor elementType="junction" elementId="1" />',
     '<predecessor elementType="junction" elementId="7" />', 'id="3" junction="-1"',
     "road links to junctions that are not in the file: 1 dropped"),
    ("odr-lane-link-to-missing-lane", '<successor id="-1" />', '<successor id="-4" />', "",
     "lane links to lanes that the linked lane section does not have: 1 dropped"),
    ("odr-circular-junction", 'incomingRoad="1"', 'incomingRoad="100"', "",
     "links of a junction into itself: 1 dropped"),
]


def _odr_refused_case(road, old, new, encoding, names):
    def run(folder: Path, stock: Stock) -> Outcome:
        (folder / "hostile.xodr").write_bytes(_replaced(_exported_road(stock, road), old, new).encode(encoding))
        route = T_ROUTE if road == "t-junction" else ("--start", "1:-1:20", "--goal", "1:-1:200")
        p = simgap("generate", folder / "hostile.xodr", *route, "--no-preview", "--out", folder / "out", cwd=folder)
        return expect_refusal(p, "hostile.xodr", *names)
    return run


def _odr_dropped_case(old, new, after, warning):
    def run(folder: Path, stock: Stock) -> Outcome:
        (folder / "hostile.xodr").write_text(_replaced(_exported_road(stock, "t-junction"), old, new, after))
        p = simgap("generate", folder / "hostile.xodr", *T_ROUTE, "--no-preview", "--out", folder / "out",
                   cwd=folder)
        warned = [line for line in p.stderr_lines() if line.startswith("warning:")]
        kinds = [line.split(": ")[2] for line in warned if line.count(": ") >= 3]
        said = [line for line in warned if warning in line]
        ok = p.rc == 0 and len(said) == 1 and len(kinds) == len(set(kinds)) == len(warned)
        return expect(p, ok, f"ran, one line per kind: {said[0][:120] if said else ''}",
                      SILENT if p.rc == 0 else OTHER, f"exit {p.rc}, warnings: {' | '.join(warned)[:140]}")
    return run


for _name, _road, _old, _new, _encoding, _names in ODR_REFUSED:
    case(_name, 5)(_odr_refused_case(_road, _old, _new, _encoding, _names))
for _name, _old, _new, _after, _warning in ODR_DROPPED:
    case(_name, 5)(_odr_dropped_case(_old, _new, _after, _warning))


RELIEF_EDITS = [  # name, the edit of the sidecar's relief, the field the refusal should name
    ("relief-grade-1000", lambda r: r["elevation"].update(grade=1000), "grade"),
    ("relief-bank-90", lambda r: r["superelevation"][2].update(bank=90), "bank"),
    ("relief-vertical-radius-0", lambda r: r["elevation"]["changes"][0].update(radius=0), "radius"),
    ("relief-vertical-radius-negative", lambda r: r["elevation"]["changes"][0].update(radius=-100), "radius"),
    ("relief-vertical-radius-nan", lambda r: r["elevation"]["changes"][0].update(radius=float("nan")), "radius"),
    ("relief-grade-string", lambda r: r["elevation"].update(grade="steep"), "grade"),
    ("relief-vertical-curve-at-nan", lambda r: r["elevation"]["changes"][0].update(s=float("nan")), "changes"),
]


def _relief_case(edit, field_name):
    def run(folder: Path, stock: Stock) -> Outcome:
        import json
        source = stock.root / "stock" / "crest"
        if not source.exists():
            p = simgap("generate", "crest-curve", "--set", "radius=30", "--set", "vertical_radius=200",
                       "--no-preview", "--out", source, cwd=stock.root)
            assert p.rc == 0, p.stderr
        (xml,) = source.glob("*.xml")
        shutil.copy(xml, folder / "edited.xml")
        metadata = json.loads(xml.with_suffix(".json").read_text())
        edit(metadata["blueprint"]["relief"])
        (folder / "edited.json").write_text(json.dumps(metadata))
        p = simgap("run", folder / "edited.xml", "--backend", "mujoco", "--no-validate", "--max-time", "2",
                   "--out", folder / "r", cwd=folder)
        return expect_refusal(p, "edited.json", field_name)
    return run


for _name, _edit, _field in RELIEF_EDITS:
    case(_name, 6)(_relief_case(_edit, _field))
for _name, _text, _names in [
    ("logical-curve-without-angle", "name: hostile\ntemplate: curve\nparameters:\n"
     "  radius: {unit: m, min: 10, max: 100, default: 50}\n", ("angle",)),
    ("logical-hairpins-without-radius", "name: hostile\ntemplate: hairpins\nparameters: {}\n", ("hairpin_radius",)),
    ("logical-angle-a-string", "name: hostile\ntemplate: curve\nfixed: {angle: big}\nparameters:\n"
     "  radius: {unit: m, min: 10, max: 100, default: 50}\n", ("angle",)),
    ("logical-lanes-not-whole", "name: hostile\ntemplate: curve\nfixed: {angle: 30, lanes: 1.5}\nparameters:\n"
     "  radius: {unit: m, min: 10, max: 100, default: 50}\n", ("lanes",)),
]:
    case(_name, 6)(_logical_case(_text, _names))


# --- round 5, h5-commands-timeline: a run whose recorded commands lost their columns

@case("run-controls-without-columns", 7)
def _(folder: Path, stock: Stock) -> Outcome:
    import pyarrow.parquet as pq

    p = simgap("run", stock.scenario, "--no-validate", "--backend", "dynamic", "--replan-every", "3", "--out",
               folder / "r", cwd=folder)
    if p.rc != 0:
        return problem(p) or Outcome(OTHER, f"the dynamic run failed: exit {p.rc}", p.stderr, p.seconds)
    path = folder / "r" / "trajectories.parquet"
    table = pq.read_table(path)
    pq.write_table(table.drop_columns(["steer_requested", "accel_achieved"]), path)    # a hand-edited file
    return expect_refusal(simgap("compare", stock.run, folder / "r", cwd=folder), "trajectories.parquet")


# --- round 5, h1-planner-process: planner deadlines, protocol hygiene, in-process planners (issue 54 items 1-3)

R5_SERVER = '''
"""A planner in its own process that misbehaves as argv[1] says (keeps its lane otherwise)."""
import os
import sys
import time

import zmq
from simgap_planner import simgap_planner_pb2 as pb
from simgap_planner import serve

from keep_lane import KeepLane  # noqa: E402   (copied beside this file)

HOW = sys.argv[1]


class Late(KeepLane):
    cycle = 0

    def plan(self, observed, t, world):
        Late.cycle += 1
        if HOW == "late-then-silent" and Late.cycle >= 3:
            time.sleep(1.05 if Late.cycle == 3 else 3600)
        if HOW == "always-late":
            time.sleep(1.05)
        return super().plan(observed, t, world)


def raw(version="1.0", name="raw", reason="no plan", shift=0):
    socket = zmq.Context.instance().socket(zmq.REP)
    socket.bind(os.environ["SIMGAP_PLANNER_ENDPOINT"])
    while True:
        request = pb.Request.FromString(socket.recv())
        reply = pb.Reply(id=request.id)
        kind = request.WhichOneof("body")
        if kind == "initialize":
            reply.ready.protocol_version, reply.ready.session, reply.ready.planner = version, 1, name
        elif kind == "plan":
            reply.id += shift
            reply.plan.no_plan = reason
        else:
            reply.closed.SetInParent()
        socket.send(reply.SerializeToString())
        if kind == "close":
            return


if HOW.startswith("version="):
    raw(version=HOW.partition("=")[2])
elif HOW == "wrong-id":
    raw(shift=5)
elif HOW == "reason-5mb":
    raw(reason="r" * 5_000_000)
elif HOW == "name-10mb":
    raw(name="n" * 10_000_000)
elif HOW == "output-300mb":
    for _ in range(300):
        sys.stdout.write("x" * (1 << 20))
    sys.exit(3)
elif HOW == "fork-and-daemon":
    if os.fork() == 0:
        open("child.pid", "w").write(str(os.getpid()))
        time.sleep(3600)
        os._exit(0)
    if os.fork() == 0:
        os.setsid()
        if os.fork() == 0:
            open("daemon.pid", "w").write(str(os.getpid()))
            time.sleep(3600)
        os._exit(0)
    serve(KeepLane)
else:
    serve(Late)
'''

R5_IN_PROCESS = '''
import ctypes
import os

from simgap.planning.idm_planner import IdmPlanner


class Wanderer(IdmPlanner):
    def plan(self, observed, t, world):
        os.makedirs("elsewhere", exist_ok=True)
        os.chdir("elsewhere")
        return super().plan(observed, t, world)


class Crasher(IdmPlanner):
    def plan(self, observed, t, world):
        if t > 0.25:
            ctypes.string_at(0)
        return super().plan(observed, t, world)
'''


def _r5_server(folder: Path, how: str) -> str:
    (folder / "server.py").write_text(R5_SERVER)
    shutil.copy(REPO / "examples" / "remote_planner" / "keep_lane.py", folder / "keep_lane.py")
    return f"exec:{sys.executable} {folder / 'server.py'} {how}"


def _r5_alive(pid: int) -> bool:
    try:
        return Path(f"/proc/{pid}/stat").read_text().rpartition(")")[2].split()[0] != "Z"
    except OSError:
        return False


def _r5_record(folder: Path) -> dict:
    import json
    path = folder / "r" / "run.json"
    return json.loads(path.read_text()) if path.is_file() else {}


def _r5_recorded_case(how: str, reason: str):
    def run(folder: Path, stock: Stock) -> Outcome:
        outcome = expect_record(simgap("run", stock.scenario, "--no-validate", "--planner", _r5_server(folder, how),
                                       "--out", folder / "r", cwd=folder, timeout=90), folder / "r")
        if outcome.verdict == RECORDED and reason not in outcome.note:     # failed, but not for what was wrong
            outcome.verdict, outcome.note = SILENT, f"accepted, no '{reason}' said; {outcome.note}"
        return outcome
    return run


# --- round 5, h3-data-safety: damaged records, experiments that lose runs, the user's files, knobs, signals
# (items of issue 54: 4 the user's files, 7 knobs, 8 damaged records, 9 experiments, 10 signals, 11 --isolate)

def _damaged_run(folder: Path, stock: Stock, damage: str) -> Path:
    """A copy of the stock run, damaged as ``damage`` says."""
    import json

    import pyarrow as pa
    import pyarrow.parquet as pq

    run = folder / "damaged"
    shutil.copytree(stock.run, run)
    meta_path, states = run / "run.json", run / "trajectories.parquet"
    meta = json.loads(meta_path.read_text())
    if damage == "null":
        meta_path.write_text("null")
    elif damage == "dt-nan":
        meta["history"]["dt"] = float("nan")
        meta_path.write_text(json.dumps(meta))
    elif damage == "score-nan":
        meta["evaluation"]["agents"][0]["score"] = float("nan")
        meta_path.write_text(json.dumps(meta))
    elif damage == "state-nan":
        table = pq.read_table(states)
        x = table.column("x").to_numpy().copy()
        x[:] = float("nan")
        pq.write_table(table.set_column(table.schema.get_field_index("x"), "x", pa.array(x)), states)
    elif damage == "no-rows":
        pq.write_table(pq.read_table(states).slice(0, 0), states)
    return run


DAMAGED_RECORD_CASES = [  # damage, what the refusal should name (file, field)
    ("null", ("run.json",)), ("dt-nan", ("run.json", "history.dt")), ("score-nan", ("run.json", "score")),
    ("state-nan", ("trajectories.parquet", "'x'")), ("no-rows", ("trajectories.parquet", "driven")),
]


def _damaged_record_case(damage: str, reader: str, names: tuple[str, ...]):
    def run(folder: Path, stock: Stock) -> Outcome:
        damaged = _damaged_run(folder, stock, damage)
        args = {"report": ["report", damaged, "--out", folder / "out"], "compare": ["compare", damaged, stock.run],
                "export": ["export", damaged, "--out", folder / "out"],
                "render": ["render", damaged, "--out", folder / "out"]}[reader]
        outcome = expect_refusal(simgap(*args, cwd=folder), *names)
        if (folder / "out").exists() and outcome.verdict == REFUSAL:
            return Outcome(LOSS, f"refused but left {sorted(p.name for p in (folder / 'out').iterdir())}",
                           outcome.stderr)
        return outcome
    return run


for _name, _how, _reason in (("version-2.0", "version=2.0", "protocol version"),
                             ("version-banana", "version=banana", "protocol version"),
                             ("version-empty", "version=", "protocol version"), ("wrong-id", "wrong-id", "with the id"),
                             ("late-then-silent", "late-then-silent", "missed its deadline")):
    case(f"r5-planner-{_name}", 1 if "late" in _how else 2)(_r5_recorded_case(_how, _reason))


@case("r5-planner-always-late", 1)
def _(folder: Path, stock: Stock) -> Outcome:
    p = simgap("run", stock.scenario, "--no-validate", "--planner", _r5_server(folder, "always-late"),
               "--out", folder / "r", cwd=folder, timeout=90)
    process = _r5_record(folder).get("settings", {}).get("planner", {}).get("process", {})
    failures = sum(a.get("planner_failures", 0) for a in _r5_record(folder).get("history", {}).get("agents", []))
    misses = process.get("deadline_misses")
    return expect(p, misses == failures and failures > 0, f"every one of {failures} late answers a miss", SILENT,
                  f"{misses} misses of {failures} failed cycles")


@case("r5-planner-output-300mb", 1)
def _(folder: Path, stock: Stock) -> Outcome:
    p = simgap("run", stock.scenario, "--no-validate", "--planner", _r5_server(folder, "output-300mb"),
               "--out", folder / "r", cwd=folder, timeout=90)
    reason = _r5_record(folder).get("history", {}).get("planner_errors", [{}])[0].get("message", "")
    return expect(p, p.max_rss_mb < 600 and "exited with code 3" in reason and len(reason) < 3000,
                  f"recorded with the end of its output ({len(reason)} characters), peak {p.max_rss_mb:.0f} MB",
                  OTHER, f"peak {p.max_rss_mb:.0f} MB, a reason of {len(reason)} characters")


@case("r5-planner-no-plan-5mb", 2)
def _(folder: Path, stock: Stock) -> Outcome:
    p = simgap("run", stock.scenario, "--no-validate", "--planner", _r5_server(folder, "reason-5mb"),
               "--out", folder / "r", cwd=folder, timeout=90)
    size = (folder / "r" / "run.json").stat().st_size if (folder / "r" / "run.json").is_file() else None
    return expect(p, size is not None and size < 1_000_000, f"run.json {size} bytes", SILENT, f"run.json {size} bytes")


@case("r5-planner-name-10mb", 2)
def _(folder: Path, stock: Stock) -> Outcome:
    p = simgap("run", stock.scenario, "--no-validate", "--planner", _r5_server(folder, "name-10mb"),
               "--out", folder / "r", cwd=folder, timeout=90)
    name = _r5_record(folder).get("settings", {}).get("planner", {}).get("process", {}).get("planner")
    return expect(p, name is not None and len(name) < 300, f"name kept as {len(name or '')} characters", SILENT,
                  f"name of {len(name or '')} characters")


for _setting, _field in (("speed: .inf", "speed"), ("speed: .nan", "speed"), ("when: 2024-01-01", "when")):
    def _settings_case(setting=_setting, field_name=_field):
        def run(folder: Path, stock: Stock) -> Outcome:
            (folder / "settings.yaml").write_text(setting + "\n")
            return expect_refusal(simgap("run", stock.scenario, "--no-validate", "--planner",
                                         _r5_server(folder, "keep"), "--planner-config", folder / "settings.yaml",
                                         "--out", folder / "r", cwd=folder), "settings.yaml", field_name)
        return run
    case(f"r5-exec-settings-{_setting.split()[1].strip('.')}", 2)(_settings_case())


def _r5_started(folder: Path, names: tuple[str, ...], timeout_s: float = 60) -> list[int]:
    end = time.monotonic() + timeout_s
    while not all((folder / n).is_file() and (folder / n).read_text() for n in names):
        if time.monotonic() > end:
            return []
        time.sleep(0.05)
    return [int((folder / n).read_text()) for n in names]


@case("r5-planner-forks-and-daemonises", 2)
def _(folder: Path, stock: Stock) -> Outcome:
    p = simgap("run", stock.scenario, "--no-validate", "--planner", _r5_server(folder, "fork-and-daemon"),
               "--out", folder / "r", cwd=folder, timeout=90)
    pids = _r5_started(folder, ("child.pid", "daemon.pid"), 5)
    time.sleep(1)
    left = [pid for pid in pids if _r5_alive(pid)]
    for pid in left:
        os.kill(pid, signal.SIGKILL)
    return expect(p, bool(pids) and not left, "the forked child and the setsid daemon ended with simgap", OTHER,
                  f"{len(left)} of its processes outlived simgap" if pids else "the planner did not start")


for _signum in (signal.SIGTERM, signal.SIGKILL):
    def _killed_case(signum=_signum):
        def run(folder: Path, stock: Stock) -> Outcome:
            (folder / "tmp").mkdir()
            child = Child(["run", stock.scenario, "--no-validate", "--planner", _r5_server(folder, "fork-and-daemon"),
                           "--out", folder / "r"], folder, env={"TMPDIR": str(folder / "tmp")})
            pids = _r5_started(folder, ("child.pid", "daemon.pid"))
            os.kill(child.popen.pid, signum)
            p = child.wait(30)
            time.sleep(2)
            left = [pid for pid in pids if _r5_alive(pid)]
            for pid in left:
                os.kill(pid, signal.SIGKILL)
            folders = list((folder / "tmp").glob("simgap-planner-*"))
            return expect(p, bool(pids) and not left and not folders, "no planner process or folder left", OTHER,
                          f"{len(left)} planner processes, {len(folders)} planner folders left")
        return run
    case(f"r5-{_signum.name.lower()}-leaves-no-planner", 2)(_killed_case())


@case("r5-in-process-chdir", 3)
def _(folder: Path, stock: Stock) -> Outcome:
    (folder / "planners.py").write_text(R5_IN_PROCESS)
    p = simgap("run", stock.scenario, "--no-validate", "--planner", "planners.py:Wanderer", "--out", "r", cwd=folder)
    return expect(p, (folder / "r" / "run.json").is_file() and not (folder / "elsewhere" / "r").exists(),
                  "the run is where --out said", LOSS, "the run was written elsewhere")


@case("r5-in-process-segfault", 3)
def _(folder: Path, stock: Stock) -> Outcome:
    (folder / "planners.py").write_text(R5_IN_PROCESS)
    p = simgap("run", stock.scenario, "--no-validate", "--planner", "planners.py:Crasher", "--out", folder / "r",
               cwd=folder)
    said = "Segmentation fault" in p.stderr and "planners.py" in p.stderr
    if p.timed_out:
        return problem(p)
    return Outcome(HANDLED if said else SILENT, f"exit {p.rc}: " + ("the segfault and the planner's line said" if said
                                                                    else "no line"), p.stderr)


# --- round 5, h7-log-viewer: runs as rerun recordings (issue 53 item 5)

def _no_recording(outcome: Outcome, folder: Path, p: Proc) -> Outcome:
    """A refusal that left an .rrd (or its temporary) behind is a loss."""
    left = [f.name for f in folder.rglob("*.rrd*") if f.is_file()]
    if left and outcome.verdict == REFUSAL:
        return Outcome(LOSS, f"refused but left {left[0]}", p.stderr, p.seconds)
    return outcome


@case("rerun-out-is-a-directory", 5)
def _(folder: Path, stock: Stock) -> Outcome:
    (folder / "mine.rrd").mkdir()
    p = simgap("export", stock.run, "--format", "rerun", "--out", folder / "mine.rrd", cwd=folder)
    return expect_refusal(p, "mine.rrd", "directory")


@case("rerun-of-a-scenario-file", 5)
def _(folder: Path, stock: Stock) -> Outcome:
    p = simgap("export", stock.scenario, "--out", folder / "x.rrd", cwd=folder)
    return _no_recording(expect_refusal(p, "--format", "one run"), folder, p)


@case("rerun-trajectories-truncated", 5)
def _(folder: Path, stock: Stock) -> Outcome:
    run = folder / "run"
    shutil.copytree(stock.run, run)
    parquet = run / "trajectories.parquet"
    parquet.write_bytes(parquet.read_bytes()[: parquet.stat().st_size // 2])
    p = simgap("export", run, "--out", folder / "x.rrd", cwd=folder)
    return _no_recording(expect_refusal(p, "trajectories.parquet"), folder, p)


@case("rerun-ideal-twin-of-another-scenario", 5)
def _(folder: Path, stock: Stock) -> Outcome:
    p = simgap("generate", "curve", "--set", "radius=20", "--set", "angle=90", "--no-preview", "--out",
               folder / "scenarios", cwd=folder)
    assert p.rc == 0, p.stderr
    p = simgap("run", folder / "scenarios" / "curve_radius-20_angle-90.xml", "--no-validate", "--max-time", "1",
               "--out", folder / "other", cwd=folder)
    assert p.rc == 0, p.stderr
    p = simgap("export", stock.run, "--out", folder / "x.rrd", "--ideal", folder / "other", cwd=folder)
    return _no_recording(expect_refusal(p, "--ideal", "same scenario"), folder, p)


# --- round 5, h4-cli-day: CI checks (--fail-on, --min-score), agents placed by --start/--goal, the search's budget

ROUND5_CLI_DAY = [  # name, issue-53 item, arguments after `simgap run SCENARIO --no-validate`, what the line names
    ("run-fail-on-unknown-outcome", 3, ["--fail-on", "off_road,crash"], ("fail-on", "off_road")),
    ("run-fail-on-empty", 3, ["--fail-on", ","], ("fail-on", "goal_reached")),
    ("run-min-score-above-one", 3, ["--min-score", "2"], ("min-score", "0 to 1")),
    ("run-start-off-the-map", 2, ["--start", "1e6,0", "--goal", "10,0"], ("--start", "no driving lane")),
    ("run-goal-without-start", 2, ["--goal", "10,0"], ("--start",)),
    ("run-start-nan", 2, ["--start", "nan,0", "--goal", "10,0"], ("--start", "finite")),
    ("run-goal-radius-negative", 2, ["--start", "10,-1.5", "--goal", "40,-1.5,-3"], ("--goal", "radius")),
]


def _round5_run_refused(arguments: list[str], names: tuple[str, ...]):
    def run(folder: Path, stock: Stock) -> Outcome:
        p = simgap("run", stock.scenario, "--no-validate", *arguments, "--out", folder / "r", cwd=folder)
        if (folder / "r").exists():
            return Outcome(LOSS, "a run directory was written for a refused run", p.stderr, p.seconds)
        return expect_refusal(p, *names)
    return run


for _damage, _names in DAMAGED_RECORD_CASES:
    for _reader in ("report", "compare", "export", "render"):
        case(f"damaged-record-{_damage}-{_reader}", 8)(_damaged_record_case(_damage, _reader, _names))


def _damaged_experiment_case(damage: Callable[[Path], None]):
    def run(folder: Path, stock: Stock) -> Outcome:
        exp = experiment(folder)
        damage(next(exp.glob("runs/*/ideal")))
        status = simgap("experiment", "status", exp, cwd=folder)
        if "2 done" in status.stdout:
            return Outcome(LOSS, f"status says done: {' '.join(status.stdout.split())[:120]}", status.stderr)
        again = simgap("experiment", "run", folder / "spec.yaml", "--out", exp, "--workers", "1", "--no-report",
                       "--no-validate", cwd=folder)
        after = simgap("experiment", "status", exp, cwd=folder)
        ok = "1 ran now" in " ".join(again.stdout.split()) and "2 done, 0 failed, 0 left" in after.stdout
        return expect(again, ok, "status: 1 left; resume ran it again; then 2 done", LOSS,
                      f"resume: {' '.join(again.stdout.split())[:80]}; status: {' '.join(after.stdout.split())[:60]}")
    return run


case("experiment-run-json-truncated", 9)(_damaged_experiment_case(
    lambda run: (run / "run.json").write_text((run / "run.json").read_text()[:300])))
case("experiment-parquet-garbage", 9)(_damaged_experiment_case(
    lambda run: (run / "trajectories.parquet").write_bytes(b"garbage" * 100)))


@case("experiment-run-failed-by-a-full-disk", 9)
def _(folder: Path, stock: Stock) -> Outcome:
    import errno

    from simgap.experiment.executors import _crashed_row
    from simgap.experiment.spec import jobs, load_spec
    from simgap.experiment.store import ResultsStore

    exp = experiment(folder)
    job = next(runs[0] for _, runs in jobs(load_spec(folder / "spec.yaml")))
    ResultsStore(exp).write_row(_crashed_row(job, OSError(errno.ENOSPC, "No space left on device")))  # as a worker would
    again = simgap("experiment", "run", folder / "spec.yaml", "--out", exp, "--workers", "1", "--no-report",
                   "--no-validate", cwd=folder)
    after = simgap("experiment", "status", exp, cwd=folder)
    ok = "1 ran now" in " ".join(again.stdout.split()) and "2 done, 0 failed, 0 left" in after.stdout
    return expect(again, ok, "the run the disk failed ran again on resume", LOSS,
                  f"resume: {' '.join(again.stdout.split())[:80]}; status: {' '.join(after.stdout.split())[:60]}")


def _users_folder_case(command: Callable[[Path, Stock, Path], list], mine: str, names: tuple[str, ...]):
    def run(folder: Path, stock: Stock) -> Outcome:
        out = folder / "mine"
        out.mkdir()
        (out / mine).write_text("mine")
        p = simgap(*command(folder, stock, out), cwd=folder)
        if (out / mine).read_text() != "mine":
            return Outcome(LOSS, f"the user's {mine} was overwritten (exit {p.rc})", p.stderr, p.seconds)
        return expect_refusal(p, *names)
    return run


for _name, _item, _arguments, _names in ROUND5_CLI_DAY:
    case(_name, _item)(_round5_run_refused(_arguments, _names))


@case("search-budget-below-its-strategies", 6)
def _(folder: Path, stock: Stock) -> Outcome:
    (folder / "search.yaml").write_text(
        "name: t\nlogical: curve\nparameters: {radius: {min: 10, max: 50}}\n"
        "ladder: [{backend: ideal}, {backend: dynamic}]\nstrategies: [grid, random, lhs]\n")
    return expect_refusal(simgap("search", folder / "search.yaml", "--budget", "2", "--out", folder / "s",
                                 "--no-report", cwd=folder, timeout=60), "budget", "3 strategies")


# --- round 5, h6-explain: simgap explain on what it cannot explain
@case("explain-an-ideal-run", 10)
def _(folder: Path, stock: Stock) -> Outcome:
    return expect_refusal(simgap("explain", stock.run, cwd=folder), "backend", "nothing to explain")


@case("explain-not-a-run", 10)
def _(folder: Path, stock: Stock) -> Outcome:
    (folder / "empty").mkdir()
    return expect_refusal(simgap("explain", folder / "empty", cwd=folder), "RUN_DIR", "run.json")


@case("explain-driven-scenario-gone", 10)
def _(folder: Path, stock: Stock) -> Outcome:
    p = simgap("run", stock.scenario, "--backend", "dynamic", "--max-time", "2", "--no-validate", "--out",
               folder / "r", cwd=folder)
    (folder / "r" / "driven.xml").unlink(missing_ok=True)
    return problem(p) or expect_refusal(simgap("explain", folder / "r", cwd=folder), "driven.xml")


@case("run-explain-in-the-ideal-world", 10)
def _(folder: Path, stock: Stock) -> Outcome:
    outcome = expect_refusal(simgap("run", stock.scenario, "--explain", "--out", folder / "r", cwd=folder),
                             "explain", "nothing to explain")
    if outcome.verdict == REFUSAL and (folder / "r").exists():
        return Outcome(SILENT, "refused, but after writing the run", "")
    return outcome


case("generate-users-same-named-file", 4)(_users_folder_case(
    lambda f, s, out: ["generate", "curve", "--set", "radius=50", "--set", "angle=30", "--no-preview", "--out", out],
    "curve_radius-50_angle-30.xml", ("curve_radius-50_angle-30.xml", "--overwrite")))
case("export-users-folder-base-xml", 4)(_users_folder_case(
    lambda f, s, out: ["export", s.scenario, "--out", out], "base.xml", ("base.xml", "--overwrite")))
case("export-run-users-xosc", 4)(_users_folder_case(
    lambda f, s, out: ["export", s.run, "--out", out], "curve_radius-50_angle-30_ideal.xosc",
    ("curve_radius-50_angle-30_ideal.xosc",)))


@case("generate-out-root", 4)
def _(folder: Path, stock: Stock) -> Outcome:
    before = set(os.listdir("/"))
    p = simgap("generate", "curve", "--set", "radius=50", "--set", "angle=30", "--no-preview", "--out", "/",
               cwd=folder)
    written = sorted(set(os.listdir("/")) - before)
    for name in written:                                  # (what a failed case wrote into / is removed)
        if name.startswith("curve_radius-50_angle-30"):
            os.unlink(Path("/") / name)
    if written:
        return Outcome(LOSS, f"wrote {written} into /", p.stderr, p.seconds)
    return expect_refusal(p, "/")


@case("generate-own-folder-again", 4)
def _(folder: Path, stock: Stock) -> Outcome:
    args = ["generate", "curve", "--set", "radius=50", "--set", "angle=30", "--no-preview", "--out", folder / "s"]
    first, again = simgap(*args, cwd=folder), simgap(*args, cwd=folder)
    return problem(first) or expect(again, first.rc == 0 and again.rc == 0, "its own folder written again", OTHER,
                                    f"exit {first.rc}, then {again.rc}: {' '.join(again.stderr_lines())[:120]}")


KNOB_CASES_R5 = [  # name, options, what the refusal should name
    ("knob-realism-ideal-latency", ("--backend", "dynamic", "--realism", "ideal", "--knob", "latency=1"),
     ("knob latency", "realism ideal")),
    ("knob-realism-ideal-position-drift", ("--backend", "dynamic", "--realism", "ideal", "--knob",
                                           "position_drift=10"), ("knob position_drift", "realism ideal")),
    ("knob-twice", ("--backend", "dynamic", "--knob", "latency=0.1", "--knob", "latency=0.5"),
     ("knob latency", "twice")),
]
for _name, _options, _names in KNOB_CASES_R5:
    case(_name, 7)(_option_case(_options, _names))
case("spec-latency-1000", 7)(_spec_case(SPEC_TWO_RUNS.replace("{replan_every: 3}", "{replan_every: 3, latency: 1000}"),
                                        ("cosim.latency", "measured", "up to 1")))
case("isolate-tcp-planner", 11)(_option_case(("--planner", "tcp://127.0.0.1:5999", "--isolate"), ("isolate",)))


def _workers_of(pid: int) -> list[int]:
    """The pool workers among ``pid``'s children (Linux /proc)."""
    found = []
    for task in Path(f"/proc/{pid}/task").glob("*"):
        try:
            found += [int(c) for c in (task / "children").read_text().split()]
        except OSError:
            pass
    return [c for c in found if "multiprocessing" in Path(f"/proc/{c}/cmdline").read_text(errors="replace")]


def _alive(pid: int) -> bool:
    try:
        return Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0] != "Z"
    except OSError:
        return False


def _driver_stopped(child: Child, how: signal.Signals, wait_s: float) -> tuple[Outcome | None, object, str]:
    """``how`` sent to ``child`` (a command whose pool runs its work) once a pool worker runs, to the
    driver alone: (an outcome when the stop went wrong — no worker, one left running, a traceback —
    else None, the driver's end, its standard error)."""
    deadline, workers = time.monotonic() + wait_s, []
    while time.monotonic() < deadline and not workers and _alive(child.popen.pid):
        time.sleep(0.2)
        workers = _workers_of(child.popen.pid)
    if not workers:
        child.kill()
        return Outcome(OTHER, "no pool worker started", child.wait().stderr), None, ""
    time.sleep(1.0)
    os.kill(child.popen.pid, how)                     # the driver alone
    p = child.wait(timeout=30)
    time.sleep(5.0)                                   # an orphan would finish its run and speak by now
    orphans = [w for w in workers if _alive(w)]
    for w in orphans:
        os.kill(w, signal.SIGKILL)
    text = child.err_file.read_text(errors="replace")
    if orphans or "Traceback" in text:
        return Outcome(LOSS if orphans else TRACEBACK, f"{len(orphans)} worker(s) left running; "
                       f"stderr: {' '.join(text.split())[:100]}", text), p, text
    return None, p, text


def _stopped_experiment_case(how: signal.Signals):
    def run(folder: Path, stock: Stock) -> Outcome:
        (folder / "spec.yaml").write_text(SPEC_TWO_RUNS.replace("{backend: ideal}", "{backend: dynamic}"))
        child = Child(["experiment", "run", folder / "spec.yaml", "--out", folder / "exp", "--workers", "1",
                       "--no-report", "--no-validate"], folder)
        wrong, p, text = _driver_stopped(child, how, 60)
        if wrong is not None:
            return wrong
        if how == signal.SIGTERM:
            lines = [line for line in text.splitlines() if line.strip()]
            return expect(p, p.rc not in (0, -15) and len(lines) == 1, f"exit {p.rc}, one line, no worker left",
                          OTHER, f"exit {p.rc}: {' '.join(lines)[:120]}")
        return Outcome(HANDLED, "the worker ended with its driver, nothing printed later", text)
    return run


case("sigterm-experiment-driver", 10)(_stopped_experiment_case(signal.SIGTERM))
case("sigkill-experiment-driver", 10)(_stopped_experiment_case(signal.SIGKILL))


@case("sigkill-render-3d-rerun", 10)
def _(folder: Path, stock: Stock) -> Outcome:
    pictures = folder / "pictures"
    child = Child(["render", stock.run, "--3d", "--out", pictures], folder)
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline and not (pictures / "scene.png").exists():
        time.sleep(0.1)
    child.kill()
    child.wait()
    half = sorted(p.name for p in pictures.glob("*")) if pictures.exists() else []
    again = simgap("render", stock.run, "--3d", "--out", pictures, cwd=folder, timeout=300)
    leftovers = sorted(p.name for p in pictures.glob(".*")) if pictures.exists() else []
    ok = again.rc == 0 and not leftovers
    return expect(again, ok, f"killed with {half}; the rerun drew it whole", LOSS,
                  f"killed with {half}; rerun exit {again.rc}: {' '.join(again.stderr_lines())[:100]}; "
                  f"hidden leftovers {leftovers}")


@case("sigkill-export-leftovers", 10)
def _(folder: Path, stock: Stock) -> Outcome:
    out = folder / "exported"
    child = Child(["export", stock.run, "--out", out], folder)
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline and not list(out.glob(".*.tmp")):
        time.sleep(0.05)
    child.kill()
    child.wait()
    again = simgap("export", stock.run, "--out", out, cwd=folder)
    leftovers = sorted(p.name for p in out.glob(".*.tmp"))
    return expect(again, again.rc == 0 and not leftovers, "the rerun wrote it and removed the killed one's staging",
                  LOSS, f"rerun exit {again.rc}; hidden leftovers {leftovers}")


# --- round 5, hostile (issue 54): the kinds the sweep lacked — item 1 a planner's 300 MB on stderr, item 10
# SIGTERM/SIGKILL of a search's driver, SIGTERM of `simgap run`, `render --3d` on a full disk; and SIGKILL of a run
# while its solution is checked (the check's process is a fork of simgap's since issue 54 item 11)

@case("r5-planner-stderr-300mb", 1)
def _(folder: Path, stock: Stock) -> Outcome:
    (folder / "loud.py").write_text("import sys\nfor _ in range(300):\n    sys.stderr.write('x' * (1 << 20))\n"
                                    "sys.exit(3)\n")
    p = simgap("run", stock.scenario, "--no-validate", "--planner", f"exec:{sys.executable} {folder / 'loud.py'}",
               "--out", folder / "r", cwd=folder, timeout=90)
    reason = _r5_record(folder).get("history", {}).get("planner_errors", [{}])[0].get("message", "")
    return expect(p, p.max_rss_mb < 600 and "exited with code 3" in reason and len(reason) < 3000,
                  f"recorded with the end of its output ({len(reason)} characters), peak {p.max_rss_mb:.0f} MB",
                  OTHER, f"exit {p.rc}, peak {p.max_rss_mb:.0f} MB, a reason of {len(reason)} characters")


SEARCH_FOUR_RUNS = ("name: t\nlogical: curve\nparameters: {radius: {min: 10, max: 50}, angle: {min: 30, max: 90}}\n"
                    "ladder: [{backend: ideal}, {backend: dynamic}]\nstrategies: [grid]\n")


def _stopped_search_case(how: signal.Signals):
    def run(folder: Path, stock: Stock) -> Outcome:
        (folder / "search.yaml").write_text(SEARCH_FOUR_RUNS)
        child = Child(["search", folder / "search.yaml", "--budget", "4", "--out", folder / "s", "--workers", "1",
                       "--no-explain", "--no-report", "--no-validate"], folder)
        wrong, p, text = _driver_stopped(child, how, 300)
        if wrong is not None:
            return wrong
        lines = [line for line in text.splitlines() if line.strip()]
        if how == signal.SIGTERM:
            return expect(p, p.rc == 128 + signal.SIGTERM and len(lines) == 1, f"exit {p.rc}, one line, no worker left",
                          OTHER, f"exit {p.rc}: {' '.join(lines)[:120]}")
        resumed = simgap("search", folder / "search.yaml", "--budget", "4", "--out", folder / "s", "--workers", "1",
                         "--no-explain", "--no-report", "--no-validate", cwd=folder, timeout=300)
        return expect(resumed, resumed.rc in (0, 1), "the worker ended with its driver; the rerun finished the search",
                      LOSS, f"rerun exit {resumed.rc}: {' '.join(resumed.stderr_lines())[:120]}")
    return run


case("sigterm-search-driver", 10)(_stopped_search_case(signal.SIGTERM))
case("sigkill-search-driver", 10)(_stopped_search_case(signal.SIGKILL))

R5_SLOW_PLANNER = """
from pathlib import Path
import time

from simgap.planning.idm_planner import IdmPlanner


class Slow(IdmPlanner):
    def plan(self, observed, t, world):
        Path("planning").write_text("1")
        time.sleep(0.2)
        return super().plan(observed, t, world)
"""


@case("sigterm-run-says-so", 10)
def _(folder: Path, stock: Stock) -> Outcome:
    (folder / "slow.py").write_text(R5_SLOW_PLANNER)
    child = Child(["run", stock.scenario, "--no-validate", "--planner", "slow.py:Slow", "--out", folder / "r"], folder)
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline and not (folder / "planning").exists():
        time.sleep(0.05)
    os.kill(child.popen.pid, signal.SIGTERM)
    p = child.wait(timeout=30)
    verdict = problem(p)
    if verdict:
        return verdict
    left = sorted(f.name for f in (folder / "r").glob("*")) if (folder / "r").exists() else []
    return expect(p, p.rc == 128 + signal.SIGTERM and len(p.stderr_lines()) == 1 and "SIGTERM" in p.stderr
                  and not left, "exit 143, one line, no half-written run", OTHER,
                  f"exit {p.rc}, {len(p.stderr_lines())} lines, left {left[:3]}: {' '.join(p.stderr_lines())[:100]}")


@case("render-3d-full-disk", 10)
def _(folder: Path, stock: Stock) -> Outcome:
    disk, run = folder / "disk", stock.run                  # the run built before the mount
    with tmpfs(disk, "size=64k") as mounted:
        if not mounted:
            return Outcome(SKIPPED, "cannot mount a tmpfs here")
        p = simgap("render", run, "--3d", "--out", disk / "out", cwd=folder)
        kept = sorted(str(f.relative_to(disk)) for f in disk.rglob("*"))
        hidden = [f for f in kept if Path(f).name.startswith(".")]
        grown = subprocess.run(["mount", "-o", "remount,size=256m", "tmpfs", str(disk)], capture_output=True)
        again = simgap("render", run, "--3d", "--out", disk / "out", cwd=folder, timeout=300) \
            if grown.returncode == 0 else None
    verdict = problem(p) or (again and problem(again))
    if verdict:
        return verdict
    said = p.rc in (1, 2, 3) and len(p.stderr_lines()) == 1 and "space" in p.stderr
    redone = again is not None and again.rc == 0
    return expect(p, said and not hidden and redone, f"one line, whole pictures kept ({len(kept)}), the rerun "
                  "with room drew the rest", LOSS, f"exit {p.rc}, hidden {hidden[:3]}, rerun exit "
                  f"{again.rc if again else None}: {' '.join((again or p).stderr_lines())[:100]}")


@case("sigkill-run-while-checked", 11)
def _(folder: Path, stock: Stock) -> Outcome:
    out = folder / "r"
    child = Child(["run", stock.scenario, "--out", out], folder, env={"SIMGAP_CACHE_DIR": str(folder / "cache")})
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline and not (out / "run.json").exists():
        time.sleep(0.02)
    time.sleep(0.3)                                       # the run saved, its check under way
    checkers = [c for task in Path(f"/proc/{child.popen.pid}/task").glob("*")
                for c in (task / "children").read_text().split()] if _alive(child.popen.pid) else []
    child.kill()
    child.wait()
    time.sleep(2.0)
    left = [int(c) for c in checkers if _alive(int(c))]
    for pid in left:
        os.kill(pid, signal.SIGKILL)
    again = simgap("run", stock.scenario, "--out", out, cwd=folder, env={"SIMGAP_CACHE_DIR": str(folder / "cache")},
                   timeout=300)
    record = run_record(out) or {}
    valid = [a.get("solution_valid") for a in record.get("agents", [])]
    return expect(again, not left and again.rc == 0 and valid == [True],
                  f"{len(checkers)} checker process(es) ended with simgap; the rerun checked the run (valid)",
                  LOSS, f"{len(left)} process(es) left; rerun exit {again.rc}, verdicts {valid}")


# -- a long export speaks (issue 54, item 10): a 20 000-road scenario (bench/export/many_roads.py) exported with its
# bars forced onto standard error; the case waits until a bar of its per-road fitting says how long is left, or
# the time limit, and stops the export there (the whole export takes long: bench/export/many_roads.py times it)
MANY_ROADS = 20_000
_DRAWING = re.compile(r"\x1b\[[0-9;?]*[A-Za-z]")


def _many_roads_xml(path: Path, roads: int) -> Path:
    spec = importlib.util.spec_from_file_location("many_roads", REPO / "bench" / "export" / "many_roads.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module.many_roads_xml(path, roads)


@case(f"export-{MANY_ROADS}-roads-progress", 10)
def _(folder: Path, stock: Stock) -> Outcome:
    xml = _many_roads_xml(folder / "roads.xml", MANY_ROADS)
    child = Child(["export", xml, "--format", "opendrive", "--out", folder / "out"], folder,
                  env={"SIMGAP_PROGRESS": "always", "COLUMNS": "150"})
    first, fitting = None, None
    while time.monotonic() - child.start < TIMEOUT_S and child.popen.poll() is None and fitting is None:
        time.sleep(0.5)
        text = _DRAWING.sub("", child.err_file.read_text(errors="replace")).replace("\r", "\n")
        if first is None and "elapsed," in text:
            first = time.monotonic() - child.start
        bars = [line for line in text.splitlines() if line.startswith("fitting roads") and "-:--:-- left" not in line]
        fitting = " ".join(w for w in bars[-1].split()[2:] if w.strip("━╸╺")) if bars else None
    seconds = time.monotonic() - child.start
    child.kill()
    p = child.wait()
    if first is None:
        return Outcome(SILENT, f"nothing on stderr for {seconds:.0f} s", p.stderr, seconds)
    if fitting is None:
        return Outcome(OTHER, f"first bar after {first:.0f} s, no per-road fitting bar with the time left within "
                       f"{seconds:.0f} s", "", seconds)
    return Outcome(HANDLED, f"first bar after {first:.0f} s; after {seconds:.0f} s: fitting roads {fitting}", "",
                   seconds)

def main(argv: list[str] | None = None) -> int:
    global TIMEOUT_S
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--json", type=Path, help="write every case's outcome to this file")
    parser.add_argument("--only", nargs="+", help="run only cases whose name contains one of these")
    parser.add_argument("--timeout", type=float, default=TIMEOUT_S, help="wall-time limit per command [s]")
    parser.add_argument("--keep", type=Path, help="keep every case's folder here")
    parser.add_argument("--list", action="store_true", help="list the cases and exit")
    args = parser.parse_args(argv)
    results_file = BenchmarkResults()
    TIMEOUT_S = args.timeout
    cases = [c for c in CASES if not args.only or any(s in c.name for s in args.only)]
    if args.list:
        for c in cases:
            print(f"{c.item:>2}  {c.name}")
        return 0
    if args.keep:
        args.keep.mkdir(parents=True, exist_ok=True)
    root = Path(tempfile.mkdtemp(prefix="simgap-hostile-", dir=args.keep))
    stock = Stock(root)
    results = []
    try:
        for i, c in enumerate(cases, 1):
            outcome = run_case(c, root, stock)
            results.append({"case": c.name, "item": c.item, **asdict(outcome)})
            print(f"[{i}/{len(cases)}] {c.name}: {outcome.verdict} ({outcome.seconds:.1f} s) {outcome.note}",
                  file=sys.stderr, flush=True)
    finally:
        if args.keep is None:
            shutil.rmtree(root, ignore_errors=True)
    print_table(results)
    if args.json:
        results_file.write(args.json, {"cases": results, "counts": {
            v: sum(r["verdict"] == v for r in results) for v in VERDICTS}})
    return 0


if __name__ == "__main__":
    sys.exit(main())
