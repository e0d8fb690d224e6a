"""The ``dynamic`` backend: every agent's plan is tracked by a controller driving CommonRoad's
single-track model — the middle rung between the ideal world and 3D physics.

Each scenario dt the controller runs at its own rate (default 100 Hz) and the plant integrates
with RK4 at 1 kHz, so tyre slip, steering lag and powertrain limits already break the ideal
world's perfect tracking. The model's reference point (its centre of gravity) is taken as the
vehicle's centre.

Settings (``backend_settings``): ``controller``, ``controller_hz``, ``params_id`` (CommonRoad
parameter set), ``model`` (``st`` single-track, or ``mb`` multi-body on request), ``integration_step`` and the reality
knobs ``road_friction`` (1.0 = dry), ``steer_delay`` and ``pedal_delay`` [s].
"""

from __future__ import annotations

import time
from typing import Mapping, Sequence

from commonroad.scenario.scenario import Scenario
from pydantic import BaseModel, ConfigDict, Field

from simgap.control import make_controller
from simgap.control.delay import with_actuator_delay
from simgap.errors import InputError, validated_settings
from simgap.sim.dynamic.plant import PLANTS, make_plant
from simgap.sim.protocol import Agent, BackendEvent, PhysicsDiverged
from simgap.trajectory import State, Trajectory


class DynamicSettings(BaseModel):
    """Settings of the ``dynamic`` world (``backend_settings`` of a run)."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    controller: str = "pure_pursuit"
    controller_hz: float = Field(100.0, ge=50.0, description="controller rate [Hz]")
    params_id: int = Field(2, ge=1, le=3, description="CommonRoad vehicle parameter set")
    model: str = Field("st", description=f"vehicle model: {', '.join(PLANTS)}")
    integration_step: float = Field(0.001, gt=0, le=0.01, description="RK4 sub-step of the vehicle model [s]")
    road_friction: float = Field(1.0, gt=0, le=1.5, description="road friction, scales the tyres' [-]")
    steer_delay: float = Field(0.0, ge=0, le=1.0, description="steering actuator delay [s]")
    pedal_delay: float = Field(0.0, ge=0, le=1.0, description="throttle/brake actuator delay [s]")


class DynamicBackend:
    name = "dynamic"

    def __init__(self, **settings):
        self.settings = validated_settings(DynamicSettings, settings)
        if self.settings.model not in PLANTS:
            raise InputError(f"unknown vehicle model '{self.settings.model}'", field="backend_settings.model",
                             allowed=", ".join(PLANTS))
        self.controller_name = self.settings.controller
        self.controller_hz = self.settings.controller_hz
        self.timings = {"control": 0.0, "physics": 0.0}
        self.notes: list[str] = []
        self._agents: list[Agent] = []
        self._dt = 0.1
        self._step = 0

    def load(self, scenario: Scenario, agents: Sequence[Agent]) -> None:
        self._dt = float(scenario.dt)
        self._agents = list(agents)
        cfg = self.settings
        self._plants = {a.id: make_plant(cfg.model, a.vehicle, cfg.params_id, cfg.road_friction, cfg.integration_step)
                        for a in agents}
        self._controllers = {a.id: with_actuator_delay(make_controller(cfg.controller, a.vehicle, cfg.controller_hz),
                                                       cfg.steer_delay, cfg.pedal_delay)
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
