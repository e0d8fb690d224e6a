"""The controller contract. Controllers know plans (trajectories) and states, never planners."""

from __future__ import annotations

from dataclasses import dataclass, fields
from typing import Protocol

from simgap.trajectory import State, Trajectory


@dataclass(frozen=True)
class Command:
    """One actuation request: one field per actuator channel, which delivers it to the car
    (`simgap.vehicles.channels`: a channel names its field).

    ``steer``: road-wheel steering angle target [rad] (the steering actuator enforces its own
    angle and rate limits); ``throttle`` and ``brake``: pedal positions in [0, 1].
    """

    steer: float
    throttle: float
    brake: float


#: a command's fields in their order (the order `Command` takes them in)
COMMAND_FIELDS = tuple(f.name for f in fields(Command))


class Controller(Protocol):
    """Runs at its own rate (``rate_hz``) inside each scenario dt.

    ``command`` is called with the latest measured state (centre convention, like every
    `State`), the plan currently in force, and the simulation time.
    """

    rate_hz: float

    def reset(self, state: State) -> None: ...

    def command(self, measured: State, plan: Trajectory, t: float) -> Command: ...
