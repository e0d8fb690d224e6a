"""The BeamNG.tech backend without a server: road conversion, the vehicle catalogue, state
conversion from BeamNG's messages, the unreachable-server error, and whole runs against a fake
server that speaks BeamNG's formats. Tests that need a real server are at the end; they run when
SIMGAP_BEAMNG_HOST names one (README: BeamNG.tech)."""

from __future__ import annotations

import json
import math
import os
import socket
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from commonroad.scenario.lanelet import LineMarking
from evaluated import recorded
from fake_server import REF_OFFSET, FakeServer
from shapely.geometry import LineString, Point

from simgap.cosim import CosimSettings, simulate
from simgap.cosim.agents import agents_from_problems
from simgap.errors import InputError
from simgap.planning.frenet import FrenetPlanner
from simgap.planning.protocol import PlannerSetup
from simgap.scenario import build_scenario, write_scenario
from simgap.sim.beamng import BeamngBackend
from simgap.sim.beamng.catalogue import DEFAULT_MODELS, MODELS, model_for
from simgap.sim.beamng.convert import (
    bbox_centre,
    forward_of,
    quat_from_yaw,
    reference_offset,
    steering_input,
    to_state,
    yaw_of,
)
from simgap.sim.beamng.roads import decal_roads
from simgap.sim.beamng.session import ServerUnreachable
from simgap.sim.beamng.settings import Materials, load_settings
from simgap.vehicles import load_vehicle

DATA = Path(__file__).parent / "data"


# --- roads ---------------------------------------------------------------------------------
@pytest.mark.parametrize("radius", [10.0, 30.0, 100.0])
def test_lanelets_become_decal_roads_that_keep_their_shape(radius):
    network = build_scenario("curve", {"radius": radius, "angle": 150}).scenario.lanelet_network
    roads = {r.rid: r for r in decal_roads(network, Materials())}
    for lanelet in network.lanelets:
        road = roads[f"lanelet_{lanelet.lanelet_id}"]
        assert road.material == "road_rubber_sticky" and road.drivable
        centre = LineString(lanelet.center_vertices)
        nodes = np.array(road.nodes)
        # every node on the centre line, with the lanelet's width there
        for x, y, _, w in nodes:
            assert centre.distance(Point(x, y)) < 0.01
            i = int(np.argmin(np.linalg.norm(lanelet.center_vertices - [x, y], axis=1)))
            assert w == pytest.approx(np.linalg.norm(lanelet.left_vertices[i] - lanelet.right_vertices[i]), abs=0.02)
        assert np.allclose(nodes[0, :2], lanelet.center_vertices[0]) and np.allclose(nodes[-1, :2],
                                                                                    lanelet.center_vertices[-1])
        spacing = np.linalg.norm(np.diff(nodes[:, :2], axis=0), axis=1)
        assert spacing.max() <= 10.0 + 1e-6
        # no flip: nodes no closer than half the road's width along the road (a chord is a little
        # shorter than its arc), but at the lanelet's very end
        assert spacing[:-1].min() >= 0.97 * 0.5 * nodes[:, 3].max()
        # shape kept: the chords between nodes stay within 5 cm of the lanelet's centre line
        chords = LineString(nodes[:, :2])
        worst = max(centre.distance(chords.interpolate(f, normalized=True)) for f in np.linspace(0, 1, 400))
        assert worst < 0.05, worst
        # both edges of the drawn road are simple curves (a folded edge crosses itself)
        for side in (1, -1):
            heading = np.arctan2(np.gradient(nodes[:, 1]), np.gradient(nodes[:, 0]))
            edge = nodes[:, :2] + side * 0.5 * nodes[:, 3:4] * np.column_stack([-np.sin(heading), np.cos(heading)])
            assert LineString(edge).is_simple


