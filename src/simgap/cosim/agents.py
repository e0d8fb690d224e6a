"""Agents from planning problems: every planning problem of a scenario becomes an agent."""

from __future__ import annotations

from collections.abc import Mapping

from commonroad.planning.planning_problem import PlanningProblemSet

from simgap.errors import InputError
from simgap.sim.protocol import Agent
from simgap.trajectory import State
from simgap.vehicles import Vehicle


def initial_state(problem, dt: float) -> State:
    s = problem.initial_state
    return State(
        t=s.time_step * dt, x=float(s.position[0]), y=float(s.position[1]),
        yaw=float(s.orientation), v=float(getattr(s, "velocity", 0.0) or 0.0),
        a=float(getattr(s, "acceleration", 0.0) or 0.0),
        yaw_rate=float(getattr(s, "yaw_rate", 0.0) or 0.0))


def agents_from_problems(problems: PlanningProblemSet, dt: float,
                         vehicles: Mapping[int, Vehicle] | Vehicle) -> list[Agent]:
    """One agent per planning problem; ``vehicles`` is one vehicle for all or one per problem id."""
    agents = []
    for pid in sorted(problems.planning_problem_dict):
        problem = problems.planning_problem_dict[pid]
        if isinstance(vehicles, Vehicle):
            vehicle = vehicles
        elif pid in vehicles:
            vehicle = vehicles[pid]
        else:
            raise InputError(f"no vehicle given for planning problem {pid}", field="vehicle",
                             allowed="ids " + ", ".join(map(str, sorted(problems.planning_problem_dict))))
        agents.append(Agent(pid, vehicle, initial_state(problem, dt)))
    return agents
