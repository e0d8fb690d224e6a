"""Plans from the planners to the cars: each agent's planner is asked for a plan when one is due
(every ``replan_every`` steps, or at once if its plan failed or ran out), from the state its
localisation shows it; a plan reaches the car its latency later (`plan_latency`); a cycle without
a plan brakes the car in its lane (`emergency_stop`), and too many in a row give the agent up."""

from __future__ import annotations

import math
import time
from collections.abc import Mapping
from typing import Annotated, Literal

import numpy as np
from commonroad.scenario.lanelet import LaneletNetwork
from pydantic import Field

from simgap.cosim.agent_progress import AgentProgress
from simgap.cosim.history import Event, Outcome, PlannerError
from simgap.cosim.interruptions import PLANNER_CRASHES, RUN_STOPS
from simgap.cosim.judging import Judge
from simgap.cosim.traffic import Traffic
from simgap.planning.plan_check import InvalidPlan, executable_plan
from simgap.planning.protocol import PlannerUnavailable, TrafficParticipant, World
from simgap.polyline import arc_length
from simgap.sim.protocol import EventKind, PlanHandover, PlanInForce, Realism
from simgap.trajectory import State, Trajectory

MEASURED = "measured"
Latency = Literal["measured"] | Annotated[float, Field(ge=0.0, le=1.0)]
RECORDED_PLANNER_ERRORS = 5      # exceptions kept with their tracebacks per run (all are counted)


def plan_latency(setting: Latency, compute_s: float, cycle: float) -> float:
    """How long after its planning time a plan reaches the car: the fixed latency set, or
    (``measured``) the planner's own compute time rounded up to whole planning cycles (the
    scenario's step): a plan made within its cycle drives the car from the next one, a plan that
    overran its cycle one cycle later for each it overran."""
    if setting == MEASURED:
        return max(1, math.ceil(compute_s / cycle - 1e-9)) * cycle
    return float(setting)


class PlanDelivery:
    """Asks each agent's planner for its plans and delivers them to its car after their latency."""

    def __init__(self, road: LaneletNetwork, dt: float, realism: Realism, latency: Latency, replan_every: int,
                 emergency_decel: float, failure_limit: int, traffic: Traffic, judge: Judge,
                 replayed_latencies: Mapping[int, tuple[float, ...]]):
        self.road, self.dt, self.realism, self.latency = road, dt, realism, latency
        self.replan_every, self.emergency_decel, self.failure_limit = replan_every, emergency_decel, failure_limit
        self.traffic, self.judge, self.replayed_latencies = traffic, judge, replayed_latencies
        self.planning_agent: int | None = None      # whose planner is running
        self.planner_errors: list[PlannerError] = []

    def plan(self, p: AgentProgress, state: State, t: float, snapshot: Mapping[int, TrafficParticipant]) -> None:
        """Let ``p``'s planner plan when it is due; a failure brakes the agent in its lane."""
        dt = self.dt
        if not p.active:
            if p.plan is None or p.plan.t_end < t + dt:
                self._brake(p, state)
            return
        due = (p.plan is None or p.plan_age >= self.replan_every
               or p.plan.t_end < t + dt or p.failures_in_row > 0)
        if not due:
            p.plan_age += 1
            return
        world = World(self.road, p.problem.goal, dt,
                      tuple(_traffic_for(p.agent.id, snapshot, self.traffic.participants())))
        observed = p.localisation.observe(p.driven, t)
        p.observed.append(observed)
        clock = time.perf_counter()
        self.planning_agent = p.agent.id
        try:
            plan = p.planner.plan(observed, t, world)
        except RUN_STOPS:
            raise
        except PlannerUnavailable as exc:   # its process is gone for good: the agent is given up
            self.planning_agent = None
            p.call_times.append(time.perf_counter() - clock)
            self._failed(p, state, t, str(exc) or "the planner is unavailable", give_up=True)
            return
        except PLANNER_CRASHES as exc:  # a planner that crashes (or exits) fails its cycle, not the run
            plan, reason = None, f"planner raised {type(exc).__name__}: {exc}"
            self._raised(p, t, exc)
        else:
            plan, reason = self._checked(p, plan, t)
        self.planning_agent = None
        elapsed = time.perf_counter() - clock
        p.call_times.append(elapsed)
        if plan is None:
            self._failed(p, state, t, reason)
        else:
            p.failures_in_row = 0
            p.plan, p.plan_age = plan, 1
            p.plans.append(plan)
            self._send(p, plan, t, elapsed)

    def in_force(self, p: AgentProgress, t: float) -> PlanInForce | None:
        """What ``p``'s car follows over the step from ``t``: its plan in force, handed over to the
        last plan that arrives during the step."""
        dt = self.dt
        while p.arriving and p.arriving[0][0] <= t + 1e-9:
            p.in_force = p.arriving.pop(0)[1]
        during = [(at, plan) for at, plan in p.arriving if at < t + dt - 1e-9]
        if not during:
            return p.in_force
        at, plan = during[-1]
        assert p.in_force is not None, "a plan arrives late only where another is in force (`_send`)"
        handover = PlanHandover(p.in_force, plan, at)
        p.arriving = [(a, q) for a, q in p.arriving if a > at]
        p.in_force = plan
        return handover

    def _send(self, p: AgentProgress, plan: Trajectory, t: float, compute_s: float) -> None:
        """``plan`` (made at ``t``) sets off for the car; it arrives after its latency."""
        replayed = self.replayed_latencies.get(p.agent.id, ())
        if self.realism is Realism.IDEAL:
            latency = 0.0
        elif self.latency == MEASURED and len(p.latencies) < len(replayed):
            latency = replayed[len(p.latencies)]
        else:
            latency = plan_latency(self.latency, compute_s, self.dt)
        p.latencies.append(latency)
        if latency <= 0.0 or p.in_force is None:
            p.in_force, p.arriving = plan, []
        else:
            p.arriving.append((t + latency, plan))

    def _checked(self, p: AgentProgress, plan: object, t: float) -> tuple[Trajectory | None, str]:
        """What ``p``'s planner returned at ``t`` as a plan to execute (None: no plan), and the reason when none."""
        if plan is None:
            return None, p.planner.failure_reason or "no feasible collision-free plan"
        try:
            return executable_plan(plan, t, self.dt), ""
        except InvalidPlan as exc:
            return None, f"invalid plan: {exc}"

    def _brake(self, p: AgentProgress, state: State) -> None:
        """``p``'s car brakes in its lane now: the stack's own fallback, with no latency; plans on
        their way are dropped."""
        p.plan = p.in_force = emergency_stop(state, self.dt, self.emergency_decel, path=p.plan)
        p.arriving = []

    def _raised(self, p: AgentProgress, t: float, exc: BaseException) -> None:
        """Count the exception; keep the first few with their tracebacks for the run record."""
        p.exceptions += 1
        if len(self.planner_errors) < RECORDED_PLANNER_ERRORS:
            self.planner_errors.append(PlannerError.of(exc, p.agent.id, t))

    def _failed(self, p: AgentProgress, state: State, t: float, reason: str, give_up: bool = False) -> None:
        """A cycle without a plan: brake in lane; after `planner_failure_limit` in a row (or at
        once, ``give_up``: the planner can plan no more) the agent is given up."""
        p.failures += 1
        p.failures_in_row += 1
        self.judge.events.append(Event(t, p.agent.id, EventKind.PLANNER_NO_SOLUTION, state.x, state.y,
                                       f"{reason}; braking in lane"))
        if p.failures_in_row == 1:
            self._brake(p, state)
        p.plan_age = 0
        if give_up:
            self.judge.finish(p, Outcome.PLANNER_FAILURE, state, f"the planner is unavailable: {reason}")
        elif p.failures_in_row >= self.failure_limit:
            self.judge.finish(p, Outcome.PLANNER_FAILURE, state,
                              f"{p.failures_in_row} consecutive cycles without a plan; last: {reason}")


