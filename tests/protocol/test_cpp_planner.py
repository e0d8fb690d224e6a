"""The planner protocol outside Python: examples/cpp_lane_keeper, a C++ lane keeper (libzmq and
protoc's C++ messages), built here with its Makefile, asked over the protocol directly (replies,
errors, its exit after Close) and driven by simgap (`--planner exec:...`) in the ideal world and
in MuJoCo."""

from __future__ import annotations

import math
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import pytest
import zmq
from shapely.geometry import LineString, Point
from simgap_planner import simgap_planner_pb2 as pb

from simgap.experiment.single_run import RunRequest, execute
from simgap.planning.registry import PlannerChoice
from simgap.planning.route import route_centre_line
from simgap.record import read_run
from simgap.scenario import build_scenario, load_scenario, write_scenario

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "cpp_lane_keeper"
PROGRAM = EXAMPLE / "build" / "lane_keeper"
DT = 0.1
FIELDS = ("t", "x", "y", "yaw", "v", "a", "yaw_rate", "steer")
TOOLS = ("g++", "make", "protoc", "pkg-config")


def _missing_toolchain() -> str | None:
    missing = [tool for tool in TOOLS if shutil.which(tool) is None]
    if missing:
        return f"no {', '.join(missing)} on PATH (make test installs the toolchain: make planner-toolchain)"
    libraries = [lib for lib in ("protobuf", "libzmq") if subprocess.run(["pkg-config", "--exists", lib]).returncode]
    if libraries:
        return f"pkg-config finds no {', '.join(libraries)} (Debian: libprotobuf-dev, libzmq3-dev; make planner-toolchain)"
    return None


