"""One car on an open proving ground (asphalt everywhere): the MuJoCo backend's car, actuation and
measurement, stepped one controller period at a time — for controller tests and vehicle
benchmarks (`simgap.sim.dynamic.track_plans` drives it like the single-track plant)."""

from __future__ import annotations

import math
from typing import Any

from commonroad.scenario.scenario import Scenario

from simgap.control.protocol import Command
from simgap.errors import InputError, validated_settings
from simgap.scenario.geometry import Straight, centre_line
from simgap.scenario.relief import ReliefProfile, RoadRelief, RoadTilt, Surface, road_tilt
from simgap.sim.mujoco.backend import MujocoPhysics
from simgap.sim.mujoco.settings import WorldSettings
from simgap.sim.protocol import Agent, Outcome, PhysicsDiverged
from simgap.trajectory import DEFAULT_TIME_STEP_S, State
from simgap.vehicles import Vehicle

AGENT = 1
TILTED_GROUND_M = 200.0     # a tilted proving ground: a plane this long, centred on the car's start [m]


def proving_ground(dt: float = DEFAULT_TIME_STEP_S) -> Scenario:
    """An empty scenario: no lanelets, no obstacles."""
    return Scenario(dt)


def tilted_ground(tilt: RoadTilt, start: State, length: float = TILTED_GROUND_M) -> RoadRelief:
    """The proving ground tilted by ``tilt`` along the heading of ``start``: a flat road's relief
    tilted, on a straight reference line of ``length`` centred on the car (a plane, grade uphill
    ahead of the car, bank falling to its right, over that stretch and the terrain's margin beside
    it; level beyond: a manoeuvre that drives further than ``length / 2`` needs a longer one)."""
    back = 0.5 * length
    origin = (start.x - back * math.cos(start.yaw), start.y - back * math.sin(start.yaw))
    return RoadRelief(ReliefProfile().tilted(tilt), centre_line([Straight(length=length)], origin, start.yaw))


class MujocoPlant:
    """``reset(state)`` places the car; ``step(command, period)`` holds ``command`` for ``period``
    seconds of physics and returns the measured state. ``world`` takes the world settings
    (``road_friction``, ``road_grade``, ...); a tilt (``road_bank``, ``road_grade``) makes the proving
    ground a plane tilted along the car's heading at reset (`tilted_ground`). With a ``relief`` the
    proving ground has that shape (asphalt everywhere), and takes no tilt on top."""

    def __init__(self, vehicle: Vehicle, relief: Surface | None = None, **world: Any):
        settings = validated_settings(WorldSettings, world)
        self.tilt = road_tilt(settings)
        if relief is not None and not self.tilt.is_level:
            raise InputError("a proving ground of a given relief is not tilted", field="road_bank, road_grade",
                             allowed="a tilt on the open proving ground, or the relief's own bank and grade")
        self.vehicle = vehicle
        self.relief = relief
        self.physics = MujocoPhysics(settings)
        self._scenario = proving_ground()
        self._t = 0.0

    @property
    def world(self):
        return self.physics.world

    def reset(self, initial: State) -> State:
        ground = self.relief if self.tilt.is_level else tilted_ground(self.tilt, initial)
        self.physics.load(self._scenario, [Agent(AGENT, self.vehicle, initial)], ground)
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
