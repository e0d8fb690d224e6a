"""The ``mujoco`` backend: every agent is a car in a MuJoCo world, driven by its tracking
controller.

Each scenario dt, for every controller period (default 100 Hz): recorded traffic moves to where
its recording says; each car is measured (centre, yaw, speed, acceleration, yaw rate, road-wheel
steering angle — the ideal backend's convention) and its controller turns the plan in force into
steering, throttle and brake; the steering target moves towards the request at the steering
system's rate and within its angle; drive torque (capped by the powertrain's power), brakes,
drag and the friction of the surface under each tyre are set; then physics runs at its own rate
(default 500 Hz) until the next controller update, with slip-based tyre forces computed every
physics step (`simgap.sim.mujoco.tyre`; ``timings['tyres']`` is their share). The controllers
and that loop are `simgap.sim.tracked`'s; this module is the physics, `MujocoPhysics`. Physical
contacts with other cars or with traffic are reported as collision events; a chassis on its side
is a ``diverged`` event of that car, which is then taken out of the world (the others drive on); a
state that is no longer finite or a solver warning is `PhysicsDiverged` (the whole run).

The car's actuators (dead times and lags, the vehicle's or the knobs') act between its controller
and this world (`simgap.sim.tracked`). A road with a relief (the scenario's, `simgap.scenario.relief`)
is built as a terrain that the cars drive on (`simgap.sim.mujoco.world`, `terrain`; the tyres'
load, slip and forces in its tangent plane, gravity vertical); `attitude` is each car's height,
pitch and roll. Reality knobs of the world: its friction; ``road_bank`` and ``road_grade`` [deg]
tilt the road (`simgap.scenario.relief.RoadTilt`), and the run lays that tilt on the relief it
hands to `load` (`simgap.scenario.ground.ground_of`): a tilted road is a relief like any other.
"""

from __future__ import annotations

import math
import time
from collections.abc import Sequence

import mujoco
import numpy as np
from commonroad.scenario.scenario import Scenario

from simgap.control.protocol import Command
from simgap.errors import InputError
from simgap.scenario.relief import Surface, road_tilt
from simgap.sim.mujoco.car import ackermann_angles, max_single_track_angle, single_track_angle, up_z, yaw_of
from simgap.sim.mujoco.settings import MujocoSettings, WorldSettings
from simgap.sim.mujoco.world import World, build_world
from simgap.sim.protocol import Agent, BackendEvent, Outcome, PhysicsDiverged, enters_at
from simgap.sim.rates import SpeedRate, is_multiple, nearest_multiple
from simgap.sim.tracked import TrackedBackend
from simgap.trajectory import Attitude, State
from simgap.vehicles.constants import AIR_DENSITY, GRAVITY

PARKED = Command(steer=0.0, throttle=0.0, brake=1.0)     # what a car taken out of the world is given
PARKING_M = 100.0           # a car that has not entered the world yet waits this far beyond the road [m]
FLIPPED_UP_Z = 0.3          # chassis up axis below this (tilted > ~73 deg): the car is on its side


