"""The ideal 2D backend: every plan is executed exactly, as in CommonRoad.

After each step a vehicle stands on its plan at t + dt (perfect control, exact state
knowledge, no dynamics) on a plane, whatever the road's relief. It is the low-fidelity end of the
fidelity ladder.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

from commonroad.scenario.scenario import Scenario
from pydantic import BaseModel, ConfigDict

from simgap.errors import InputError
from simgap.scenario.relief import Surface
from simgap.sim.protocol import REFERENCE, Agent, BackendEntry, BackendEvent, PlanInForce, Realism, enters_at, plan_at
from simgap.trajectory import DEFAULT_TIME_STEP_S, Attitude, State


class NoSettings(BaseModel):
    """The settings of a backend that takes none (the ideal world executes every plan exactly)."""

    model_config = ConfigDict(extra="forbid", frozen=True)


def no_settings(settings: Mapping[str, Any]) -> NoSettings:
    if settings:
        raise InputError("the ideal backend has no settings: it executes every plan exactly",
                         field=f"backend_settings.{next(iter(settings))}", allowed="none")
    return NoSettings()


class IdealBackend:
    name = REFERENCE
    realism = Realism.IDEAL

    def __init__(self, settings: object = None) -> None:
        """``settings``: `NoSettings` (the ideal world takes none)."""
        self._agents: list[Agent] = []
        self._states: dict[int, State] = {}
        self._dt = DEFAULT_TIME_STEP_S          # the scenario's, once loaded
        self._step = 0
        self.timings: dict[str, float] = {}
        self.notes: list[str] = []

    def load(self, scenario: Scenario, agents: Sequence[Agent], relief: Surface | None = None) -> None:
        self._agents = list(agents)
        self._dt = float(scenario.dt)

    def reset(self) -> dict[int, State]:
        self._states = {a.id: a.initial_state for a in self._agents if enters_at(a, 0.0, self._dt)}
        self._step = 0
        return dict(self._states)

    def step(self, plans: Mapping[int, PlanInForce]) -> dict[int, State]:
        self._step += 1
        t_next = self._step * self._dt          # no drift from summing dt
        for aid, state in self._states.items():
            plan = plans.get(aid)
            if plan is None:
                self._states[aid] = state.replace(t=t_next, v=0.0, a=0.0, yaw_rate=0.0)
            else:
                self._states[aid] = plan_at(plan, t_next).at(t_next).replace(t=t_next)
        for a in self._agents:
            if a.id not in self._states and enters_at(a, t_next, self._dt):
                self._states[a.id] = a.initial_state.replace(t=t_next)
        return dict(self._states)

    def attitudes(self) -> dict[int, Attitude]:
        return {}

    def events(self) -> list[BackendEvent]:
        return []

    def control_traces(self) -> None:
        """None: the ideal world executes each plan exactly, with no controller and no actuators."""
        return None

    def close(self) -> None:
        pass


#: the ideal backend, as the registry knows it
BACKEND = BackendEntry(IdealBackend, no_settings, "simgap.sim.ideal")