def test_markings_become_decal_roads_of_their_own_material():
    concrete = build_scenario("curve", {"radius": 30, "angle": 90, "lanes": 2})
    network = concrete.scenario.lanelet_network
    edge = network.lanelets[0]
    edge.line_marking_right_vertices = LineMarking.CURB         # a kerb on one outer edge
    materials = Materials(solid="paint_solid", dashed="paint_dashed", curb="kerb")
    roads = decal_roads(network, materials)
    by_kind = {k: [r for r in roads if r.kind == k] for k in ("lanelet", "marking", "curb")}
    assert len(by_kind["lanelet"]) == len(network.lanelets)
    bounds = {}
    for lanelet in network.lanelets:
        for xy, marking in ((lanelet.left_vertices, lanelet.line_marking_left_vertices),
                            (lanelet.right_vertices, lanelet.line_marking_right_vertices)):
            key = tuple(sorted([tuple(np.round(xy[0], 2)), tuple(np.round(xy[-1], 2))])) + (marking,)
            bounds[key] = marking
    expected = {m: sum(1 for v in bounds.values() if v == m) for m in set(bounds.values())}
    assert expected[LineMarking.DASHED] > 0
    assert sum(r.material == "paint_dashed" for r in by_kind["marking"]) == expected[LineMarking.DASHED]
    assert sum(r.material == "paint_solid" for r in by_kind["marking"]) == expected[LineMarking.SOLID]
    assert [r.material for r in by_kind["curb"]] == ["kerb"]
    assert all(not r.drivable and r.render_priority < by_kind["lanelet"][0].render_priority for r in roads
               if r.kind != "lanelet")
    assert {r.nodes[0][3] for r in by_kind["marking"]} == {0.12} and by_kind["curb"][0].nodes[0][3] == 0.3


def test_junction_lanelets_are_included():
    network = build_scenario("intersection", {}).scenario.lanelet_network
    rids = {r.rid for r in decal_roads(network, Materials())}
    assert {f"lanelet_{l.lanelet_id}" for l in network.lanelets} <= rids


def test_roads_and_cars_become_beamngpy_objects_without_a_server():
    pytest.importorskip("beamngpy")
    from simgap.sim.beamng.session import Spawn, scenario_objects

    network = build_scenario("curve", {"radius": 10, "angle": 90}).scenario.lanelet_network
    roads = decal_roads(network, Materials())
    spawn = Spawn("agent_1", "etk800", (10.0, -1.5, 0.0), quat_from_yaw(0.0))
    scenario, vehicles = scenario_objects("smallgrid", "simgap_test", roads, [spawn])
    assert [r.rid for r in scenario.roads] == [r.rid for r in roads]
    first = scenario.roads[0]
    assert first.material == "road_rubber_sticky" and first.nodes == list(roads[0].nodes)
    assert {r.drivability for r in scenario.roads} == {1, -1}
    car = vehicles["agent_1"]
    assert car.model == "etk800" and {"electrics", "damage"} <= set(car.sensors.data)


# --- catalogue -------------------------------------------------------------------------------
def test_catalogue_maps_the_papers_cars_and_can_be_overridden():
    assert {v: model_for(v).name for v in DEFAULT_MODELS} == {"sedan": "etk800", "suv": "hopper", "city": "autobello"}
    assert model_for("sedan", {"sedan": "hopper"}).name == "hopper"
    custom = model_for("truck", {"truck": "pickup"}, {"pickup": 0.6})
    assert (custom.name, custom.steer_lock) == ("pickup", 0.6)
    with pytest.raises(InputError, match="vehicle_models.truck"):
        model_for("truck")
    with pytest.raises(InputError, match="steer_locks.pickup"):
        model_for("truck", {"truck": "pickup"})
    with pytest.raises(InputError, match="unknown vehicle|no BeamNG model|not"):
        model_for("truck", {"truck": "pickup"}, {"pickup": 3.0})


