"""One car on an open proving ground (asphalt everywhere): the MuJoCo backend's car, actuation and
measurement, stepped one controller period at a time — for controller tests and vehicle
benchmarks (`simgap.sim.dynamic.track_plans` drives it like the single-track plant)."""

from __future__ import annotations

from typing import Any

from commonroad.scenario.scenario import Scenario

from simgap.control.protocol import Command
from simgap.errors import validated_settings
from simgap.scenario.relief import Surface
from simgap.sim.mujoco.backend import MujocoPhysics
from simgap.sim.mujoco.settings import WorldSettings
from simgap.sim.protocol import Agent, Outcome, PhysicsDiverged
from simgap.trajectory import DEFAULT_TIME_STEP_S, State
from simgap.vehicles import Vehicle

AGENT = 1


def proving_ground(dt: float = DEFAULT_TIME_STEP_S) -> Scenario:
    """An empty scenario: no lanelets, no obstacles."""
    return Scenario(dt)


class MujocoPlant:
    """``reset(state)`` places the car; ``step(command, period)`` holds ``command`` for ``period``
    seconds of physics and returns the measured state. ``world`` takes the world settings
    (``road_friction``, ``road_grade``, ...); on the proving ground a slope runs along the car's
    heading. With a ``relief`` the proving ground has that shape (asphalt everywhere)."""

    def __init__(self, vehicle: Vehicle, relief: Surface | None = None, **world: Any):
        self.vehicle = vehicle
        self.relief = relief
        self.physics = MujocoPhysics(validated_settings(WorldSettings, world))
        self._scenario = proving_ground()
        self._t = 0.0

    @property
    def world(self):
        return self.physics.world

    def reset(self, initial: State) -> State:
        self.physics.load(self._scenario, [Agent(AGENT, self.vehicle, initial)], self.relief)
        self._t = initial.t
        self.physics.reset(initial.t)
        return self.physics.measure(AGENT, initial.t)

    def step(self, command: Command, period: float) -> State:
        self.physics.actuate(AGENT, command, period)
        self.physics.advance(self._t, period)
        self._t += period
        flipped = next((e for e in self.physics.events() if e.kind == Outcome.DIVERGED), None)
        if flipped is not None:         # one car alone: nothing drives on without it
            raise PhysicsDiverged(flipped.detail)
        return self.physics.measure(AGENT, self._t)


def compile_tyres() -> None:
    """Compile the tyre kernel (`simgap.sim.mujoco.tyre`, numba) into its on-disk cache: one car on
    the proving ground, stepped once. ``make`` does it at install, so that the processes a study or
    the test suite starts at once each load it instead of compiling it (seconds of CPU each)."""
    from simgap.vehicles import DEFAULT_VEHICLE, load_vehicle

    plant = MujocoPlant(load_vehicle(DEFAULT_VEHICLE))
    plant.reset(State(t=0.0, x=0.0, y=0.0, yaw=0.0, v=5.0))
    plant.step(Command(0.0, 0.1, 0.0), 0.01)


if __name__ == "__main__":
    compile_tyres()
