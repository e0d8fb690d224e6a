"""One car on an open proving ground (asphalt everywhere): the MuJoCo backend's car, actuation and
measurement, stepped one controller period at a time — for controller tests and vehicle
benchmarks (`simgap.sim.dynamic.track_plans` drives it like the single-track plant)."""

from __future__ import annotations

from typing import Any

from commonroad.common.util import Interval
from commonroad.scenario.scenario import Scenario

from simgap.control.protocol import Command
from simgap.sim.mujoco.backend import MujocoBackend
from simgap.sim.protocol import Agent
from simgap.trajectory import State
from simgap.vehicles import Vehicle

AGENT = 1


def proving_ground(dt: float = 0.1) -> Scenario:
    """An empty scenario: no lanelets, no obstacles."""
    return Scenario(dt)


class MujocoPlant:
    """``reset(state)`` places the car; ``step(command, period)`` holds ``command`` for ``period``
    seconds of physics and returns the measured state. ``world`` takes the backend's world
    settings (``road_grade``, ``road_bank``, ...); on the proving ground a slope runs along the
    car's heading."""

    def __init__(self, vehicle: Vehicle, physics_hz: float = 500.0, road_friction: float = 1.0, **world: Any):
        self.vehicle = vehicle
        self.backend = MujocoBackend(controller_hz=100.0, physics_hz=physics_hz, road_friction=road_friction,
                                     **world)
        self._scenario = proving_ground()
        self._period_steps: dict[float, int] = {}

    @property
    def world(self):
        return self.backend.world

    def reset(self, initial: State) -> State:
        self.backend.load(self._scenario, [Agent(AGENT, self.vehicle, initial)])
        return self.backend.reset()[AGENT]

    def step(self, command: Command, period: float) -> State:
        b = self.backend
        b.apply_surface()
        b._actuate(AGENT, command, period)
        steps = max(1, round(period * b.settings.physics_hz))
        t = b.world.data.time
        b.advance(steps)
        b._check(t + period)
        state = b.measure(AGENT, self.t0 + b.world.data.time)
        return state

    @property
    def t0(self) -> float:
        return self.backend._t0