@pytest.fixture(scope="module")
def lane_keeper() -> Path:
    """The example's program, built (make is incremental: a second run only checks)."""
    reason = _missing_toolchain()
    if reason:
        pytest.skip(reason)
    started = time.perf_counter()
    proc = subprocess.run(["make", "-C", str(EXAMPLE)], capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    print(f"built {PROGRAM} in {time.perf_counter() - started:.1f} s")
    return PROGRAM


class Server:
    """The program started as simgap starts it (its endpoint in SIMGAP_PLANNER_ENDPOINT), and a REQ socket to it."""

    def __init__(self, program: Path):
        self.folder = tempfile.mkdtemp(prefix="simgap-cpp-")
        endpoint = f"ipc://{self.folder}/planner.sock"
        self.process = subprocess.Popen([str(program)], env=dict(os.environ, SIMGAP_PLANNER_ENDPOINT=endpoint),
                                        stdout=subprocess.PIPE, stderr=subprocess.PIPE)
        self.context = zmq.Context()
        self.socket = self.context.socket(zmq.REQ)
        self.socket.setsockopt(zmq.LINGER, 0)
        self.socket.setsockopt(zmq.RCVTIMEO, 5000)
        self.socket.connect(endpoint)
        self.ids = iter(range(1, 1000))

    def send_raw(self, raw: bytes) -> pb.Reply:
        self.socket.send(raw)
        return pb.Reply.FromString(self.socket.recv())

    def call(self, request: pb.Request) -> pb.Reply:
        request.id = next(self.ids)
        reply = self.send_raw(request.SerializeToString())
        assert reply.id == request.id
        return reply

    def initialize(self, route: np.ndarray, settings: str = "{}", version: str = "1.0") -> pb.Reply:
        request = pb.Request()
        init = request.initialize
        init.protocol_version, init.agent_id, init.dt, init.settings_json = version, 1, DT, settings
        init.vehicle.name, init.vehicle.wheelbase = "sedan", 2.7
        init.route.x, init.route.y = _column(route[:, 0]), _column(route[:, 1])
        return self.call(request)

    def plan(self, session: int, t: float, x: float, y: float, v: float, yaw: float = 0.0) -> pb.Reply:
        request = pb.Request()
        request.plan.session, request.plan.t = session, t
        request.plan.observed.t, request.plan.observed.x, request.plan.observed.y = t, x, y
        request.plan.observed.v, request.plan.observed.yaw = v, yaw
        return self.call(request)

    def close_session(self, session: int) -> pb.Reply:
        request = pb.Request()
        request.close.session = session
        return self.call(request)

    def stop(self) -> None:
        if self.process.poll() is None:
            self.process.kill()
        self.process.wait()
        self.socket.close(linger=0)
        self.context.term()
        shutil.rmtree(self.folder, ignore_errors=True)


@pytest.fixture
def server(lane_keeper):
    server = Server(lane_keeper)
    yield server
    server.stop()


def _bend(radius: float = 50.0) -> np.ndarray:
    """20 m straight along x, then a left quarter circle of ``radius`` centred on (0, radius), 1 m apart."""
    straight = np.column_stack([np.arange(-20.0, 0.0), np.zeros(20)])
    angle = np.linspace(0.0, math.pi / 2, int(radius * math.pi / 2) + 1)
    return np.vstack([straight, np.column_stack([radius * np.sin(angle), radius * (1 - np.cos(angle))])])


def _column(values) -> bytes:
    """A column of the protocol: float64, little-endian."""
    return np.asarray(values, dtype="<f8").tobytes()


def _columns(reply: pb.Reply) -> dict[str, np.ndarray]:
    assert reply.WhichOneof("body") == "plan", reply
    assert reply.plan.WhichOneof("result") == "trajectory", reply.plan
    trajectory = reply.plan.trajectory
    assert trajectory.dt == pytest.approx(DT)
    return {name: np.frombuffer(getattr(trajectory, name), dtype="<f8") for name in FIELDS}


def test_plans_along_the_route_on_the_time_grid(server):
    ready = server.initialize(_bend())
    assert ready.WhichOneof("body") == "ready", ready
    assert (ready.ready.protocol_version, ready.ready.planner) == ("1.0", "cpp_lane_keeper")
    assert ready.ready.session >= 1
    timings = []
    for t, (x, y, v) in [(0.0, (-20.0, 0.4, 0.0)), (1.3, (-1.0, -0.3, 6.0)), (4.2, (35.36, 14.64, 12.0))]:
        started = time.perf_counter()
        plan = _columns(server.plan(ready.ready.session, t, x, y, v))
        timings.append(time.perf_counter() - started)
        assert len(plan["t"]) == 31                                       # 3 s at 0.1 s, both ends
        assert np.allclose(plan["t"], t + DT * np.arange(31))            # starts at t, on the grid
        assert all(np.isfinite(column).all() for column in plan.values())
        assert np.allclose(plan["v"], np.clip(v + 1.5 * DT * np.arange(31), None, max(v, 5.0)))   # held, or up to 5 m/s
        on_route = LineString(_bend())
        assert max(on_route.distance(Point(px, py)) for px, py in zip(plan["x"], plan["y"])) < 0.02
        start = on_route.project(Point(x, y))                              # it starts at the projection ...
        assert on_route.project(Point(plan["x"][0], plan["y"][0])) == pytest.approx(start, abs=0.01)
        step = np.hypot(np.diff(plan["x"]), np.diff(plan["y"]))           # ... and marches at its speed
        assert np.allclose(step, 0.5 * (plan["v"][1:] + plan["v"][:-1]) * DT, atol=0.01)
        heading = np.arctan2(np.diff(plan["y"]), np.diff(plan["x"]))      # the route's, between two states
        between = np.angle(np.exp(1j * plan["yaw"][:-1]) + np.exp(1j * plan["yaw"][1:]))
        assert np.allclose(np.angle(np.exp(1j * (between - heading))), 0.0, atol=0.01)
    # on the arc: curvature 1/50 m, yaw rate v / r, steering atan(wheelbase / r)
    assert np.allclose(plan["yaw_rate"][:5], 12.0 / 50.0, rtol=0.02)
    assert np.allclose(plan["steer"][:5], math.atan(2.7 / 50.0), rtol=0.02)
    print(f"planning round trips: {', '.join(f'{1e3 * s:.2f} ms' for s in timings)}")


def test_a_setting_sets_the_cruise_speed(server):
    ready = server.initialize(_bend(), settings='{"cruise_speed": 8.5}')
    plan = _columns(server.plan(ready.ready.session, 0.0, -20.0, 0.0, 8.5))
    assert np.allclose(plan["v"], 8.5) and np.allclose(plan["a"], 0.0)


def test_bad_requests_get_error_replies_and_close_ends_the_process(server):
    garbage = server.send_raw(b"not a protobuf message")
    assert garbage.WhichOneof("body") == "error" and garbage.error.type == "DecodeError", garbage
    assert server.call(pb.Request()).error.type == "EmptyRequest"
    assert server.plan(7, 0.0, 0.0, 0.0, 5.0).error.type == "UnknownSession"
    assert server.initialize(_bend(), version="2.0").error.type == "ProtocolVersion"
    no_route = server.initialize(np.zeros((0, 2)))                 # simgap found no route to the goal
    assert no_route.WhichOneof("body") == "error" and "route" in no_route.error.message, no_route
    first, second = server.initialize(_bend()).ready.session, server.initialize(_bend()).ready.session
    assert first != second and 0 not in (first, second)
    assert server.process.poll() is None                           # still serving after all that
    assert server.close_session(first).WhichOneof("body") == "closed"
    assert server.plan(second, 0.0, -20.0, 0.0, 5.0).WhichOneof("body") == "plan"
    assert server.process.poll() is None                           # a session is still open
    assert server.close_session(second).WhichOneof("body") == "closed"
    assert server.process.wait(timeout=5) == 0                     # the last one closed: it exits
    assert server.process.stderr.read() == b""


def test_without_an_endpoint_it_says_where_to_find_one(lane_keeper):
    env = {k: v for k, v in os.environ.items() if k != "SIMGAP_PLANNER_ENDPOINT"}
    proc = subprocess.run([str(lane_keeper)], env=env, capture_output=True, text=True, timeout=10)
    assert proc.returncode == 2 and "SIMGAP_PLANNER_ENDPOINT" in proc.stderr


# ---------------------------------------------------------------------------------- with simgap

@pytest.fixture(scope="module")
def curve(tmp_path_factory) -> Path:
    return write_scenario(build_scenario("curve", {"radius": 50.0, "angle": 45.0}), tmp_path_factory.mktemp("curve"),
                          preview=False)


def _max_lateral_deviation(scenario: Path, run) -> float:
    """The driven centre's largest distance from the route's centre line [m]."""
    network, problems = load_scenario(scenario)
    agent = run.agents[0]
    route, _ = route_centre_line(network.lanelet_network, problems.planning_problem_dict[agent.id])
    line, driven = LineString(route), run.history.driven[agent.id]
    return max(line.distance(Point(x, y)) for x, y in zip(driven.x, driven.y))


@pytest.mark.parametrize("backend, bound_m", [("ideal", 0.05), ("mujoco", 0.3)])
def test_simgap_drives_the_curve_to_its_goal_with_the_cpp_planner(lane_keeper, curve, tmp_path, backend, bound_m):
    started = time.perf_counter()
    run = execute(RunRequest(scenario=curve, backend=backend, planner=PlannerChoice(planner=f"exec:{lane_keeper}")),
                  tmp_path / "run")
    elapsed = time.perf_counter() - started
    agent = run.agents[0]
    assert agent.history.outcome == "goal_reached", (run.failure, run.history.events, run.history.planner_errors)
    assert read_run(tmp_path / "run").agents[0].history.outcome == "goal_reached"              # as recorded
    assert agent.history.planner_failures == 0 and agent.evaluation.planning_calls > 100
    deviation = _max_lateral_deviation(curve, run)
    assert deviation < bound_m
    print(f"{backend}: {elapsed:.1f} s wall, {agent.evaluation.planning_calls} planning calls of {agent.evaluation.planning_mean_s * 1e3:.2f} ms "
          f"mean, max lateral deviation {deviation:.3f} m, time to goal {agent.history.time_to_goal_s} s")


def test_the_readme_command_runs(lane_keeper, curve, tmp_path):
    """`simgap run SCENARIO.xml --backend ideal --out OUT --planner exec:PATH` as the README gives it."""
    proc = subprocess.run([sys.executable, "-m", "simgap", "run", str(curve), "--backend", "ideal", "--no-validate",
                           "--out", str(tmp_path / "run"), "--planner", f"exec:{lane_keeper}"],
                          capture_output=True, text=True, timeout=600, env=dict(os.environ, COLUMNS="160"))
    assert proc.returncode == 0, proc.stdout + proc.stderr
    record = read_run(tmp_path / "run")
    assert (record.agents[0].planner, record.agents[0].history.outcome) == ("lane_keeper", "goal_reached")
    process = record.settings.planner.process              # what its Ready said, and how it went
    assert (process.planner, process.protocol_version, process.restarts) == ("cpp_lane_keeper", "1.0", 0)
