"""The ``dynamic`` backend: every agent's plan is tracked by a controller driving CommonRoad's
single-track model — the middle rung between the ideal world and 3D physics.

Each scenario dt the controller runs at its own rate (default 100 Hz) and the plant integrates
with RK4 at 1 kHz, so tyre slip, steering lag and powertrain limits already break the ideal
world's perfect tracking. The model's reference point (its centre of gravity) is taken as the
vehicle's centre.
"""

from __future__ import annotations

import time
from typing import Mapping, Sequence

from commonroad.scenario.scenario import Scenario

from simgap.control import make_controller
from simgap.sim.dynamic.plant import SingleTrackPlant
from simgap.sim.protocol import Agent, BackendEvent, PhysicsDiverged
from simgap.trajectory import State, Trajectory


class DynamicBackend:
    name = "dynamic"

    def __init__(self, controller: str = "pure_pursuit", controller_hz: float = 100.0, params_id: int = 2):
        self.controller_name = controller
        self.controller_hz = float(controller_hz)
        self.params_id = params_id
        self.timings = {"control": 0.0, "physics": 0.0}
        self._agents: list[Agent] = []
        self._dt = 0.1
        self._step = 0

    def load(self, scenario: Scenario, agents: Sequence[Agent]) -> None:
        self._dt = float(scenario.dt)
        self._agents = list(agents)
        self._plants = {a.id: SingleTrackPlant(a.vehicle, self.params_id) for a in agents}
        self._controllers = {a.id: make_controller(self.controller_name, a.vehicle, self.controller_hz)
                             for a in agents}

    def reset(self) -> dict[int, State]:
        self._step = 0
        self._states = {}
        for a in self._agents:
            self._states[a.id] = self._plants[a.id].reset(a.initial_state)
            self._controllers[a.id].reset(self._states[a.id])
        return dict(self._states)

    def step(self, plans: Mapping[int, Trajectory]) -> dict[int, State]:
        ticks = max(1, round(self._dt * self.controller_hz))
        period = self._dt / ticks
        self._step += 1
        for a in self._agents:
            state, plan = self._states[a.id], plans[a.id]
            plant, controller = self._plants[a.id], self._controllers[a.id]
            t0 = a.initial_state.t + (self._step - 1) * self._dt
            for k in range(ticks):
                c0 = time.perf_counter()
                command = controller.command(state, plan, t0 + k * period)
                c1 = time.perf_counter()
                try:
                    state = plant.step(command, period)
                except FloatingPointError as exc:
                    raise PhysicsDiverged(f"agent {a.id}: {exc}") from None
                self.timings["control"] += c1 - c0
                self.timings["physics"] += time.perf_counter() - c1
            self._states[a.id] = state.replace(t=a.initial_state.t + self._step * self._dt)
        return dict(self._states)

    def events(self) -> list[BackendEvent]:
        return []

    def close(self) -> None:
        pass
