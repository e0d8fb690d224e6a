"""The ``dynamic`` backend: every agent's plan is tracked by a controller driving CommonRoad's
single-track model — the middle rung between the ideal world and 3D physics.

Each scenario dt the controller runs at its own rate (default 100 Hz) and the plant integrates
with RK4 at 1 kHz, so tyre slip, steering lag and powertrain limits already break the ideal
world's perfect tracking. The model's reference point (its centre of gravity) is taken as the
vehicle's centre.

Settings (``backend_settings``): the tracking (`TrackingSettings`: the realism, the actuators'
knobs), ``params_id`` (CommonRoad parameter set), ``model`` (``st`` single-track, or ``mb``
multi-body on request), ``integration_step`` and the reality knob ``road_friction`` (1.0 = dry).
Under ``realism: real`` the drive and brakes lag through the vehicle's actuators, so the model's
own powertrain lag is off; under ``realism: ideal`` it keeps it (0.1 s), as before realism.

On a road with a relief the cars stay in the plane, and the road's grade and bank under each car
act on it as gravity's pull along the road's tangent plane there (`Slope`), taken every controller
period — the middle rung between the flat ideal world and the MuJoCo world, which drives on the
surface itself. Each car's attitude is the road's under it: its centre of gravity at its height
above the surface, pitched and rolled as the surface.
"""

from __future__ import annotations

import math
import time
from collections.abc import Sequence

import numpy as np
from commonroad.scenario.scenario import Scenario

from simgap.control.protocol import Command
from simgap.scenario.relief import Surface, tilt_of
from simgap.sim.dynamic.plant import PLANTS, Slope
from simgap.sim.dynamic.settings import DynamicSettings
from simgap.sim.protocol import Agent, BackendEvent, PhysicsDiverged, Realism, enters_at
from simgap.sim.tracked import TrackedBackend
from simgap.trajectory import Attitude, State
from simgap.vehicles.constants import GRAVITY


def slope_under(normal: np.ndarray, heading: float) -> Slope:
    """Gravity's pull [m/s^2] along a plane of unit ``normal``: along ``heading`` (in the plane) and to its left."""
    forward = np.array([math.cos(heading), math.sin(heading), 0.0])
    forward -= forward.dot(normal) * normal
    forward /= np.linalg.norm(forward)
    left = np.cross(normal, forward)
    return Slope(along=-GRAVITY * float(forward[2]), across=-GRAVITY * float(left[2]))


class SingleTrackWorld:
    """The `Physics` of the ``dynamic`` backend: one CommonRoad vehicle model per agent, each
    integrated on its own (the cars of this world do not touch)."""

    def __init__(self, settings: DynamicSettings):
        self.settings = settings
        self.timings = {"physics": 0.0}
        self.notes: list[str] = []
        self._agents: list[Agent] = []

    def load(self, scenario: Scenario, agents: Sequence[Agent], relief: Surface | None = None) -> None:
        cfg = self.settings
        self._agents = list(agents)
        self._relief = relief
        self._dt = float(scenario.dt)
        # a real car's drive and brakes lag through its actuators (`TrackedBackend`), not twice
        lag = {} if cfg.realism is Realism.IDEAL else {"accel_time_constant": 0.0}
        self._plants = {a.id: PLANTS[cfg.model](a.vehicle, cfg.params_id, road_friction=cfg.road_friction,
                                                integration_step=cfg.integration_step, **lag) for a in agents}
        self._commands: dict[int, Command] = {}

    def reset(self, t0: float) -> None:
        self._states = {a.id: self._plants[a.id].reset(a.initial_state) for a in self._agents
                        if enters_at(a, t0, self._dt)}
        self._commands = {}

    def enter(self, agent_id: int, t: float) -> None:
        agent = next(a for a in self._agents if a.id == agent_id)
        self._states[agent_id] = self._plants[agent_id].reset(agent.initial_state.replace(t=t))

    def begin_step(self, t: float) -> None:
        pass

    def measure(self, agent_id: int, t: float) -> State:
        return self._states[agent_id].replace(t=t)

    def attitude(self, agent_id: int) -> Attitude | None:
        if self._relief is None:
            return None
        state = self._states[agent_id]
        surface = self._relief.surface(state.x, state.y)
        pitch, roll = tilt_of(surface.normal, state.yaw)
        plant = self._plants[agent_id]
        return Attitude(z=float(surface.z) + plant.p.h_s / float(surface.normal[2]), pitch=pitch, roll=roll)

    def actuate(self, agent_id: int, command: Command, period: float) -> None:
        self._commands[agent_id] = command

    def advance(self, t: float, period: float) -> None:
        start = time.perf_counter()
        for aid, command in self._commands.items():
            if self._relief is not None:
                state = self._states[aid]
                self._plants[aid].slope = slope_under(self._relief.surface(state.x, state.y).normal, state.yaw)
            try:
                self._states[aid] = self._plants[aid].step(command, period)
            except FloatingPointError as exc:
                raise PhysicsDiverged(f"agent {aid}: {exc}") from None
        self.timings["physics"] += time.perf_counter() - start

    def events(self) -> list[BackendEvent]:
        return []

    def close(self) -> None:
        pass


class DynamicBackend(TrackedBackend):
    """The ``dynamic`` backend: `SingleTrackWorld` under a tracking controller per car."""

    def __init__(self, settings: DynamicSettings | None = None):
        cfg = self.settings = settings or DynamicSettings()
        super().__init__("dynamic", SingleTrackWorld(cfg), cfg)
