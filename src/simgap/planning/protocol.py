"""What a planner is given and what it returns. Planners know nothing about backends."""

from __future__ import annotations

from dataclasses import dataclass, field
from enum import StrEnum
from typing import TYPE_CHECKING, Protocol, Sequence

from commonroad.planning.goal import GoalRegion
from commonroad.planning.planning_problem import PlanningProblem
from commonroad.scenario.lanelet import LaneletNetwork

from simgap.trajectory import DEFAULT_TIME_STEP_S, State, Trajectory

if TYPE_CHECKING:
    from simgap.vehicles.catalogue import Vehicle


class PlanOutcome(StrEnum):
    """How a built-in planner's cycle ended (its diagnostics; a string enum)."""

    PLANNED = "planned"
    STRUCK_FROM_BEHIND = "struck_from_behind"   # every plan meets traffic, this one only what runs into it
    NO_FEASIBLE_SAMPLE = "no_feasible_sample"   # nothing within the vehicle's limits
    ALL_COLLIDING = "all_colliding"             # every plan within the limits meets traffic or leaves the road
    NO_PLAN = "no_plan"                         # (reactive) no plan found
    PROJECTION_FAILED = "projection_failed"     # the observed state is not on the reference path


@dataclass(frozen=True)
class TrafficParticipant:
    """Another road user as a planner sees it: its footprint and where it will be.

    ``prediction`` is another agent's latest plan, or a non-agent obstacle's recorded
    trajectory; its states are centre positions on the scenario's time grid.
    """

    id: int
    length: float
    width: float
    prediction: Trajectory


@dataclass(frozen=True)
class World:
    """Everything outside the ego vehicle that a planner may use."""

    lanelet_network: LaneletNetwork
    goal: GoalRegion
    dt: float
    traffic: Sequence[TrafficParticipant] = field(default_factory=tuple)


class Planner(Protocol):
    """``plan`` must accept any observed state: moving, off-centre, with a heading error.

    It returns a trajectory starting at time ``t`` on the grid ``world.dt`` — at ``observed``,
    or on its own previous plan when the vehicle is close to it (plan stitching) — or ``None``
    when no feasible, collision-free plan exists.
    """

    def plan(self, observed: State, t: float, world: World) -> Trajectory | None: ...


class PlannerUnavailable(Exception):
    """Raised by ``plan`` when the planner can plan no more (its process is gone and was not
    restarted): the loop gives the agent up as a planner failure, with this reason."""


@dataclass(frozen=True)
class PlannerSetup:
    """What a planner is built from, once per agent, before the first cycle.

    A planner class is constructed as ``cls(setup, settings)``, ``cls(setup)`` or ``cls()``, as
    its constructor takes them: ``settings`` is an instance of the class's ``Settings`` pydantic
    model when it declares one (``None`` otherwise; the registry validates the user's settings
    through that model, so a bad field is refused before any run starts). ``vehicle`` is the model the planner assumes it drives (not necessarily the
    simulated car). ``agent_id`` is the planning problem's id; ``dt`` the scenario's time step,
    the grid every returned trajectory must lie on. A constructor that raises fails that run
    (recorded with the traceback), not the batch.
    """

    agent_id: int
    vehicle: Vehicle
    lanelet_network: LaneletNetwork
    planning_problem: PlanningProblem
    dt: float

    @classmethod
    def for_problem(cls, planning_problem: PlanningProblem, vehicle: Vehicle, lanelet_network: LaneletNetwork,
                    dt: float = DEFAULT_TIME_STEP_S) -> "PlannerSetup":
        """The setup of the agent that drives ``planning_problem`` (the agent's id is the problem's)."""
        return cls(planning_problem.planning_problem_id, vehicle, lanelet_network, planning_problem, dt)
