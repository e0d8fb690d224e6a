"""A vehicle's actuators: how late and how slowly each of its channels (`simgap.vehicles.channels`:
the steering, the drive, the brakes) does what it is asked. Every number in a data file carries its
source, like the tyres'.

Each channel is a dead time followed by a lag (first order: a time constant; second order: a
natural frequency and a damping ratio), the model Autoware's vehicle simulator and its MPC use
(``DELAY_STEER_ACC``: dead time + first-order lag) and openpilot's car ports identify
(``steerActuatorDelay``, ``longitudinalActuatorDelay``). The steering's angle and rate limits
at the road wheels are the steering system's (``physics.steering``), applied after the lag.

`Actuators` holds a vehicle's numbers per channel, as the ``actuators`` section of its data file
gives them (one subsection per channel; how to add a channel: `simgap.vehicles.channels`).

`ChannelResponse` is the channel's response in discrete time, at the controller's period: the
physics backends apply them between the controller and the car (`ActuatorResponses`, in
`simgap.sim.tracked`), and the controllers that compensate the delays predict with the steering's
(`simgap.control.delay`). It is deterministic and its state can be copied, so a prediction runs
the same response forward.
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Mapping, Sequence
from operator import attrgetter, call
from typing import Any

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, RootModel, model_validator
from pydantic_core import PydanticCustomError, PydanticUndefined
from scipy.linalg import expm

from simgap.trajectory import State
from simgap.vehicles.channels import CHANNELS, Channel

MAX_DEAD_TIME_S = 1.0       # s: a longer dead time is no actuator but a broken car
MAX_TIME_CONSTANT_S = 2.0   # s


class ActuatorChannel(BaseModel):
    """One channel of a vehicle's actuators, as its file gives it: a dead time, then a first-order
    lag (``time_constant``) or a second-order one (``natural_frequency`` and ``damping_ratio``), or
    none."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    dead_time: float = Field(0.0, ge=0.0, le=MAX_DEAD_TIME_S, description="dead time [s]")
    time_constant: float = Field(0.0, ge=0.0, le=MAX_TIME_CONSTANT_S,
                                 description="first-order lag: time to 63 % of a step [s] (0: none)")
    natural_frequency: float | None = Field(None, gt=0.0, le=200.0,
                                            description="second-order lag: natural frequency [rad/s]")
    damping_ratio: float | None = Field(None, gt=0.0, le=5.0, description="second-order lag: damping ratio [-]")
    source: str = Field("", description="where the numbers come from")

    @model_validator(mode="after")
    def _one_lag(self) -> ActuatorChannel:
        second = (self.natural_frequency is not None, self.damping_ratio is not None)
        if any(second) and not all(second):
            raise ValueError("a second-order lag needs both natural_frequency and damping_ratio")
        if all(second) and self.time_constant > 0:
            raise ValueError("give either time_constant (first order) or natural_frequency and damping_ratio "
                             "(second order), not both")
        return self

    def second_order_lag(self) -> tuple[float, float]:
        """The natural frequency [rad/s] and damping ratio of a second-order channel (``order`` 2)."""
        if self.natural_frequency is None or self.damping_ratio is None:
            raise ValueError("not a second-order lag")
        return self.natural_frequency, self.damping_ratio

    @property
    def order(self) -> int:
        return 2 if self.natural_frequency is not None else 1 if self.time_constant > 0 else 0

    def with_changes(self, dead_time: float | None = None, time_constant: float | None = None) -> ActuatorChannel:
        """This channel with another dead time or first-order lag (a reality knob's override;
        a first-order lag replaces a second-order one)."""
        changes: dict = {}
        if dead_time is not None:
            changes["dead_time"] = dead_time
        if time_constant is not None:
            changes |= {"time_constant": time_constant, "natural_frequency": None, "damping_ratio": None}
        return self.model_copy(update=changes) if changes else self

    def summary(self) -> str:
        """``0.12 s dead time + lag 0.1 s``, in a line."""
        if self.order == 2:
            lag = f" + 2nd-order lag {self.natural_frequency:g} rad/s, zeta {self.damping_ratio:g}"
        else:
            lag = f" + lag {self.time_constant:g} s" if self.order == 1 else ""
        return f"{self.dead_time:g} s dead time{lag}"

    def response(self, period: float, initial: float = 0.0) -> ChannelResponse:
        return ChannelResponse(self, period, initial)


IDEAL_CHANNEL = ActuatorChannel(source="ideal: acts at once")


