"""Where one agent of a run stands: its planner, goal and localisation, what it drove, planned and
observed so far, the plans on their way to its car, and its outcome once it has one. The loop's
parts (`plan_delivery`, `judging`, `history_building`) share it."""

from __future__ import annotations

from dataclasses import dataclass, field

from commonroad.planning.planning_problem import PlanningProblem

from simgap.cosim.history import Outcome
from simgap.cosim.sensing import Localisation
from simgap.planning.protocol import Planner
from simgap.scenario.goal import Goal
from simgap.sim.protocol import Agent
from simgap.trajectory import Attitude, State, Trajectory

# a car that reached its goal has left the scenario; one whose physics diverged, the backend's world
LEFT_THE_WORLD = (Outcome.GOAL_REACHED, Outcome.DIVERGED)


@dataclass
class AgentProgress:
    agent: Agent
    planner: Planner
    problem: PlanningProblem
    goal: Goal
    deadline: float
    localisation: Localisation                  # what its planner sees of its car
    driven: list[State] = field(default_factory=list)
    attitudes: list[Attitude] = field(default_factory=list)    # beside `driven`, where the backend has them
    standing: list[State] = field(default_factory=list)        # after its outcome, while in the world
    observed: list[State] = field(default_factory=list)        # what its planner saw, per planning call
    plans: list[Trajectory] = field(default_factory=list)
    plan: Trajectory | None = None              # the newest plan (what the other agents see)
    in_force: Trajectory | None = None          # the plan the car follows
    arriving: list[tuple[float, Trajectory]] = field(default_factory=list)   # plans on their way: (when, plan)
    latencies: list[float] = field(default_factory=list)
    plan_age: int = 0
    outcome: Outcome | None = None
    failures_in_row: int = 0
    failures: int = 0
    exceptions: int = 0
    call_times: list[float] = field(default_factory=list)     # wall time of every planning call [s]

    @property
    def active(self) -> bool:
        return self.outcome is None

    @property
    def last_state(self) -> State:
        """Where it was last seen: its last driven state, or where it started."""
        return self.driven[-1] if self.driven else self.agent.initial_state
