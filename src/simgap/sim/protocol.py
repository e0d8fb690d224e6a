"""The `Backend` contract shared by the ideal 2D world and the physics worlds."""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from enum import Enum, StrEnum
from typing import Any, Protocol

from commonroad.scenario.scenario import Scenario

from simgap.scenario.relief import Surface
from simgap.trajectory import Attitude, ControlTrace, State, Trajectory
from simgap.vehicles import Vehicle

REFERENCE = "ideal"     # the ideal backend's name: the world of the planner's assumptions, which every other is compared with


class Realism(str, Enum):
    """How real a physics world's car is. ``real`` (the default): the vehicle's measured actuators,
    a localisation that drifts, and compute latency; ``ideal``: a perfect machine (actuators that
    act at once, the exact state observed, plans that take no time) — the ideal world's
    assumptions on a physical car. The ideal backend is always ``ideal``."""

    REAL = "real"
    IDEAL = "ideal"


@dataclass(frozen=True)
class PlanHandover:
    """A plan that reaches the car during a step (after its compute latency): the ``previous``
    plan stays in force until ``at``, then ``plan`` takes over."""

    previous: Trajectory
    plan: Trajectory
    at: float

    def in_force(self, t: float) -> Trajectory:
        return self.plan if t >= self.at - 1e-9 else self.previous


PlanInForce = Trajectory | PlanHandover


def plan_at(plan: PlanInForce, t: float) -> Trajectory:
    """The trajectory a car follows at ``t``."""
    return plan.in_force(t) if isinstance(plan, PlanHandover) else plan


@dataclass(frozen=True)
class Agent:
    """A vehicle driven by a planner: one per planning problem of the scenario."""

    id: int
    vehicle: Vehicle
    initial_state: State


def enters_at(agent: Agent, t: float, dt: float) -> bool:
    """``agent`` enters the world at time ``t`` (its initial state's time, on the dt grid)."""
    return abs(agent.initial_state.t - t) < 0.5 * dt


class Outcome(StrEnum):
    """How an agent's run ended (a string enum: it compares and serialises as its value)."""

    GOAL_REACHED = "goal_reached"
    COLLISION = "collision"
    OFF_ROAD = "off_road"
    PLANNER_FAILURE = "planner_failure"      # no feasible plan for too long
    TIMEOUT = "timeout"                      # the goal not reached by its deadline
    DIVERGED = "diverged"                    # the physics blew up

    @classmethod
    def worst(cls, outcomes: list[Outcome]) -> Outcome:
        """The first outcome that is not reaching the goal, else reaching it."""
        return next((o for o in outcomes if o != cls.GOAL_REACHED), cls.GOAL_REACHED)


class EventKind(StrEnum):
    """What a run's event records besides how an agent's run ended (an `Outcome`, which a backend
    reports too: a contact, a blow-up): a planning cycle without a plan, or damage a backend saw
    (a string enum: it compares and serialises as its value)."""

    PLANNER_NO_SOLUTION = "planner_no_solution"
    DAMAGE = "damage"


def event_kind(value: str) -> Outcome | EventKind:
    """An event's kind by its value: the outcome of that value, else the event kind."""
    try:
        return Outcome(value)
    except ValueError:
        return EventKind(value)


@dataclass(frozen=True)
class BackendEvent:
    """Something the backend itself observed (a physical contact, a blow-up)."""

    t: float
    agent_id: int
    kind: Outcome | EventKind    # Outcome.COLLISION, Outcome.DIVERGED or EventKind.DAMAGE
    detail: str = ""
    other_id: int | None = None


@dataclass(frozen=True)
class BackendEntry:
    """What a backend declares to the registry (`simgap.sim.registry`): an object that its
    ``module:attr`` names, for a built-in in `BUILTIN_BACKENDS`, for an installed one in the
    entry-point group ``simgap.backends``. Each callable may be given as ``module:attr``, imported
    on first use (naming a backend loads neither its physics engine nor an optional one that is
    not installed)."""

    make: str | Callable[[Any], Backend]                       # the backend, from its settings model
    settings: str | Callable[[dict[str, Any]], Any]            # a mapping validated into that model
    module: str                                                 # must be importable
    extra: str | None = None                                    # pip extra that installs it (optional backends)
    check: str | Callable[[Any], None] | None = None            # raises when it cannot run with these settings


class PhysicsDiverged(RuntimeError):
    """Raised by a backend when its numerical state blew up (NaN, a flipped chassis)."""


class Backend(Protocol):
    """A world that advances exactly one scenario dt per `step`.

    ``load`` is given the scenario (lanelets, non-agent obstacles), the agents and the
    vehicle each agent drives, and the road's relief (None: a flat road; the ideal world is flat
    whatever the road: the planner's assumption). The run's clock starts at 0 (the scenario's first time step).
    ``reset`` puts every agent whose initial state is at 0 there and returns the observed
    states. ``step`` executes the plans (each starting at the current time) for one dt and
    returns each present agent's observed state afterwards. An agent whose initial state lies
    later (a planning problem of a recorded scenario that starts when its vehicle enters the
    road) is out of the world until then: no state of it is returned, and at the step that
    reaches its initial time it is put at its initial state (`enters_at`).

    The loop reads ``timings`` (wall seconds spent per phase inside the backend, e.g. control
    and physics; added to the run's timings) and ``notes`` (what the backend did that the run
    record should say, e.g. how it approximated a moving start) once the run ends. A plan that
    reaches a car during the step (a `PlanHandover`) is followed from its time on. ``attitudes``
    gives the third dimension of the states the last `reset` or `step` returned, for the agents
    whose world has one. ``control_traces`` gives, once the run ends, what each car's controller
    asked and what the car did per control tick (None: a world that executes plans exactly).
    """

    name: str
    timings: dict[str, float]
    notes: list[str]
    realism: Realism            # the ideal world's is IDEAL: the loop then adds no sensing error and no latency

    def load(self, scenario: Scenario, agents: Sequence[Agent], relief: Surface | None = None) -> None: ...

    def reset(self) -> dict[int, State]: ...

    def step(self, plans: Mapping[int, PlanInForce]) -> dict[int, State]: ...

    def attitudes(self) -> dict[int, Attitude]:
        """Height, pitch and roll of the agents of the last states (none from a plane)."""
        ...

    def events(self) -> list[BackendEvent]:
        """Events observed during the last step (may be empty)."""
        ...

    def control_traces(self) -> Mapping[int, ControlTrace] | None:
        """Per agent whose car a controller drives, its `ControlTrace` since the last `reset`
        (None: this world has no controller and no actuators)."""
        ...

    def close(self) -> None: ...
