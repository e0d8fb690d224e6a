"""The ``beamng`` backend: every agent is a car in a running BeamNG.tech, for users who own the
paper's simulator (``pip install 'simgap[beamng]'``; see the README).

`load` lays every lanelet and marking out as decal roads (`roads`), spawns one BeamNG car per
agent (`catalogue` maps simgap vehicles to BeamNG models) and one per recorded obstacle, switches
physics to deterministic mode at ``physics_hz`` and pauses. `reset` moves each car so that its
body's centre, not BeamNG's reference node, sits on the agent's initial state. Each scenario dt
is then ``physics_hz × dt`` physics steps, taken while the simulation is otherwise paused.
`BeamngWorld` is the `Physics` and the loop is `simgap.sim.tracked`'s, as for the other physics
backends:

- ``driver: controller`` (default): every controller period simgap's tracking controller (the
  same as in the MuJoCo backend, with the same actuator-delay knobs) turns the plan in force and
  the measured state into steering, throttle and brake;
- ``driver: script_ai``: the paper's method, BeamNG's script AI following the plan's
  time-stamped waypoints, re-sent whenever the planner replans; the cars are then read only at
  the end of each scenario step.

The state read back after each step follows simgap's convention (`convert`); a jump in a car's
damage is a collision, attributed to the nearest other road user. A moving start, which BeamNG
cannot spawn, is approached by a run-up: the car is pushed to its initial speed with
``set_velocity`` over ``run_up_s`` and put back on its initial pose without resetting its
velocity; what was done and the speed reached are written to the run record (``backend_notes``).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Mapping, Sequence

import numpy as np
from commonroad.scenario.scenario import Scenario

from simgap.control.protocol import Command, Controller
from simgap.errors import InputError
from simgap.scenario.obstacles import recorded_obstacles
from simgap.scenario.relief import Surface
from simgap.sim.beamng.catalogue import model_for
from simgap.sim.beamng.convert import (
    DAMAGE_COLLISION,
    bbox_centre,
    quat_from_yaw,
    reference_offset,
    reference_position,
    steering_input,
    to_state,
)
from simgap.sim.beamng.roads import decal_roads
from simgap.sim.beamng.session import BeamngSession, Poll, Session, Spawn
from simgap.sim.beamng.settings import BeamngSettings, load_settings
from simgap.sim.protocol import Agent, BackendEvent, EventKind, Outcome, PhysicsDiverged, PlanInForce, enters_at
from simgap.sim.rates import SpeedRate, steps_per_tick
from simgap.sim.tracked import TrackedBackend
from simgap.trajectory import Attitude, State, Trajectory

MOVING_START = 0.1          # m/s: slower initial speeds are standstill starts


class BeamngWorld:
    """A running BeamNG.tech as the `Physics` of a tracked backend (see the module doc)."""

    def __init__(self, settings: BeamngSettings, session_factory: Callable[[BeamngSettings], Session]):
        self.settings = settings
        self._connect = session_factory
        self.timings = {"physics": 0.0}
        self.notes: list[str] = []
        self._events: list[BackendEvent] = []
        self.session: Session | None = None

    # --- Physics protocol -----------------------------------------------------------------------
    def load(self, scenario: Scenario, agents: Sequence[Agent], relief: Surface | None = None) -> None:
        cfg = self.settings
        self._dt = float(scenario.dt)
        self._agents = list(agents)
        if relief is not None:
            self.notes.append("the road's relief is not built in BeamNG: its roads lie on flat terrain")
        steps = cfg.physics_hz * self._dt
        if abs(steps - round(steps)) > 1e-6:
            raise InputError(f"the scenario's dt {self._dt:g} s is not a whole number of physics steps at "
                             f"{cfg.physics_hz} Hz", field="backend_settings.physics_hz",
                             allowed=f"a multiple of {1 / self._dt:g} Hz")
        self._steps_per_tick = steps_per_tick(cfg.physics_hz, cfg.controller_hz, "backend_settings.controller_hz")
        late = [a for a in agents if not enters_at(a, 0.0, self._dt)]
        if late:
            raise InputError(f"agent {late[0].id} enters at t = {late[0].initial_state.t:g} s; the beamng backend "
                             "spawns every car at the start", field="planning problem initial time step",
                             allowed="0 for every planning problem (mujoco, dynamic and ideal take later ones)")
        self._models = {a.id: model_for(a.vehicle.name, cfg.vehicle_models, cfg.steer_locks) for a in agents}
        self._traffic = recorded_obstacles(scenario)
        traffic_model = model_for("traffic", {"traffic": "etk800"} | cfg.vehicle_models, cfg.steer_locks)
        spawns = [Spawn(_vid(a.id), self._models[a.id].name, (a.initial_state.x, a.initial_state.y, 0.0),
                        quat_from_yaw(a.initial_state.yaw)) for a in agents]
        for o in self._traffic:
            s = o.motion.at(o.motion.t[0])
            spawns.append(Spawn(_obstacle_vid(o.id), traffic_model.name, (s.x, s.y, 0.0), quat_from_yaw(s.yaw)))
        roads = decal_roads(scenario.lanelet_network, cfg.materials, cfg.shape_tolerance, cfg.node_spacing)
        self.session = self._connect(cfg)
        try:
            self.session.build(f"simgap_{scenario.scenario_id}", roads, spawns, [_vid(a.id) for a in agents])
        except BaseException:
            self.close()
            raise
        self.notes.append(f"{len(roads)} decal roads on level {cfg.level}; " + ", ".join(
            f"agent {a.id}: {a.vehicle.name} as {self._models[a.id].name}" for a in agents)
            + f"; driver {cfg.driver}; {int(round(steps))} physics steps per dt at {cfg.physics_hz} Hz")

    def reset(self, t0: float) -> None:
        s, cfg = self.session, self.settings
        assert s is not None, "load() comes first"
        self._offset: dict[str, np.ndarray] = {}
        for vid in [_vid(a.id) for a in self._agents] + [_obstacle_vid(o.id) for o in self._traffic]:
            p = s.poll(vid)
            self._offset[vid] = reference_offset(p.state, bbox_centre(p.bbox))
        for a in self._agents:
            self._place(_vid(a.id), a.initial_state, reset=True)
        self._move_traffic(t0)
        moving = [a for a in self._agents if a.initial_state.v > MOVING_START]
        if moving:
            self._run_up(moving)
        self._accel = {a.id: SpeedRate(t0, a.initial_state.v, a.initial_state.a) for a in self._agents}
        self._damage = {}
        self._measured: dict[int, State] = {}
        for a in self._agents:
            poll = s.poll(_vid(a.id))
            self._damage[a.id] = float(poll.damage.get("damage", 0.0))
            self._measured[a.id] = self._read(a.id, poll, t0)
        for a in moving:
            self.notes.append(f"agent {a.id}: moving start at {a.initial_state.v:.2f} m/s approached by a "
                              f"{cfg.run_up_s:g} s run-up (set_velocity), then placed on its initial pose "
                              f"keeping its velocity; speed at t0 {self._measured[a.id].v:.2f} m/s")
        self._events = []

    def begin_step(self, t: float) -> None:
        self._events = []
        self._step_end = t + self._dt

    def measure(self, agent_id: int, t: float) -> State:
        """The car's state at ``t``: polled once per controller period (the state read at the end of
        a step serves the first period of the next)."""
        last = self._measured[agent_id]
        if abs(last.t - t) > 1e-9:
            s = self.session
            assert s is not None, "load() comes first"
            last = self._measured[agent_id] = self._read(agent_id, s.poll(_vid(agent_id)), t)
        return last

    def actuate(self, agent_id: int, command: Command, period: float) -> None:
        lock = self._models[agent_id].steer_lock
        s = self.session
        assert s is not None, "load() comes first"
        s.control(_vid(agent_id), steering_input(command.steer, lock),
                             min(max(command.throttle, 0.0), 1.0), min(max(command.brake, 0.0), 1.0))

    def advance(self, t: float, period: float) -> None:
        self._move_traffic(t)
        start = time.perf_counter()
        s = self.session
        assert s is not None, "load() comes first"
        s.step(self._steps_per_tick)
        self.timings["physics"] += time.perf_counter() - start
        if t + period >= self._step_end - 1e-9:            # the end of a scenario step: read every car
            polls = {a.id: s.poll(_vid(a.id)) for a in self._agents}
            self._measured = {aid: self._read(aid, p, self._step_end) for aid, p in polls.items()}
            self._collisions(polls, self._step_end)

    def enter(self, agent_id: int, t: float) -> None:
        """Never needed: `load` refuses a car that enters after the start (every car is spawned then)."""
        raise NotImplementedError("the beamng backend spawns every car at the start")

    def follow(self, agent_id: int, plan: Trajectory, now: float) -> None:
        """Hand ``plan`` from ``now`` on to BeamNG's script AI of the agent's car."""
        s = self.session
        assert s is not None, "load() comes first"
        s.set_script(_vid(agent_id), self._script(agent_id, plan, now))

    def attitude(self, agent_id: int) -> Attitude | None:
        return None

    def events(self) -> list[BackendEvent]:
        return list(self._events)

    def close(self) -> None:
        if self.session is not None:
            self.session.close()
            self.session = None

    # --- helpers ------------------------------------------------------------------------------
    def _place(self, vid: str, state: State, reset: bool) -> None:
        pos = reference_position(state.x, state.y, 0.0, state.yaw, self._offset[vid])
        s = self.session
        assert s is not None, "load() comes first"
        s.teleport(vid, pos, quat_from_yaw(state.yaw), reset)

    def _run_up(self, moving: list[Agent]) -> None:
        """Push the ``moving`` cars to their initial speeds (the others hold still on the brake),
        then put every car back on its initial pose; only the moving ones keep their velocity."""
        s, cfg = self.session, self.settings
        assert s is not None, "load() comes first"
        running = {a.id for a in moving}
        for a in self._agents:
            if a.id in running:
                s.set_velocity(_vid(a.id), a.initial_state.v, cfg.run_up_s)
            else:
                s.control(_vid(a.id), 0.0, 0.0, 1.0)
        s.step(max(1, round(cfg.run_up_s * cfg.physics_hz)))
        for a in self._agents:
            self._place(_vid(a.id), a.initial_state, reset=a.id not in running)

    def _read(self, agent_id: int, poll: Poll, t: float) -> State:
        for key in ("pos", "vel", "rotation"):
            if not np.all(np.isfinite(np.asarray(poll.state.get(key, [math.nan]), dtype=float))):
                raise PhysicsDiverged(f"agent {agent_id}: BeamNG reported no finite {key} at t = {t:.2f} s")
        state = to_state(t, poll.state, bbox_centre(poll.bbox), poll.electrics, poll.imu,
                         self._models[agent_id].steer_lock)
        accel = self._accel[agent_id].update(t, state.v)
        return state.replace(a=accel) if math.isnan(state.a) else state

    def _script(self, agent_id: int, plan: Trajectory, now: float) -> list[dict[str, float]]:
        """The plan from ``now`` on as script-AI nodes: reference-node positions, times from now."""
        offset = self._offset[_vid(agent_id)]
        nodes = []
        for st in plan:
            if st.t < now - 1e-9:
                continue
            x, y, z = reference_position(st.x, st.y, 0.0, st.yaw, offset)
            nodes.append({"x": x, "y": y, "z": z, "t": st.t - now})
        while len(nodes) < 3:              # the script AI needs three nodes; hold the last one
            last = dict(nodes[-1]) if nodes else {"x": self._measured[agent_id].x, "y": self._measured[agent_id].y,
                                                  "z": 0.0, "t": 0.0}
            last["t"] += self._dt
            nodes.append(last)
        return nodes

    def _traffic_at(self, t: float) -> list[tuple[int, State]]:
        """The recorded obstacles present at ``t``, with their recorded states."""
        return [(o.id, o.motion.at(t)) for o in self._traffic
                if o.motion.t[0] - 1e-9 <= t <= o.motion.t_end + 1e-9]

    def _move_traffic(self, t: float) -> None:
        for oid, state in self._traffic_at(t):
            self._place(_obstacle_vid(oid), state, reset=True)

    def _collisions(self, polls: Mapping[int, Poll], t: float) -> None:
        traffic = self._traffic_at(t)
        for aid, poll in polls.items():
            damage = float(poll.damage.get("damage", 0.0))
            rise, self._damage[aid] = damage - self._damage[aid], damage
            if rise < DAMAGE_COLLISION:
                continue
            me = self._measured[aid]
            others = [(oid, st) for oid, st in self._measured.items() if oid != aid] + traffic
            near = [(math.hypot(st.x - me.x, st.y - me.y), oid) for oid, st in others]
            if near:
                dist, other = min(near)
                self._events.append(BackendEvent(t, aid, Outcome.COLLISION, f"damage rose by {rise:.0f}; nearest road "
                                                 f"user {other} at {dist:.1f} m", other))
            else:
                self._events.append(BackendEvent(t, aid, EventKind.DAMAGE, f"damage rose by {rise:.0f}"))


class BeamngBackend(TrackedBackend):
    """The ``beamng`` backend: `BeamngWorld` under simgap's tracking controllers, or with each car
    driven by BeamNG's script AI on its plan's waypoints (``driver: script_ai``)."""

    physics: BeamngWorld

    def __init__(self, settings: BeamngSettings | None = None,
                 session_factory: Callable[[BeamngSettings], Session] | None = None):
        self.settings = settings or load_settings({})
        super().__init__("beamng", BeamngWorld(self.settings, session_factory or BeamngSession), self.settings)
        self._scripted: dict[int, Trajectory] = {}

    @property
    def session(self) -> Session | None:
        return self.physics.session

    def make_controller(self, agent: Agent) -> Controller | None:
        return super().make_controller(agent) if self.settings.driver == "controller" else None

    def reset(self) -> dict[int, State]:
        self._scripted = {}
        return super().reset()

    def step(self, plans: Mapping[int, PlanInForce]) -> dict[int, State]:
        if self.settings.driver == "script_ai":        # a plan goes to the script AI when it reaches the car
            now = self._step * self._dt
            for a in self._agents:
                in_force = plans[a.id]
                plan = in_force if isinstance(in_force, Trajectory) else in_force.plan
                if self._scripted.get(a.id) is not plan:
                    self.physics.follow(a.id, plan, now)
                    self._scripted[a.id] = plan
        return super().step(plans)


def _vid(agent_id: int) -> str:
    return f"agent_{agent_id}"


def _obstacle_vid(obstacle_id: int) -> str:
    return f"obstacle_{obstacle_id}"
