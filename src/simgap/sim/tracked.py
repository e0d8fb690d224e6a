"""Physics backends as a tracker and a plant (nuPlan's ``TwoStageController``: tracker + motion
model). A physics backend supplies only its `Plant` — the world that measures, actuates and
advances its cars; `TrackedBackend` owns what every such backend shares: a tracking controller
per agent (with its actuator delays), the controller rate, and the inner loop that runs, for
each scenario dt,

    for every controller period k:   measure each car -> its controller's command -> actuate it;
                                     then the plant advances one period (its own sub-steps)

and times the phases (``control`` here; ``physics`` and anything finer in the plant).
"""

from __future__ import annotations

import time
from typing import Any, Mapping, Protocol, Sequence

from commonroad.scenario.scenario import Scenario

from simgap.control import make_controller
from simgap.control.delay import with_actuator_delay
from simgap.control.protocol import Command
from simgap.errors import InputError
from simgap.sim.protocol import Agent, BackendEvent
from simgap.trajectory import State, Trajectory

MAX_ACTUATOR_DELAY_S = 1.0


class Plant(Protocol):
    """The physical world of a physics backend, driven one controller period at a time."""

    timings: dict[str, float]       # seconds per phase this plant spent (``physics``, ...)

    def load(self, scenario: Scenario, agents: Sequence[Agent]) -> None: ...

    def reset(self, t0: float) -> None:
        """Put every agent at its initial state; the clock starts at ``t0``."""
        ...

    def begin_step(self, t: float) -> None:
        """A scenario step starts at ``t``: forget the last step's events, check the state."""
        ...

    def measure(self, agent_id: int, t: float) -> State: ...

    def actuate(self, agent_id: int, command: Command, period: float) -> None:
        """Hold ``command`` on the car's actuators for the next ``period`` seconds."""
        ...

    def advance(self, t: float, period: float) -> None:
        """Advance every car from ``t`` by ``period`` seconds."""
        ...

    def events(self) -> list[BackendEvent]: ...

    def close(self) -> None: ...


def checked_delay(value: Any, name: str) -> float:
    if not isinstance(value, (int, float)) or not 0.0 <= value <= MAX_ACTUATOR_DELAY_S:
        raise InputError(f"{value!r} is not a delay", field=f"backend_settings.{name}",
                         allowed=f"0 to {MAX_ACTUATOR_DELAY_S:g} s")
    return float(value)


class TrackedBackend:
    """A `Backend`: a `Plant` whose cars each follow their plan under a tracking controller."""

    def __init__(self, name: str, plant: Plant, controller: str = "pure_pursuit", controller_hz: float = 100.0,
                 controller_gains: Mapping[str, Any] | None = None, steer_delay: float = 0.0,
                 pedal_delay: float = 0.0):
        self.name = name
        self.plant = plant
        self.controller_name = controller
        self.controller_hz = float(controller_hz)
        self.controller_gains = dict(controller_gains or {})
        self.steer_delay = checked_delay(steer_delay, "steer_delay")
        self.pedal_delay = checked_delay(pedal_delay, "pedal_delay")
        self.timings = plant.timings
        self.timings.setdefault("control", 0.0)
        self.notes: list[str] = []
        self._agents: list[Agent] = []
        self._dt = 0.1
        self._t0 = 0.0
        self._step = 0

    def load(self, scenario: Scenario, agents: Sequence[Agent]) -> None:
        self._dt = float(scenario.dt)
        self._agents = list(agents)
        self.plant.load(scenario, agents)
        self._controllers = {a.id: with_actuator_delay(make_controller(self.controller_name, a.vehicle,
                                                                       self.controller_hz, self.controller_gains),
                                                       self.steer_delay, self.pedal_delay) for a in agents}

    def reset(self) -> dict[int, State]:
        self._t0 = min(a.initial_state.t for a in self._agents) if self._agents else 0.0
        self._step = 0
        self.plant.reset(self._t0)
        states = {a.id: self.plant.measure(a.id, self._t0) for a in self._agents}
        for a in self._agents:
            self._controllers[a.id].reset(states[a.id])
        return states

    def step(self, plans: Mapping[int, Trajectory]) -> dict[int, State]:
        plant, timings = self.plant, self.timings
        ticks = max(1, round(self._dt * self.controller_hz))
        period = self._dt / ticks
        t0 = self._t0 + self._step * self._dt
        plant.begin_step(t0)
        for k in range(ticks):
            t = t0 + k * period
            start = time.perf_counter()
            for a in self._agents:
                command = self._controllers[a.id].command(plant.measure(a.id, t), plans[a.id], t)
                plant.actuate(a.id, command, period)
            timings["control"] += time.perf_counter() - start
            plant.advance(t, period)
        self._step += 1
        t_end = t0 + self._dt
        return {a.id: plant.measure(a.id, t_end) for a in self._agents}

    def events(self) -> list[BackendEvent]:
        return self.plant.events()

    def close(self) -> None:
        self.plant.close()
