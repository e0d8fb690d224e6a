"""What a planner is given and what it returns, and what simgap asks of every planner.

Planners know nothing about backends. The types here carry the field names of the planner SDK
(`simgap_planner`, the package a planner in a process of its own is served with): a planner
written against those names runs unchanged in simgap's process and in its own.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from enum import StrEnum
from functools import cached_property
from typing import TYPE_CHECKING, Any

import numpy as np
from commonroad.planning.goal import GoalRegion
from commonroad.planning.planning_problem import PlanningProblem, PlanningProblemSet
from commonroad.scenario.lanelet import LaneletNetwork
from commonroad.scenario.scenario import Scenario

from simgap.planning.route import route_centre_line
from simgap.scenario.files import scenario_xml
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


@dataclass(frozen=True)
class PlannerReport:
    """What a run's record keeps of how a planner in a process of its own ran (run.json's
    ``settings.planner.process``): where it ran, the name and protocol version its Ready gave,
    its deadline, and how often it missed it or was restarted."""

    target: str                 # the command simgap started, or the address it connected to
    planner: str                # the name the planner gave itself
    protocol_version: str
    deadline_s: float
    deadline_misses: int = 0
    restarts: int = 0


class Planner(ABC):
    """What simgap asks of every planner, in its own process or in a process of its own (after
    nuPlan's abstract planner): ``plan`` each cycle; ``failure_reason`` when it returned no plan;
    ``close`` once, at the end of the run; ``report`` for the run's record.

    ``plan`` must accept any observed state: moving, off-centre, with a heading error. It returns
    a trajectory starting at time ``t`` on the grid ``world.dt`` — at ``observed``, or on its own
    previous plan when the vehicle is close to it (plan stitching) — or ``None`` when no feasible,
    collision-free plan exists.

    A planner class needs only ``plan``: one that does not derive from `Planner` is wrapped in one
    when it is built (`as_planner`), its own ``failure_reason`` and ``close`` used when it has them.
    """

    failure_reason: str = ""    # why the last ``plan`` returned None ("" when it gave no reason)

    @abstractmethod
    def plan(self, observed: State, t: float, world: World) -> Trajectory | None: ...

    def close(self) -> None:  # noqa: B027 - optional: most planners hold nothing
        """Release what the planner holds (a process, files); called once, when its run ends."""

    def report(self) -> PlannerReport | None:
        """What the run's record keeps of the planner's process (None: it ran in simgap's)."""
        return None


class _PlainPlanner(Planner):
    """A planner class's object that does not derive from `Planner` (the SDK asks only ``plan``
    of it), with the rest of the contract: its ``failure_reason`` and ``close`` when it has them."""

    def __init__(self, planner: Any):
        self.planner = planner
        self.plan = planner.plan  # type: ignore[method-assign]  # the planner's own method: no extra call per cycle
        closer = getattr(planner, "close", None)
        self._close = closer if callable(closer) else None

    def plan(self, observed: State, t: float, world: World) -> Trajectory | None:   # replaced in __init__
        return self.planner.plan(observed, t, world)

    @property
    def failure_reason(self) -> str:        # type: ignore[override]
        return str(getattr(self.planner, "failure_reason", "") or "")

    def close(self) -> None:
        if self._close is not None:
            self._close()


def as_planner(planner: Any) -> Planner:
    """``planner`` with the whole `Planner` contract: itself when it derives from `Planner`."""
    return planner if isinstance(planner, Planner) else _PlainPlanner(planner)


class PlannerUnavailable(Exception):
    """Raised by ``plan`` when the planner can plan no more (its process is gone and was not
    restarted): the loop gives the agent up as a planner failure, with this reason."""


class RemotePlannerError(RuntimeError):
    """A planner in a process of its own answered a planning request with an error;
    ``remote_traceback`` is its own."""

    def __init__(self, kind: str, message: str, remote_traceback: str):
        super().__init__(f"{kind}: {message}" if message else kind)
        self.kind, self.remote_traceback = kind, remote_traceback


@dataclass(frozen=True)
class PlannerSetup:
    """What a planner is built from, once per agent, before the first cycle.

    A planner class is constructed as ``cls(setup, settings)``, ``cls(setup)`` or ``cls()``, as
    its constructor takes them: ``settings`` is an instance of the class's ``Settings`` pydantic
    model when it declares one (``None`` otherwise; the registry validates the user's settings
    through that model, so a bad field is refused before any run starts); ``settings`` here holds
    the same settings as a JSON object, as a planner in a process of its own gets them.
    ``vehicle`` is the model the planner assumes it drives (not necessarily the simulated car;
    its limits in ``vehicle.limits``); ``route`` the route centre line to the goal. ``agent_id``
    is the planning problem's id; ``dt`` the scenario's time step, the grid every returned
    trajectory must lie on. A constructor that raises fails that run
    (recorded with the traceback), not the batch.
    """

    agent_id: int
    vehicle: Vehicle
    lanelet_network: LaneletNetwork
    planning_problem: PlanningProblem
    dt: float
    settings: Mapping[str, Any] = field(default_factory=dict)

    @classmethod
    def for_problem(cls, planning_problem: PlanningProblem, vehicle: Vehicle, lanelet_network: LaneletNetwork,
                    dt: float = DEFAULT_TIME_STEP_S) -> PlannerSetup:
        """The setup of the agent that drives ``planning_problem`` (the agent's id is the problem's)."""
        return cls(planning_problem.planning_problem_id, vehicle, lanelet_network, planning_problem, dt)

    @cached_property
    def route(self) -> np.ndarray:
        """simgap's route centre line from the initial state to the goal, an (N, 2) array of
        points [m] (no points when the goal cannot be reached on the lanelet network); worked out
        on first use."""
        try:
            line, _ = route_centre_line(self.lanelet_network, self.planning_problem)
        except Exception:           # no route to the goal: the planner gets the map and the problem alone
            return np.zeros((0, 2))
        return np.asarray(line, dtype=float).reshape(-1, 2)

    @cached_property
    def commonroad_xml(self) -> str:
        """The CommonRoad XML of the lanelet network and the planning problem (what the protocol sends)."""
        scenario = Scenario(self.dt)
        scenario.add_objects(self.lanelet_network)
        return scenario_xml(scenario, PlanningProblemSet([self.planning_problem]))