class Actuators(RootModel[dict[str, ActuatorChannel]]):
    """A car's actuators: each channel's numbers (`simgap.vehicles.channels.CHANNELS`) by its
    section, as a vehicle file's ``actuators`` gives them. A channel the file leaves out acts at
    once; a section that is no channel's is refused."""

    model_config = ConfigDict(frozen=True)

    @model_validator(mode="before")
    @classmethod
    def _every_channel(cls, sections: Any) -> Any:
        if sections is PydanticUndefined:
            sections = {}
        if not isinstance(sections, Mapping):
            return sections             # pydantic says what it should be
        for section in sections:
            if section not in CHANNELS:
                raise PydanticCustomError("unknown_channel", "'{section}' is no actuator channel",
                                          {"section": section, "expected": ", ".join(CHANNELS)})
        return {section: sections.get(section, IDEAL_CHANNEL) for section in CHANNELS}

    def __getitem__(self, channel: type[Channel]) -> ActuatorChannel:
        return self.root[channel.section]

    def items(self) -> list[tuple[type[Channel], ActuatorChannel]]:
        """Each channel with its numbers, in the channels' order."""
        return [(CHANNELS[section], numbers) for section, numbers in self.root.items()]

    @property
    def ideal(self) -> bool:
        return all(c.dead_time == 0 and c.order == 0 for c in self.root.values())

    def summary(self) -> str:
        """``steering 0.12 s dead time + lag 0.1 s, drive ..., brake ...``, in a line."""
        return ", ".join(f"{channel.section} {numbers.summary()}" for channel, numbers in self.items())


IDEAL_ACTUATORS = Actuators()      # every channel acts at once


class ChannelResponse:
    """An `ActuatorChannel` in discrete time at ``period``: the dead time as a queue of whole
    periods (rounded), the lag discretised exactly for a request held over each period (zero-order
    hold). ``initial``: the output (and the requests in flight) at the start."""

    def __init__(self, channel: ActuatorChannel, period: float, initial: float = 0.0):
        self.channel, self.period, self.order = channel, period, channel.order
        self.delay_ticks = int(round(channel.dead_time / period))
        self._queue: deque[float] = deque([initial] * self.delay_ticks)
        self._y, self._rate = float(initial), 0.0        # output and its rate (plain floats: a hot path)
        if self.order == 2:
            wn, zeta = channel.second_order_lag()
            phi, gamma = _zero_order_hold(np.array([[0.0, 1.0], [-wn * wn, -2.0 * zeta * wn]]),
                                          np.array([0.0, wn * wn]), period)
            self._phi = tuple(float(v) for v in phi.ravel())
            self._gamma = tuple(float(v) for v in gamma)
        elif self.order == 1:
            self._alpha = 1.0 - math.exp(-period / channel.time_constant)

    @property
    def output(self) -> float:
        return self._y

    @property
    def alpha(self) -> float:
        """A first-order lag's share of the gap to the request closed in one period."""
        return self._alpha

    def step(self, request: float) -> float:
        """Take ``request`` now; the output over the next period."""
        queue = self._queue
        if queue:
            queue.append(request)
            request = queue.popleft()
        if self.order == 0:
            self._y = request
        elif self.order == 1:
            self._y += self._alpha * (request - self._y)
        else:
            p, g, y, r = self._phi, self._gamma, self._y, self._rate
            self._y = p[0] * y + p[1] * r + g[0] * request
            self._rate = p[2] * y + p[3] * r + g[1] * request
        return self._y

    def copy(self) -> ChannelResponse:
        twin = object.__new__(ChannelResponse)
        twin.__dict__.update(self.__dict__)
        twin._queue = deque(self._queue)
        return twin

    @property
    def in_flight(self) -> list[float]:
        """The requests sent and not yet arrived, oldest first."""
        return list(self._queue)


def _zero_order_hold(a: np.ndarray, b: np.ndarray, period: float) -> tuple[np.ndarray, np.ndarray]:
    """Exact discretisation of x' = A x + B u with u held over ``period`` (the augmented matrix's
    exponential)."""
    n = len(a)
    m = np.zeros((n + 1, n + 1))
    m[:n, :n], m[:n, n] = a * period, b * period
    exp = expm(m)
    return exp[:n, :n], exp[:n, n]


class ActuatorResponses:
    """A car's channels in discrete time: what each delivers, period by period, for what it is
    asked. Each starts as its channel does on a car at ``state`` (the steering at the car's angle,
    the pedals released). ``requests``: the fields of the commands it is asked, in their order, each
    the ``command`` of one channel (default: the channels' own, in the channels' order); `respond`
    answers in that order."""

    def __init__(self, actuators: Actuators, period: float, state: State, requests: Sequence[str] = ()):
        self.actuators, self.period = actuators, period
        self._responses = {channel: numbers.response(period, channel.start(state))
                           for channel, numbers in actuators.items()}
        by_request = {channel.command: response for channel, response in self._responses.items()}
        requests = tuple(requests) or tuple(by_request)
        if sorted(requests) != sorted(by_request):
            raise ValueError(f"the commands carry {', '.join(requests)}; the actuator channels deliver "
                             f"{', '.join(by_request)}")
        self._requested = attrgetter(*requests)
        self._steps = tuple(by_request[name].step for name in requests)      # bound once: a hot path

    def __getitem__(self, channel: type[Channel]) -> ChannelResponse:
        return self._responses[channel]

    def respond(self, asked: Any) -> tuple[float, ...]:
        """What acts over the next period for each request of ``asked`` (a
        `simgap.control.protocol.Command`: a road-wheel angle [rad], pedal positions [0, 1]), in
        the order of ``requests``."""
        return tuple(map(call, self._steps, self._requested(asked)))
