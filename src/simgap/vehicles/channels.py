"""The actuator channels of a car, each defined once: what its controller asks of it, where a
vehicle file gives its numbers, and which reality knobs set them.

A channel is a class here (`Steering`, `Drive`, `Brake`); defining it registers it in `CHANNELS`,
and whatever handles actuators iterates that table: a vehicle file's ``actuators`` section (one
subsection per channel, `simgap.vehicles.actuators.Actuators`), the response between the
controller and the car (`ActuatorResponses`, in `simgap.sim.tracked`), the knobs over the
vehicle's numbers (`simgap.sim.settings.TrackingSettings.actuators`), the restored actuators of an
attribution (every channel's knobs at 0), the knobs' table (`simgap.experiment.knobs`), the run
record's note of a car's actuators, ``simgap vehicles show`` and the reference page.

Adding a channel — a handbrake, say — is

1. a class here::

       class Handbrake(Channel):
           section = "handbrake"       # its subsection of a vehicle file's ``actuators``
           command = "handbrake"       # the field of the controller's `Command` it delivers
           knobs = PEDAL_KNOBS         # pedal_delay and pedal_lag set it as they set the pedals
           description = "rear-wheel brake torque request: the handbrake lever in [0, 1]"

2. its subsection in each vehicle file of the catalogue (dead time, lag and their source; a test
   checks that every file has every channel's), and

3. what a new actuator needs anyway: the field in `simgap.control.protocol.Command` (with a
   default, so a controller that does not use it is unchanged) and the physics that acts on it
   (the ``actuate`` of each world that has one, `simgap.sim.tracked.Physics`).

A channel set by knobs of its own declares a new `TimingKnobs` pair and the two fields of those
names in `TrackingSettings` (their bounds and meaning); the knobs' table, the attribution's
restoration and BeamNG's exclusion of the lags follow from the declaration.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass
from typing import Any, ClassVar

from simgap.trajectory import State


@dataclass(frozen=True)
class TimingKnobs:
    """A pair of reality knobs, set over the vehicle's numbers on every channel that declares the
    pair: a dead time and a first-order lag's time constant (the fields of these names in
    `simgap.sim.settings.TrackingSettings`; None there: the vehicle's own)."""

    delay: str
    lag: str

    @property
    def names(self) -> tuple[str, str]:
        return self.delay, self.lag

    @property
    def channels(self) -> list[type[Channel]]:
        """The channels the pair sets."""
        return [c for c in CHANNELS.values() if c.knobs == self]

    @property
    def subject(self) -> str:
        """What the pair sets, in words: ``drive and brake``."""
        return in_words(self.channels)


STEERING_KNOBS = TimingKnobs("steer_delay", "steer_lag")
PEDAL_KNOBS = TimingKnobs("pedal_delay", "pedal_lag")


class Channel:
    """One actuator channel of a car, defined by a subclass that says what it is; defining the
    subclass registers it in `CHANNELS` (its numbers — dead time, lag, source — are each vehicle's,
    `simgap.vehicles.actuators.ActuatorChannel`)."""

    section: ClassVar[str]          # its subsection of a vehicle file's ``actuators``
    command: ClassVar[str]          # the field of the controller's `Command` it delivers
    knobs: ClassVar[TimingKnobs]    # the reality knobs that set its dead time and lag
    description: ClassVar[str]      # what it is asked for, in a line

    def __init_subclass__(cls, **kwargs: Any) -> None:
        super().__init_subclass__(**kwargs)
        for other in CHANNELS.values():
            if cls.section == other.section or cls.command == other.command:
                raise ValueError(f"the actuator channel {cls.__name__} takes the section or the command of "
                                 f"{other.__name__} ('{other.section}', '{other.command}')")
        CHANNELS[cls.section] = cls

    @staticmethod
    def start(state: State) -> float:
        """What the channel delivers (and has in flight) when its car starts at ``state``: nothing,
        a pedal released."""
        return 0.0


#: every channel, by its section, in the order defined
CHANNELS: dict[str, type[Channel]] = {}


class Steering(Channel):
    """The steering; its angle and rate limits at the road wheels are the steering system's
    (``physics.steering``), which the car applies after the channel."""

    section = "steering"
    command = "steer"
    knobs = STEERING_KNOBS
    description = "road-wheel angle request [rad]"

    @staticmethod
    def start(state: State) -> float:
        """The road wheels' angle the car starts with."""
        return state.steer


class Drive(Channel):
    """The drive: the engine or motor's torque at the driven wheels."""

    section = "drive"
    command = "throttle"
    knobs = PEDAL_KNOBS
    description = "drive torque request: the accelerator pedal in [0, 1]"


class Brake(Channel):
    """The service brakes: a pressure at every wheel's brake."""

    section = "brake"
    command = "brake"
    knobs = PEDAL_KNOBS
    description = "brake pressure request: the brake pedal in [0, 1]"


def timing_knobs() -> list[TimingKnobs]:
    """The knob pairs the channels declare, each once, in the channels' order."""
    return list(dict.fromkeys(c.knobs for c in CHANNELS.values()))


def knob_names() -> list[str]:
    """The names of every channel's knobs: ``steer_delay``, ``steer_lag``, ``pedal_delay``, ..."""
    return [name for pair in timing_knobs() for name in pair.names]


def in_words(channels: Iterable[type[Channel]]) -> str:
    """``steering, drive and brake``."""
    *first, last = [c.section for c in channels]
    return f"{', '.join(first)} and {last}" if first else last


def channel_table() -> str:
    """The channels as a Markdown table (the vehicle files' reference page)."""
    rows = ["| section | delivers `Command` field | knobs | request |", "|---|---|---|---|"]
    rows += [f"| `{c.section}` | `{c.command}` | `{c.knobs.delay}`, `{c.knobs.lag}` | {c.description} |"
             for c in CHANNELS.values()]
    return "\n".join(rows)
