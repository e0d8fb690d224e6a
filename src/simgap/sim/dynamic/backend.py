"""The ``dynamic`` backend: every agent's plan is tracked by a controller driving CommonRoad's
single-track model — the middle rung between the ideal world and 3D physics.

Each scenario dt the controller runs at its own rate (default 100 Hz) and the plant integrates
with RK4 at 1 kHz, so tyre slip, steering lag and powertrain limits already break the ideal
world's perfect tracking. The model's reference point (its centre of gravity) is taken as the
vehicle's centre.

Settings (``backend_settings``): the tracking (`TrackingSettings`), ``params_id`` (CommonRoad
parameter set), ``model`` (``st`` single-track, or ``mb`` multi-body on request), ``integration_step`` and the reality
knobs ``road_friction`` (1.0 = dry), ``steer_delay`` and ``pedal_delay`` [s].
"""

from __future__ import annotations

import time
from typing import Any, Sequence

from commonroad.scenario.scenario import Scenario
from pydantic import Field

from simgap.control.protocol import Command
from simgap.errors import InputError, validated_settings
from simgap.sim.dynamic.plant import PLANTS, make_plant
from simgap.sim.protocol import Agent, BackendEvent, PhysicsDiverged, enters_at
from simgap.sim.settings import DRY_ROAD_FRICTION, RoadFriction, TrackingSettings
from simgap.sim.tracked import TrackedBackend
from simgap.trajectory import State


class DynamicSettings(TrackingSettings):
    """Settings of the ``dynamic`` world (``backend_settings`` of a run)."""

    params_id: int = Field(2, ge=1, le=3, description="CommonRoad vehicle parameter set")
    model: str = Field("st", description=f"vehicle model: {', '.join(PLANTS)}")
    integration_step: float = Field(0.001, gt=0, le=0.01, description="RK4 sub-step of the vehicle model [s]")
    road_friction: RoadFriction = DRY_ROAD_FRICTION


class SingleTrackWorld:
    """The `Plant` of the ``dynamic`` backend: one CommonRoad vehicle model per agent, each
    integrated on its own (the cars of this world do not touch)."""

    def __init__(self, settings: DynamicSettings):
        self.settings = settings
        self.timings = {"physics": 0.0}
        self.notes: list[str] = []
        self._agents: list[Agent] = []

    def load(self, scenario: Scenario, agents: Sequence[Agent]) -> None:
        cfg = self.settings
        self._agents = list(agents)
        self._dt = float(scenario.dt)
        self._plants = {a.id: make_plant(cfg.model, a.vehicle, cfg.params_id, cfg.road_friction, cfg.integration_step)
                        for a in agents}
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

    def actuate(self, agent_id: int, command: Command, period: float) -> None:
        self._commands[agent_id] = command

    def advance(self, t: float, period: float) -> None:
        start = time.perf_counter()
        for aid, command in self._commands.items():
            try:
                self._states[aid] = self._plants[aid].step(command, period)
            except FloatingPointError as exc:
                raise PhysicsDiverged(f"agent {aid}: {exc}") from None
        self.timings["physics"] += time.perf_counter() - start

    def events(self) -> list[BackendEvent]:
        return []

    def close(self) -> None:
        pass


def dynamic_settings(values: dict[str, Any]) -> DynamicSettings:
    """``values`` validated as the backend's settings."""
    cfg = validated_settings(DynamicSettings, values)
    if cfg.model not in PLANTS:
        raise InputError(f"unknown vehicle model '{cfg.model}'", field="backend_settings.model",
                         allowed=", ".join(PLANTS))
    return cfg


class DynamicBackend(TrackedBackend):
    """The ``dynamic`` backend: `SingleTrackWorld` under a tracking controller per car."""

    def __init__(self, **settings):
        cfg = dynamic_settings(settings)
        self.settings = cfg
        super().__init__("dynamic", SingleTrackWorld(cfg), cfg)