class MujocoPhysics:
    """The MuJoCo world as the `Physics` of a tracked backend: it measures, actuates and advances
    every car of a scenario (see the module doc)."""

    def __init__(self, settings: WorldSettings):
        self.settings = settings
        self.timings = {"physics": 0.0, "tyres": 0.0}
        self.notes: list[str] = []
        self.world: World | None = None
        self._events: list[BackendEvent] = []
        self._seen: set[tuple[int, int | None]] = set()

    # --- Physics protocol ------------------------------------------------------------------------
    def load(self, scenario: Scenario, agents: Sequence[Agent], relief: Surface | None = None) -> None:
        if relief is None and not road_tilt(self.settings).is_level:     # the run lays it on the ground it gives
            raise ValueError("road_bank and road_grade tilt the road's relief, which the caller lays on it "
                             "(simgap.experiment.run_scene); this world was given no relief to drive")
        self._agents = list(agents)
        self._dt = float(scenario.dt)
        self.world = world = build_world(scenario, agents, self.settings, relief, looks=False)
        cars = [world.cars[a.id] for a in agents]
        self._wheel_bodies = np.array([b for car in cars for b in car.wheel_bodies], dtype=int)
        self._steer_limit = {a.id: max_single_track_angle(world.cars[a.id].physics, a.vehicle.wheelbase)
                             for a in agents}
        model = world.model
        self._owner = np.full(model.ngeom, -1, dtype=int)
        for geom, aid in world.owner.items():
            self._owner[geom] = aid
        self._traffic_owner = np.full(model.ngeom, -1, dtype=int)
        for geom, oid in world.traffic_geoms.items():
            self._traffic_owner[geom] = oid

    def reset(self, t0: float) -> None:
        w = self.world
        assert w is not None, "load() comes first"
        mujoco.mj_resetData(w.model, w.data)
        for k, a in enumerate(self._agents):
            w.place(a.id, a.initial_state if enters_at(a, t0, self._dt) else self._parked(k, t0))
        self._steer_target = {a.id: a.initial_state.steer for a in self._agents}
        w.tyres.reset()
        w.move_traffic(t0)
        mujoco.mj_forward(w.model, w.data)
        w.tyres.apply(settle=True)
        self._accel = {a.id: SpeedRate(t0, a.initial_state.v, a.initial_state.a) for a in self._agents}
        self._events = []
        self._retired: set[int] = set()

    def enter(self, agent_id: int, t: float) -> None:
        """Bring a parked car (`_parked`) to its initial state, its tyres settled to its motion."""
        k = self._index(agent_id)
        initial = self._agents[k].initial_state.replace(t=t)
        self._place_settled(k, initial)
        self._steer_target[agent_id] = initial.steer
        self._accel[agent_id] = SpeedRate(t, initial.v, initial.a)

    def _parked(self, k: int, t: float) -> State:
        """Where the ``k``-th car waits until it enters the world: at rest on the ground plane,
        `PARKING_M` beyond the road's corner, one car length apart from the next."""
        assert self.world is not None, "load() comes first"
        x0, y0, x1, _ = self.world.road_bounds
        return State(t=t, x=x1 + PARKING_M + 8.0 * k, y=y0 - PARKING_M, yaw=0.0, v=0.0)

    def _index(self, agent_id: int) -> int:
        return next(k for k, a in enumerate(self._agents) if a.id == agent_id)

    def _place_settled(self, k: int, state: State) -> None:
        """Put the ``k``-th car at ``state``, its tyres settled to its motion."""
        w = self.world
        assert w is not None, "load() comes first"
        w.place(self._agents[k].id, state)
        mujoco.mj_forward(w.model, w.data)
        w.tyres.settle(slice(4 * k, 4 * k + 4))

    def _flipped(self) -> list[int]:
        """The cars found on their side since the step began (their ``diverged`` events)."""
        return [e.agent_id for e in self._events if e.kind == Outcome.DIVERGED]

    def begin_step(self, t: float) -> None:
        for aid in self._flipped():
            self._retire(aid, t)
        self._events = []
        self._seen = set()
        self.check(t)

    def _retire(self, agent_id: int, t: float) -> None:
        """Take a car whose physics diverged out of the world: parked (`_parked`) and braked, so
        that the others drive on in a world without it."""
        k = self._index(agent_id)
        self._place_settled(k, self._parked(k, t))
        self._retired.add(agent_id)

    def advance(self, t: float, period: float) -> None:
        """Traffic and surface friction for the period, the physics sub-steps (tyre forces every
        one), then the checks and contacts at its end."""
        w = self.world
        assert w is not None, "load() comes first"
        start, tyres_before = time.perf_counter(), w.tyres.seconds
        if w.traffic:
            w.move_traffic(t)
        self.apply_surface()
        w.step(max(1, round(period * self.settings.physics_hz)))
        tyres = w.tyres.seconds - tyres_before
        self.timings["tyres"] += tyres
        self.timings["physics"] += time.perf_counter() - start - tyres
        self.check(t + period)
        self._collect_contacts(t + period, self._seen)

    def events(self) -> list[BackendEvent]:
        return list(self._events)

    def close(self) -> None:
        self.world = None


    # --- measuring and actuating -------------------------------------------------------------
    def measure(self, agent_id: int, t: float) -> State:
        """The car's state in the `State` convention (centre, yaw from +x, speed, yaw rate,
        single-track steering angle). The acceleration is the speed's rate of change between
        measurements, low-pass filtered (`SpeedRate`)."""
        w = self.world
        assert w is not None, "load() comes first"
        car = w.cars[agent_id]
        q, v = w.data.qpos, w.data.qvel
        x, y = float(q[car.qpos]), float(q[car.qpos + 1])
        quat = q[car.qpos + 3:car.qpos + 7]
        yaw = yaw_of(quat)
        vx, vy = float(v[car.qvel]), float(v[car.qvel + 1])
        speed = math.hypot(vx, vy)
        if vx * math.cos(yaw) + vy * math.sin(yaw) < 0.0:
            speed = -speed
        qw, qx, qy, qz = quat
        wl = v[car.qvel + 3:car.qvel + 6]
        yaw_rate = float(2 * (qx * qz - qw * qy) * wl[0] + 2 * (qy * qz + qw * qx) * wl[1]
                         + (1 - 2 * (qx * qx + qy * qy)) * wl[2])
        steer = single_track_angle(float(q[car.steer_qpos[0]]), float(q[car.steer_qpos[1]]))
        accel = self._accel[agent_id].update(t, speed)
        return State(t=t, x=x, y=y, yaw=yaw, v=speed, a=accel, yaw_rate=yaw_rate, steer=steer)

    def attitude(self, agent_id: int) -> Attitude:
        """The chassis' height (of the centre of gravity), pitch and roll."""
        w = self.world
        assert w is not None, "load() comes first"
        q = w.data.qpos[w.cars[agent_id].qpos:]
        qw, x, y, z = q[3:7]
        return Attitude(z=float(q[2]), pitch=math.asin(min(max(2.0 * (x * z - qw * y), -1.0), 1.0)),
                        roll=math.atan2(2.0 * (y * z + qw * x), up_z(q[3:7])))

    def actuate(self, agent_id: int, command: Command, period: float) -> None:
        if agent_id in self._retired:
            command = PARKED
        w = self.world
        assert w is not None, "load() comes first"
        car = w.cars[agent_id]
        ph, d, m = car.physics, w.data, w.model
        # steering: rate, then angle limit of the steering system; Ackermann at the wheels
        limit = self._steer_limit[agent_id]
        target = self._steer_target[agent_id]
        step = ph.steering.max_rate * period
        target += min(max(command.steer - target, -step), step)
        target = min(max(target, -limit), limit)
        self._steer_target[agent_id] = target
        left, right = ackermann_angles(target, car.vehicle.wheelbase, ph.track_front)
        d.ctrl[car.steer_actuators[0]], d.ctrl[car.steer_actuators[1]] = left, right

        # drive: open differentials, torque capped by power at the driven wheels' speed
        throttle = min(max(command.throttle, 0.0), 1.0)
        brake = min(max(command.brake, 0.0), 1.0)
        front, rear = ph.drive_shares()
        torque = throttle * ph.max_drive_torque
        driven = [i for i, act in enumerate(car.drive_actuators) if act >= 0]
        if driven and torque > 0.0:
            omega = abs(float(np.mean([d.qvel[car.spin_dofs[i]] for i in driven])))
            wheel_power = torque * omega
            if wheel_power > ph.max_power:
                torque *= ph.max_power / wheel_power
        for i, act in enumerate(car.drive_actuators):
            if act >= 0:
                d.ctrl[act] = torque * (front if i < 2 else rear) / 2.0
        # brakes and rolling resistance as dry friction on the spin joints
        rolling = ph.rolling_resistance * ph.mass * GRAVITY / 4.0 * ph.wheel_radius
        for i, dof in enumerate(car.spin_dofs):
            share = ph.brake_front_share if i < 2 else 1.0 - ph.brake_front_share
            m.dof_frictionloss[dof] = rolling + brake * ph.max_brake_torque * share / 2.0
        # aerodynamic drag at the centre of gravity
        vx, vy = d.qvel[car.qvel], d.qvel[car.qvel + 1]
        speed = math.hypot(vx, vy)
        drag = 0.5 * AIR_DENSITY * ph.drag_coefficient_area * speed
        d.xfrc_applied[car.chassis_body, 0:2] = [-drag * vx, -drag * vy]

    def apply_surface(self) -> None:
        """Give every tyre the friction of the surface it stands on: road or verge (a factor on
        the tyre's own peak friction)."""
        w = self.world
        assert w is not None, "load() comes first"
        xy = w.data.xpos[self._wheel_bodies, :2]
        on_road = w.surface.on_road(xy[:, 0], xy[:, 1])
        w.tyres.mu[:] = np.where(on_road, w.settings.road_friction, w.settings.offroad_friction)

    # --- events --------------------------------------------------------------------------------
    def check(self, t: float) -> None:
        w = self.world
        assert w is not None, "load() comes first"
        d = w.data
        finite = np.isfinite(d.qpos).all() and np.isfinite(d.qvel).all()
        if not finite or d.warning[mujoco.mjtWarning.mjWARN_BADQACC].number > 0:
            raise PhysicsDiverged(f"the physics state is no longer finite at t = {t:.2f} s")
        for a in self._agents:
            car = w.cars[a.id]
            q = d.qpos[car.qpos:car.qpos + 7]
            if up_z(q[3:7]) < FLIPPED_UP_Z and a.id not in self._retired and a.id not in self._flipped():
                self._events.append(BackendEvent(t, a.id, Outcome.DIVERGED, f"chassis on its side or roof at t = {t:.2f} s, "
                                                 f"x = {q[0]:.1f} m, y = {q[1]:.1f} m"))

    def _collect_contacts(self, t: float, seen: set[tuple[int, int | None]]) -> None:
        """Contacts between two cars, or a car and recorded traffic, become collision events
        (each pair once per step)."""
        assert self.world is not None, "load() comes first"
        d = self.world.data
        if d.ncon == 0:
            return
        g1, g2 = d.contact.geom1[:d.ncon], d.contact.geom2[:d.ncon]
        a1, a2 = self._owner[g1], self._owner[g2]
        o1, o2 = self._traffic_owner[g1], self._traffic_owner[g2]
        hits = ((a1 >= 0) & (a2 >= 0) & (a1 != a2)) | ((a1 >= 0) & (o2 >= 0)) | ((a2 >= 0) & (o1 >= 0))
        for i in np.flatnonzero(hits):
            pos = d.contact.pos[i]
            for me, other_agent, other_obstacle in ((a1[i], a2[i], o2[i]), (a2[i], a1[i], o1[i])):
                if me < 0:
                    continue
                kind, other = ("agent", int(other_agent)) if other_agent >= 0 else ("obstacle", int(other_obstacle))
                if (int(me), other) in seen:
                    continue
                seen.add((int(me), other))
                self._events.append(BackendEvent(t, int(me), Outcome.COLLISION,
                                                 f"physical contact with {kind} {other} at "
                                                 f"({pos[0]:.1f}, {pos[1]:.1f})", other))