def test_settings_come_from_the_environment_and_are_checked(monkeypatch):
    monkeypatch.setenv("SIMGAP_BEAMNG_HOST", "sim-box")
    monkeypatch.setenv("SIMGAP_BEAMNG_PORT", "4444")
    s = load_settings({})
    assert (s.host, s.port) == ("sim-box", 4444)
    assert load_settings({"port": 5555}).port == 5555           # the settings win over the environment
    with pytest.raises(InputError, match="controller_hz"):
        load_settings({"physics_hz": 60, "controller_hz": 50})
    with pytest.raises(InputError, match="backend_settings.driver"):
        load_settings({"driver": "autopilot"})
    monkeypatch.setenv("SIMGAP_BEAMNG_PORT", "lots")
    with pytest.raises(InputError, match="SIMGAP_BEAMNG_PORT"):
        load_settings({})


# --- state conversion ------------------------------------------------------------------------
@pytest.mark.parametrize("yaw", [0.0, 0.7, -2.5, math.pi])
def test_rotation_round_trip_and_beamng_forward_axis(yaw):
    assert math.isclose(math.remainder(yaw_of(quat_from_yaw(yaw)) - yaw, 2 * math.pi), 0.0, abs_tol=1e-12)
    assert np.allclose(forward_of((0, 0, 0, 1)), [0, -1, 0])       # BeamNG cars face -y unrotated


def test_state_from_beamng_messages():
    """A car heading 30 deg, at 12 m/s, braking and turning left, as beamngpy reports it."""
    poll = json.loads((DATA / "poll_turning_left.json").read_text())
    lock = MODELS["etk800"].steer_lock
    centre = bbox_centre(poll["bbox"])
    state = to_state(4.2, poll["state"], centre, poll["electrics"], poll["imu"], lock)
    assert (state.x, state.y) == pytest.approx((50.0, 20.0), abs=1e-6)
    assert state.yaw == pytest.approx(math.radians(30), abs=1e-6)
    assert state.v == pytest.approx(12.0, abs=1e-6)
    assert state.a == pytest.approx(-2.0, abs=1e-6)             # along the heading, not the raw x axis
    assert state.yaw_rate == pytest.approx(0.25, abs=1e-6)       # about world up, whatever the sensor's axes
    assert state.steer == pytest.approx(0.2 * lock)             # input -0.2 (left) is +0.2 lock in simgap
    assert steering_input(state.steer, lock) == pytest.approx(poll["electrics"]["steering_input"])
    # the reference node sits ahead of the centre, as the message says
    offset = reference_offset(poll["state"], centre)
    assert offset == pytest.approx([1.3, 0.0, 0.5], abs=1e-6)


# --- the unreachable server ------------------------------------------------------------------
def _closed_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def test_unreachable_server_is_a_clear_error():
    concrete = build_scenario("curve", {"radius": 30, "angle": 90})
    agents = agents_from_problems(concrete.problems, concrete.scenario.dt, load_vehicle("sedan"))
    backend = BeamngBackend(load_settings({"host": "127.0.0.1", "port": _closed_port(), "connect_timeout": 1.0}))
    with pytest.raises(ServerUnreachable, match=r"no BeamNG.tech server answers at 127.0.0.1:\d+") as err:
        backend.load(concrete.scenario, agents)
    assert "SIMGAP_BEAMNG_HOST" in str(err.value)


def test_cli_run_without_server_exits_with_the_reason_and_writes_nothing(tmp_path):
    path = write_scenario(build_scenario("curve", {"radius": 30, "angle": 90}), tmp_path, preview=False)
    config = tmp_path / "beamng.yaml"
    config.write_text("host: 127.0.0.1\nconnect_timeout: 1\n")
    env = os.environ | {"SIMGAP_BEAMNG_PORT": str(_closed_port())}
    out = tmp_path / "run"
    proc = subprocess.run([sys.executable, "-m", "simgap", "run", str(path), "--backend", "beamng",
                           "--backend-config", str(config), "--out", str(out)],
                          capture_output=True, text=True, env=env, timeout=120)
    assert proc.returncode == 2, proc.stderr
    assert "no BeamNG.tech server answers at 127.0.0.1" in proc.stderr and "Traceback" not in proc.stderr
    assert not out.exists()