def emergency_stop(state: State, dt: float, decel: float, horizon_s: float = 3.0,
                   path: Trajectory | None = None) -> Trajectory:
    """Brake to standstill: along ``path`` (the last plan: in lane) from where it passes closest to
    ``state``, else along the current heading (the loop's fallback when planning fails)."""
    n = max(2, int(round(horizon_s / dt)) + 1)
    v = max(state.v, 0.0)
    speeds = np.maximum(v - decel * dt * np.arange(n), 0.0)
    travel = np.concatenate([[0.0], np.cumsum(0.5 * (speeds[1:] + speeds[:-1]) * dt)])
    x, y, yaw = _along(path, state, travel)
    a = np.where(speeds > 0, -decel, 0.0)
    return Trajectory(dt, t=state.t + dt * np.arange(n), x=x, y=y, yaw=yaw, v=speeds, a=a,
                      yaw_rate=np.zeros(n), steer=np.full(n, state.steer))


def _along(path: Trajectory | None, state: State, travel: np.ndarray):
    """Poses ``travel`` metres from ``state`` along ``path`` (continued straight past its end)."""
    straight = (state.x + travel * math.cos(state.yaw), state.y + travel * math.sin(state.yaw),
                np.full(len(travel), state.yaw))
    if path is None or len(path) < 2:
        return straight
    xy = np.stack([path.x, path.y], axis=1)
    k = int(np.hypot(xy[:, 0] - state.x, xy[:, 1] - state.y).argmin())
    if math.hypot(xy[k, 0] - state.x, xy[k, 1] - state.y) > 1.0:
        return straight                     # the vehicle is not on its plan's path
    xy = np.vstack([[state.x, state.y], xy[k + 1:]])
    if len(xy) < 2:
        return straight
    s = arc_length(xy)
    yaw = np.unwrap(np.concatenate([[state.yaw], np.arctan2(*np.diff(xy, axis=0).T[::-1])]))
    beyond = np.maximum(travel - s[-1], 0.0)
    x = np.interp(travel, s, xy[:, 0]) + beyond * math.cos(yaw[-1])
    y = np.interp(travel, s, xy[:, 1]) + beyond * math.sin(yaw[-1])
    return x, y, np.interp(travel, s, yaw)


def traffic_snapshot(progress_of: Mapping[int, AgentProgress], states: Mapping[int, State],
                     dt: float) -> dict[int, TrafficParticipant]:
    """Each agent as the others see it: its latest plan (or where it stands, before it has one).

    Agents that reached their goal have left the scenario and are not shown.
    """
    snapshot: dict[int, TrafficParticipant] = {}
    for aid, p in progress_of.items():
        if p.outcome == Outcome.GOAL_REACHED or (p.plan is None and aid not in states):
            continue         # left the scenario, or not entered yet
        prediction = p.plan if p.plan is not None else Trajectory.from_states([states[aid]], dt)
        snapshot[aid] = TrafficParticipant(aid, p.agent.vehicle.length, p.agent.vehicle.width, prediction)
    return snapshot


def _traffic_for(aid: int, snapshot: Mapping[int, TrafficParticipant],
                 obstacles) -> list[TrafficParticipant]:
    """What agent ``aid`` sees: the other agents' latest plans and the obstacles' motion."""
    return [tp for oid, tp in snapshot.items() if oid != aid] + list(obstacles)