class MujocoBackend(TrackedBackend):
    """The ``mujoco`` backend: `MujocoPhysics` under a tracking controller per car."""

    physics: MujocoPhysics

    def __init__(self, settings: MujocoSettings | None = None):
        cfg = self.settings = settings or MujocoSettings()
        super().__init__("mujoco", MujocoPhysics(cfg), cfg)

    def fit_rates(self, settings: MujocoSettings, dt: float) -> MujocoSettings:
        """The controller rate fitted to the scenario (`TrackedBackend.fit_rates`), and the physics
        rate to the controller's: the one set, or, when none was set and the default does not
        divide by the controller's, its multiple nearest the default (540 Hz under 90 Hz)."""
        fitted = super().fit_rates(settings, dt)
        if fitted is not settings and not is_multiple(settings.physics_hz, fitted.controller_hz):
            if "physics_hz" in settings.model_fields_set:
                raise InputError(f"physics rate {settings.physics_hz:g} Hz must be a whole multiple of the controller "
                                 f"rate {fitted.controller_hz:g} Hz (fitted to the scenario's step {dt:g} s)",
                                 field="backend_settings.physics_hz",
                                 allowed=f"a multiple of {fitted.controller_hz:g} Hz, or no physics_hz")
            physics_hz = nearest_multiple(settings.physics_hz, fitted.controller_hz)
            self.notes.append(f"physics at {physics_hz:g} Hz, a multiple of the controller's {fitted.controller_hz:g} Hz")
            fitted = fitted.model_copy(update={"physics_hz": physics_hz})
        self.physics.settings = fitted
        return fitted

    @property
    def world(self) -> World | None:
        return self.physics.world