# --- whole runs against the fake server ---------------------------------------------------------
def _run(concrete, servers, **settings):
    scenario, problems = concrete.scenario, concrete.problems
    sedan = load_vehicle("sedan")
    agents = agents_from_problems(problems, scenario.dt, sedan)
    planners = {a.id: FrenetPlanner(PlannerSetup.for_problem(problems.planning_problem_dict[a.id], sedan, scenario.lanelet_network))
                for a in agents}

    def connect(cfg):
        servers.append(FakeServer(cfg))
        return servers[-1]

    backend = BeamngBackend(load_settings(settings), session_factory=connect)
    cosim = CosimSettings(replan_every=3)
    return recorded(simulate(scenario, problems, backend, agents, planners, cosim), scenario, problems, cosim), agents


def test_controller_drives_the_sharp_curve_in_the_fake_server():
    servers = []
    concrete = build_scenario("curve", {"radius": 10, "angle": 90})
    run, agents = _run(concrete, servers)
    server = servers[0]
    assert run.agents[0].history.outcome == "goal_reached", run.history.events
    assert server.closed
    # the body's centre, not the reference node, starts on the agent's initial state
    first = run.history.driven[1][0]
    start = agents[0].initial_state
    assert (first.x, first.y, first.yaw) == pytest.approx((start.x, start.y, start.yaw), abs=1e-6)
    # synchronous stepping: 60 Hz x 0.1 s = 6 physics steps per scenario step, one control per tick
    loop_steps = len(run.history.driven[1]) - 1
    assert server.steps == 6 * loop_steps
    assert server.calls["control"] == 6 * loop_steps
    assert {r.kind for r in server.roads} == {"lanelet", "marking"}
    assert run.history.backend_notes[0].startswith("15 decal roads on level smallgrid; agent 1: sedan as etk800")


def test_script_ai_follows_the_plans_waypoints_in_the_fake_server():
    servers = []
    concrete = build_scenario("curve", {"radius": 30, "angle": 90})
    # the perfect machine: each plan goes to the script AI at the step it is made (a real car's
    # plans arrive a planning cycle later: test_a_plan_reaches_the_script_ai_after_its_latency)
    run, _ = _run(concrete, servers, driver="script_ai", realism="ideal")
    server = servers[0]
    assert run.agents[0].history.outcome == "goal_reached", run.history.events
    assert "control" not in server.calls
    assert len(server.scripts) == len(run.history.plans[1])           # one script per replanned plan
    vid, script = server.scripts[5]
    assert script[0]["t"] == pytest.approx(0.0) and all(b["t"] > a["t"] for a, b in zip(script, script[1:]))
    # waypoints are reference-node positions: ahead of the plan's centre positions
    plan = run.history.plans[1][5]
    x0, y0 = plan.x[0], plan.y[0]
    assert math.hypot(script[0]["x"] - x0, script[0]["y"] - y0) == pytest.approx(
        math.hypot(REF_OFFSET[0], REF_OFFSET[1]), abs=1e-6)


def test_a_plan_reaches_the_script_ai_after_its_latency():
    servers = []
    run, _ = _run(build_scenario("curve", {"radius": 30, "angle": 90}), servers, driver="script_ai")
    scripts, plans = servers[0].scripts, run.history.plans[1]
    assert run.agents[0].history.outcome == "goal_reached", run.history.events
    # the first plan drives at once; each later one from the step after it was made (measured latency: one cycle)
    assert run.agents[0].evaluation.plan_latency_max_s == pytest.approx(0.1)
    first_waypoints = [(round(s[0]["x"], 6), round(s[0]["y"], 6)) for _, s in scripts]
    assert len(set(first_waypoints)) == len(plans) == len(scripts)


def test_moving_start_is_approached_and_recorded():
    servers = []
    concrete = build_scenario("curve", {"radius": 50, "angle": 45, "initial_speed": 8})
    run, agents = _run(concrete, servers)
    assert run.agents[0].history.outcome == "goal_reached", run.history.events
    first = run.history.driven[1][0]
    assert first.v == pytest.approx(8.0, abs=0.05)
    assert (first.x, first.y) == pytest.approx((agents[0].initial_state.x, agents[0].initial_state.y), abs=1e-6)
    note = next(n for n in run.history.backend_notes if "moving start" in n)
    assert "8.00 m/s" in note and "run-up" in note and servers[0].calls["set_velocity"] == 1


def test_a_dropped_connection_fails_the_run_with_its_reason():
    concrete = build_scenario("curve", {"radius": 30, "angle": 90})
    sedan = load_vehicle("sedan")
    agents = agents_from_problems(concrete.problems, concrete.scenario.dt, sedan)
    planners = {a.id: FrenetPlanner(PlannerSetup.for_problem(concrete.problems.planning_problem_dict[a.id], sedan, concrete.scenario.lanelet_network)) for a in agents}
    servers = []

    def connect(cfg):
        servers.append(FakeServer(cfg, fail_on="step"))
        return servers[-1]

    with pytest.raises(ConnectionResetError, match="dropped the connection"):
        simulate(concrete.scenario, concrete.problems, BeamngBackend(session_factory=connect), agents, planners)
    assert servers[0].closed


# --- a real server ----------------------------------------------------------------------------
needs_server = pytest.mark.skipif(not os.environ.get("SIMGAP_BEAMNG_HOST"),
                                  reason="no BeamNG.tech server: set SIMGAP_BEAMNG_HOST (and _PORT, _HOME)")


@needs_server
@pytest.mark.parametrize("driver", ["controller", "script_ai"])
def test_real_server_drives_the_sharp_curve(tmp_path, driver):
    from simgap.experiment.single_run import RunRequest, execute

    path = write_scenario(build_scenario("curve", {"radius": 10, "angle": 90}), tmp_path, preview=False)
    run = execute(RunRequest(scenario=path, backend="beamng", vehicles="sedan",
                             backend_settings={"driver": driver}), tmp_path / "run")
    # reaching the goal of a sharp left turn needs the steering sign right
    assert run.agents[0].history.outcome == "goal_reached", run.history.events
    driven = run.history.driven[1]
    assert driven[0].v == pytest.approx(0.0, abs=0.2)
    # the steering lock: in the curve, the yaw rate is what the road-wheel angle makes of the speed
    wheelbase = load_vehicle("sedan").wheelbase
    turning = [(s.yaw_rate, s.v * math.tan(s.steer) / wheelbase) for s in driven if s.v > 3 and abs(s.steer) > 0.1]
    assert len(turning) > 10
    ratio = np.median([measured / kinematic for measured, kinematic in turning])
    assert 0.7 < ratio < 1.3, f"yaw rate / kinematic yaw rate = {ratio:.2f}: set steer_locks for this build"


def test_experiment_with_an_unreachable_server_stops_before_any_run(tmp_path):
    spec = tmp_path / "bng.yaml"
    spec.write_text(f"""name: bng
logical: curve
parameters:
  radius: {{values: [10, 30]}}
  angle: {{values: [90]}}
sampler: {{kind: grid}}
fidelities:
  - backend: ideal
  - backend: beamng
    settings: {{host: 127.0.0.1, port: {_closed_port()}, connect_timeout: 1}}
""")
    out = tmp_path / "exp"
    proc = subprocess.run([sys.executable, "-m", "simgap", "experiment", "run", str(spec), "--out", str(out),
                           "--workers", "1"], capture_output=True, text=True, timeout=120)
    assert proc.returncode == 2, proc.stderr
    assert "no BeamNG.tech server answers at 127.0.0.1" in proc.stderr and "Traceback" not in proc.stderr
    assert not (out / "store").exists()
