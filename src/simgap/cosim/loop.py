"""The synchronous multi-agent co-simulation loop.

Every dt: observe each agent's state from the backend → every active agent plans (every
``replan_every`` steps, or at once if its plan failed or ran out) → the backend advances one dt
and the non-agent traffic moves (as recorded, or by its IDM) → the loop checks goal, collision,
road departure and timeout. The loop knows nothing about any concrete backend or planner: it is
handed a `Backend` and one `Planner` per agent.

The goal is CommonRoad's (`simgap.scenario.goal`): any goal state counts, and the end of its time
window is the agent's deadline. When a planner finds no plan, the agent brakes along the path of
its last plan (in its lane), and the event records the planner's reason.

In a physical world whose realism is ``real`` (the default of the physics backends) two things
stand between the planner and its car. Sensing: each time an agent plans it sees its own state
through its localisation (`simgap.cosim.sensing`: drifting errors, an estimate's latency), seeded
per run and agent; the backend, the record and the monitors keep the true state. Latency: a plan
made from the state observed at t reaches the car ``latency`` later — a fixed time, or the
planner's own compute time rounded up to whole planning cycles (``measured``, the default): as in
a stack that plans in cycles of the scenario's step, a plan drives the car from the cycle after
the one it was made in, and a planner that overruns its cycle pays a cycle more for each it
overran. A planner that keeps its cycle runs bit for bit the same; one that overruns it on some
calls makes the run depend on the machine's speed there (a fixed latency never does). Until a
plan arrives the car follows the plan it had.
The ideal world takes neither: it is the planner's assumption.

On a road with a relief (its ``relief``, handed to the backend) the planners still plan and
observe in the plane; the record keeps, beside each driven state, the car's height, pitch and roll
where the backend has them (`Backend.attitudes`).
"""

from __future__ import annotations

import copy
import math
import time
from dataclasses import dataclass, field
from typing import Annotated, Callable, ClassVar, Literal, Mapping

from commonroad.planning.planning_problem import PlanningProblem, PlanningProblemSet
from commonroad.scenario.scenario import Scenario
import numpy as np
from pydantic import BaseModel, ConfigDict, Field

from simgap.polyline import arc_length
from simgap.cosim.interruptions import PLANNER_CRASHES, RUN_STOPS, WallClockExceeded, interruptions
from simgap.cosim.history import AgentHistory, Event, History, Outcome, PlannerError
from simgap.cosim.sensing import Localisation, SensingProfile, SensingSettings, localisation_accuracy
from simgap.cosim.traffic import Traffic, TrafficMode, make_traffic
from simgap.planning.plan_check import InvalidPlan, executable_plan
from simgap.planning.protocol import Planner, PlannerUnavailable, TrafficParticipant, World, as_planner
from simgap.scenario.goal import Goal
from simgap.scenario.relief import Surface
from simgap.scenario.road_frame import DrivableArea, footprint
from simgap.sim.assumptions import Assumption, Restorations
from simgap.sim.protocol import Agent, Backend, EventKind, PhysicsDiverged, PlanHandover, PlanInForce, Realism
from simgap.trajectory import Attitude, ControlTrace, State, Trajectory


MEASURED = "measured"
Latency = Literal["measured"] | Annotated[float, Field(ge=0.0, le=1.0)]


def plan_latency(setting: Latency, compute_s: float, cycle: float) -> float:
    """How long after its planning time a plan reaches the car: the fixed latency set, or
    (``measured``) the planner's own compute time rounded up to whole planning cycles (the
    scenario's step): a plan made within its cycle drives the car from the next one, a plan that
    overran its cycle one cycle later for each it overran."""
    if setting == MEASURED:
        return max(1, math.ceil(compute_s / cycle - 1e-9)) * cycle
    return float(setting)


DEFAULT_TIME_LIMIT_S = 60.0
MAX_SIMULATED_TIME_S = 600.0     # no run simulates longer, whatever its goal's time window
# a car that reached its goal has left the scenario; one whose physics diverged, the backend's world
_LEFT_THE_WORLD = (Outcome.GOAL_REACHED, Outcome.DIVERGED)
RECORDED_PLANNER_ERRORS = 5      # exceptions kept with their tracebacks per run (all are counted)


class CosimSettings(BaseModel):
    """Settings of the loop (not of the planner or backend)."""

    model_config = ConfigDict(extra="forbid", allow_inf_nan=False)
    # what a physical world of realism real breaks between the planner and its car: exact
    # observation, and plans that take no time
    ASSUMPTIONS: ClassVar[Restorations] = {Assumption.SENSING: {"sensing": SensingSettings(profile=SensingProfile.PERFECT)},
                                           Assumption.LATENCY: {"latency": 0.0}}

    replan_every: int = Field(1, ge=1, description="replan every N steps (the paper's Frenetix: 3)")
    max_time_s: float | None = Field(
        None, gt=0, le=MAX_SIMULATED_TIME_S,
        description="limit on simulated time [s]; default: the end of the goal's time window (the planning "
                    f"problem's deadline), or {DEFAULT_TIME_LIMIT_S:g} s when it states none; never more than "
                    f"{MAX_SIMULATED_TIME_S:g} s")
    emergency_decel: float = Field(8.0, gt=0, description="deceleration of the emergency stop [m/s^2]")
    planner_failure_limit: int = Field(
        10, ge=1, description="consecutive failed planning cycles before an agent is given up")
    offroad_tolerance: float = Field(0.05, ge=0, description="footprint may exceed the road by [m]")
    sensing: SensingSettings = Field(default_factory=SensingSettings,
                                     description="the localisation each planner observes its car through (physical "
                                                 "worlds of realism real)")
    latency: Latency = Field(MEASURED, description="when a plan reaches the car after its planning time: measured "
                             "(the planner's compute time, rounded up to whole planning cycles of the scenario's "
                             "step) or a fixed time [s] (physical worlds of realism real)")
    traffic: TrafficMode = Field(TrafficMode.REPLAY, description="recorded traffic: replay (as recorded) or idm "
                                 "(driven along its recorded path by an IDM towards the vehicle ahead)")
    planning_budget_s: float | None = Field(
        None, gt=0, description="wall time a planning call may take [s]; longer calls are counted per agent "
                                "(over budget), the run goes on; default: no budget")


@dataclass
class _AgentProgress:
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


def deadline(goal: Goal, settings: CosimSettings) -> float:
    """When an agent times out: the cap when set, else the goal's deadline (at most
    `MAX_SIMULATED_TIME_S`), else the default."""
    if settings.max_time_s is not None:
        return settings.max_time_s
    return min(goal.deadline_s, MAX_SIMULATED_TIME_S) if goal.deadline_s is not None else DEFAULT_TIME_LIMIT_S


def simulate(
    scenario: Scenario,
    problems: PlanningProblemSet,
    backend: Backend,
    agents: list[Agent],
    planners: Mapping[int, Planner],
    settings: CosimSettings | None = None,
    progress: Callable[[float], None] | None = None,
    seed: int = 0,
    wall_time_limit_s: float | None = None,
    relief: Surface | None = None,
    replayed_latencies: Mapping[int, tuple[float, ...]] | None = None,
) -> History:
    """Run the co-simulation of ``agents`` (one per planning problem) in ``backend`` on the road's
    ``relief`` (None: flat); ``seed`` seeds the localisations' errors. A run still going after
    ``wall_time_limit_s`` (even in a planning call that does not return) is stopped and recorded as
    failed. ``replayed_latencies`` (agent id -> the latency of each of its plans, in order, as a
    record keeps them) replace the ``measured`` latencies, so a run made on a loaded machine
    replays exactly on an idle one."""
    return _CoSimulation(scenario, problems, backend, agents, planners, settings or CosimSettings(), seed,
                         wall_time_limit_s, relief, replayed_latencies or {}).run(progress)


class _CoSimulation:
    """One run of the loop: the agents' progress, the traffic, the events and the timings."""

    def __init__(self, scenario: Scenario, problems: PlanningProblemSet, backend: Backend, agents: list[Agent],
                 planners: Mapping[int, Planner], settings: CosimSettings, seed: int, wall_time_limit_s: float | None,
                 relief: Surface | None, replayed_latencies: Mapping[int, tuple[float, ...]]):
        self.scenario, self.backend, self.settings, self.relief = scenario, backend, settings, relief
        self.replayed_latencies = replayed_latencies
        self.realism = backend.realism
        self.wall_time_limit_s = wall_time_limit_s
        self.planning_agent: int | None = None      # whose planner is running
        self.dt = float(scenario.dt)
        self.timings = {"planning": 0.0, "execution": 0.0, "monitoring": 0.0}
        self.events: list[Event] = []
        self.traffic_driven: dict[int, list[State]] = {}     # the IDM traffic's states, by obstacle
        self.planner_errors: list[PlannerError] = []
        self.traffic: Traffic = make_traffic(scenario, settings.traffic)
        self.road = DrivableArea(scenario.lanelet_network, settings.offroad_tolerance)
        self.progress_of: dict[int, _AgentProgress] = {}
        self.accuracy = localisation_accuracy(settings.sensing, self.realism)
        for a in agents:
            problem = problems.planning_problem_dict[a.id]
            goal = Goal.of(problem.goal, self.dt)
            localisation = Localisation(self.accuracy, np.random.default_rng((seed, a.id)))
            self.progress_of[a.id] = _AgentProgress(a, as_planner(planners[a.id]), problem, goal, deadline(goal, settings),
                                                    localisation)
        self.horizon = max(p.deadline for p in self.progress_of.values())
        self.agents = agents

    def run(self, progress: Callable[[float], None] | None) -> History:
        wall_start = time.perf_counter()
        self.backend.load(self._scenario_for_backend(), self.agents, self.relief)
        failure = None
        limit = self.wall_time_limit_s
        step = 0
        try:
            with interruptions(limit):
                states = self.backend.reset()
                self._drove(states)
                self._record_traffic(0.0)
                while any(p.active for p in self.progress_of.values()):
                    if limit is not None and time.perf_counter() - wall_start > limit:
                        raise WallClockExceeded(limit)
                    states = self._step(step, states)
                    step += 1
                    if progress is not None:
                        progress(min(1.0, step * self.dt / self.horizon))
        except WallClockExceeded as exc:
            where = "" if self.planning_agent is None else f" in agent {self.planning_agent}'s planning call"
            failure = f"timeout: {exc}{where} at t = {step * self.dt:.1f} s"
            for p in self.progress_of.values():
                if p.active:
                    self._finish(p, Outcome.TIMEOUT, p.driven[-1] if p.driven else p.agent.initial_state, failure)
        except PhysicsDiverged as exc:
            failure = f"physics diverged: {exc}"
            for p in self.progress_of.values():
                if p.active:
                    self._finish(p, Outcome.DIVERGED, p.driven[-1] if p.driven else p.agent.initial_state, str(exc))
        else:
            diverged = [e for e in self.events if e.kind == Outcome.DIVERGED]
            if diverged and len(diverged) == len(self.progress_of):   # no agent has a verdict of the scenario
                failure = f"physics diverged: agent {diverged[0].agent_id}: {diverged[0].detail}"
        finally:
            backend_timings = dict(self.backend.timings)
            backend_notes = list(self.backend.notes)
            controls = dict(self.backend.control_traces() or {})
            self.backend.close()
        self.timings.update(backend_timings)
        return self._record(time.perf_counter() - wall_start, backend_notes, failure, controls)

    def _scenario_for_backend(self) -> Scenario:
        """The scenario as the backend builds it: with IDM traffic the loop moves the recorded
        vehicles, so the backend gets none of the obstacles the IDM drives."""
        if self.settings.traffic is TrafficMode.REPLAY or not self.scenario.dynamic_obstacles:
            return self.scenario
        scenario = copy.deepcopy(self.scenario)
        for obstacle in list(scenario.dynamic_obstacles):
            scenario.remove_obstacle(obstacle)
        return scenario

    def _step(self, step: int, states: dict[int, State]) -> dict[int, State]:
        """Plan, execute one dt, move the traffic, monitor; returns the new states."""
        t = step * self.dt
        clock = time.perf_counter()
        snapshot = _traffic_snapshot(self.progress_of, states, self.dt)   # every agent plans from it
        for aid, state in states.items():          # agents that have entered the world
            self._plan(self.progress_of[aid], state, t, snapshot)
        self.timings["planning"] += time.perf_counter() - clock
        clock = time.perf_counter()
        states = self.backend.step({aid: self._in_force(p, t) for aid, p in self.progress_of.items()})
        self.timings["execution"] += time.perf_counter() - clock
        clock = time.perf_counter()
        self.traffic.advance(t, self.dt, snapshot)
        self._drove({aid: st for aid, st in states.items() if self.progress_of[aid].active})
        self._stood(states)
        self._record_traffic(t + self.dt)
        self._monitor(states, t + self.dt)
        self.timings["monitoring"] += time.perf_counter() - clock
        return states

    def _drove(self, states: Mapping[int, State]) -> None:
        """Record the agents' ``states`` (a finished agent's record ends where it finished) and
        their attitudes."""
        attitudes = self.backend.attitudes()
        for aid, st in states.items():
            self.progress_of[aid].driven.append(st)
            if aid in attitudes:
                self.progress_of[aid].attitudes.append(attitudes[aid])

    def _stood(self, states: Mapping[int, State]) -> None:
        """Record where the finished agents still in the world stand (their cars stay there)."""
        for aid, st in states.items():
            p = self.progress_of[aid]
            if not p.active and p.outcome not in _LEFT_THE_WORLD:
                p.standing.append(st)

    def _record_traffic(self, t: float) -> None:
        """Record where the road users the loop drives itself (IDM traffic) are at ``t``."""
        if self.traffic.driven_ids:
            for oid, (state, _, _) in self.traffic.poses(t, self.traffic.driven_ids).items():
                self.traffic_driven.setdefault(oid, []).append(state)

    def _plan(self, p: _AgentProgress, state: State, t: float, snapshot: Mapping[int, TrafficParticipant]) -> None:
        """Let ``p``'s planner plan when it is due; a failure brakes the agent in its lane."""
        settings, dt = self.settings, self.dt
        if not p.active:
            if p.plan is None or p.plan.t_end < t + dt:
                self._brake(p, state)
            return
        due = (p.plan is None or p.plan_age >= settings.replan_every
               or p.plan.t_end < t + dt or p.failures_in_row > 0)
        if not due:
            p.plan_age += 1
            return
        world = World(self.scenario.lanelet_network, p.problem.goal, dt,
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
            self._planner_failed(p, state, t, str(exc) or "the planner is unavailable", give_up=True)
            return
        except PLANNER_CRASHES as exc:  # a planner that crashes (or exits) fails its cycle, not the run
            plan, reason = None, f"planner raised {type(exc).__name__}: {exc}"
            self._planner_raised(p, t, exc)
        else:
            plan, reason = self._checked(p, plan, t)
        self.planning_agent = None
        elapsed = time.perf_counter() - clock
        p.call_times.append(elapsed)
        if plan is None:
            self._planner_failed(p, state, t, reason)
        else:
            p.failures_in_row = 0
            p.plan, p.plan_age = plan, 1
            p.plans.append(plan)
            self._send(p, plan, t, elapsed)

    def _send(self, p: _AgentProgress, plan: Trajectory, t: float, compute_s: float) -> None:
        """``plan`` (made at ``t``) sets off for the car; it arrives after its latency."""
        replayed = self.replayed_latencies.get(p.agent.id, ())
        if self.realism is Realism.IDEAL:
            latency = 0.0
        elif self.settings.latency == MEASURED and len(p.latencies) < len(replayed):
            latency = replayed[len(p.latencies)]
        else:
            latency = plan_latency(self.settings.latency, compute_s, self.dt)
        p.latencies.append(latency)
        if latency <= 0.0 or p.in_force is None:
            p.in_force, p.arriving = plan, []
        else:
            p.arriving.append((t + latency, plan))

    def _in_force(self, p: _AgentProgress, t: float) -> PlanInForce | None:
        """What ``p``'s car follows over the step from ``t``: its plan in force, handed over to the
        last plan that arrives during the step."""
        dt = self.dt
        while p.arriving and p.arriving[0][0] <= t + 1e-9:
            p.in_force = p.arriving.pop(0)[1]
        during = [(at, plan) for at, plan in p.arriving if at < t + dt - 1e-9]
        if not during:
            return p.in_force
        at, plan = during[-1]
        handover = PlanHandover(p.in_force, plan, at)
        p.arriving = [(a, q) for a, q in p.arriving if a > at]
        p.in_force = plan
        return handover

    def _checked(self, p: _AgentProgress, plan: object, t: float) -> tuple[Trajectory | None, str]:
        """What ``p``'s planner returned at ``t`` as a plan to execute (None: no plan), and the reason when none."""
        if plan is None:
            return None, p.planner.failure_reason or "no feasible collision-free plan"
        try:
            return executable_plan(plan, t, self.dt), ""
        except InvalidPlan as exc:
            return None, f"invalid plan: {exc}"

    def _brake(self, p: _AgentProgress, state: State) -> None:
        """``p``'s car brakes in its lane now: the stack's own fallback, with no latency; plans on
        their way are dropped."""
        p.plan = p.in_force = emergency_stop(state, self.dt, self.settings.emergency_decel, path=p.plan)
        p.arriving = []

    def _planner_raised(self, p: _AgentProgress, t: float, exc: BaseException) -> None:
        """Count the exception; keep the first few with their tracebacks for the run record."""
        p.exceptions += 1
        if len(self.planner_errors) < RECORDED_PLANNER_ERRORS:
            self.planner_errors.append(PlannerError.of(exc, p.agent.id, t))

    def _planner_failed(self, p: _AgentProgress, state: State, t: float, reason: str, give_up: bool = False) -> None:
        """A cycle without a plan: brake in lane; after `planner_failure_limit` in a row (or at
        once, ``give_up``: the planner can plan no more) the agent is given up."""
        p.failures += 1
        p.failures_in_row += 1
        self.events.append(Event(t, p.agent.id, EventKind.PLANNER_NO_SOLUTION, state.x, state.y,
                                 f"{reason}; braking in lane"))
        if p.failures_in_row == 1:
            self._brake(p, state)
        p.plan_age = 0
        if give_up:
            self._finish(p, Outcome.PLANNER_FAILURE, state, f"the planner is unavailable: {reason}")
        elif p.failures_in_row >= self.settings.planner_failure_limit:
            self._finish(p, Outcome.PLANNER_FAILURE, state,
                         f"{p.failures_in_row} consecutive cycles without a plan; last: {reason}")

    def _finish(self, p: _AgentProgress, outcome: Outcome, state: State, detail: str = "",
                other: int | None = None) -> None:
        p.outcome = outcome
        self.events.append(Event(state.t, p.agent.id, outcome, state.x, state.y, detail, other))

    def _monitor(self, states: Mapping[int, State], t: float) -> None:
        """Collision, road departure, goal and deadline of every agent in the scene at ``t``."""
        progress_of = self.progress_of
        shapes = {aid: footprint(st, progress_of[aid].agent.vehicle.length, progress_of[aid].agent.vehicle.width)
                  for aid, st in states.items()}
        contacts = {}
        for ev in self.backend.events():       # a car that reached its goal has left the scenario
            gone = ev.other_id in progress_of and progress_of[ev.other_id].outcome == Outcome.GOAL_REACHED
            if ev.kind == Outcome.COLLISION and not gone:
                contacts.setdefault(ev.agent_id, ev.other_id)
            elif ev.kind == Outcome.DIVERGED and ev.agent_id in states and progress_of[ev.agent_id].active:   # taken out
                self._finish(progress_of[ev.agent_id], Outcome.DIVERGED, states[ev.agent_id], ev.detail)
        present = [aid for aid in states if progress_of[aid].outcome not in _LEFT_THE_WORLD]
        active = [aid for aid in present if progress_of[aid].active]
        obstacles = self._obstacles_near(active, states, t)
        obstacle_shapes = {oid: footprint(st, length, width) for oid, (st, length, width) in obstacles.items()}
        poses = {aid: states[aid] for aid in present} | {oid: st for oid, (st, _, _) in obstacles.items()}
        for aid in active:
            p = progress_of[aid]
            others = {oid: shapes[oid] for oid in present if oid != aid} | obstacle_shapes
            hit = _first_contact(shapes[aid], others)
            if aid in contacts and hit is None:
                hit = contacts[aid]
            excursion = self.road.excursion(shapes[aid])
            detail = "" if hit is None else collision_detail(states[aid], p.agent.vehicle.length, hit,
                                                             poses.get(hit), hit in progress_of)
            self._judge(p, states[aid], hit, excursion, detail)

    def _obstacles_near(self, present: list[int], states: Mapping[int, State],
                        t: float) -> dict[int, tuple[State, float, float]]:
        """The obstacles at ``t`` that may touch a present agent (`ObstacleReach.near`): every other
        one is farther, and needs no footprint."""
        reach = self.traffic.reach
        near = set()
        for aid in present:
            p, st = self.progress_of[aid], states[aid]
            near.update(reach.near(t, st.x, st.y, math.hypot(p.agent.vehicle.length, p.agent.vehicle.width) / 2,
                                   0.0).tolist())
        return self.traffic.poses(t, [int(i) for i in reach.ids[sorted(near)]])

    def _judge(self, p: _AgentProgress, state: State, hit: int | None, excursion: float, detail: str = "") -> None:
        if hit is not None:
            self._finish(p, Outcome.COLLISION, state, detail, hit)
        elif excursion > 0.0:
            self._finish(p, Outcome.OFF_ROAD, state, f"footprint {excursion:.3f} m beyond the road")
        elif p.goal.is_reached(state):
            self._finish(p, Outcome.GOAL_REACHED, state)
        elif state.t >= p.deadline - 1e-9:
            self._finish(p, Outcome.TIMEOUT, state, f"goal not reached by t = {p.deadline:.1f} s: "
                                              f"{p.goal.miss_reason(p.driven)}")

    def _record(self, wall_time: float, backend_notes: list[str], failure: str | None,
                controls: Mapping[int, ControlTrace]) -> History:
        dt = self.dt
        agents = []
        for aid, p in self.progress_of.items():
            driven = Trajectory.from_states(p.driven or [p.agent.initial_state], dt)
            trace = controls[aid].until(driven.t_end) if aid in controls else None
            agents.append(AgentHistory(
                id=aid, vehicle=p.agent.vehicle, outcome=p.outcome or Outcome.TIMEOUT, driven=driven,
                plans=tuple(p.plans),
                observed=Trajectory.from_states(p.observed, dt) if p.observed else None,
                attitudes=tuple(p.attitudes) if p.attitudes and len(p.attitudes) == len(p.driven) else (),
                standing=Trajectory.from_states(p.standing, dt) if p.standing else None,
                planning_call_s=tuple(p.call_times), plan_latency_s=tuple(p.latencies),
                planner_failures=p.failures, planner_exceptions=p.exceptions,
                controls=trace if trace is not None and len(trace) else None))
        return History(
            scenario_id=str(self.scenario.scenario_id), backend=self.backend.name, dt=dt, realism=self.realism,
            agents=tuple(agents), events=tuple(self.events), timings=self.timings, wall_time_s=wall_time,
            failure=failure, planner_errors=tuple(self.planner_errors), backend_notes=tuple(backend_notes),
            traffic={oid: Trajectory.from_states(states, dt) for oid, states in self.traffic_driven.items()})


def collision_detail(ego: State, ego_length: float, other_id: int, other: State | None, agent: bool) -> str:
    """A collision in a user's words: who, and whether the other road user ran into the ego from
    behind (its centre more than half the ego's length behind, heading the ego's way) - with
    replayed traffic, which does not brake for it, a collision the ego could not prevent - and
    what the ego was doing then (at rest, braking, driving)."""
    who = f"{'agent' if agent else 'recorded road user'} {other_id}"
    if other is None:
        return f"footprints overlap with {who}"
    c, s = math.cos(ego.yaw), math.sin(ego.yaw)
    ahead = (other.x - ego.x) * c + (other.y - ego.y) * s
    if ahead < -0.5 * ego_length and math.cos(other.yaw - ego.yaw) > 0.5:
        doing = ("at rest" if abs(ego.v) < 0.1 else
                 f"braking at {-ego.a:.1f} m/s^2 from {ego.v:.1f} m/s" if ego.a < -0.5 else f"driving at {ego.v:.1f} m/s")
        return (f"rear-ended by {who} ({other.v:.1f} m/s) while the ego was {doing}"
                + ("; replayed traffic does not brake for the ego" if not agent else ""))
    return f"ran into {who} at {ego.v:.1f} m/s (the other at {other.v:.1f} m/s)"


def _first_contact(shape, others) -> int | None:
    """The first of ``others`` that ``shape`` touches (None: clear)."""
    return next((oid for oid, other_shape in others.items() if shape.distance(other_shape) <= 0.0), None)


def _traffic_snapshot(progress_of: Mapping[int, _AgentProgress], states: Mapping[int, State],
                      dt: float) -> dict[int, TrafficParticipant]:
    """Each agent as the others see it: its latest plan (or where it stands, before it has one).

    Agents that reached their goal have left the scenario and are not shown.
    """
    snapshot = {}
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


def not_started(scenario: Scenario, backend: str, agents: list[Agent], errors: list[PlannerError],
                realism: Realism = Realism.IDEAL) -> History:
    """The history of a run that could not start because planners raised in their constructors:
    every agent a planner failure where it stands, the exceptions with their tracebacks."""
    dt = float(scenario.dt)
    failed = {e.agent_id: e for e in errors}
    histories, events = [], []
    for a in agents:
        st = a.initial_state
        detail = (f"planner raised {failed[a.id].exception} in its constructor: {failed[a.id].message}"
                  if a.id in failed else "another agent's planner could not be built")
        histories.append(AgentHistory(a.id, a.vehicle, Outcome.PLANNER_FAILURE, Trajectory.from_states([st], dt),
                                      planner_failures=1 if a.id in failed else 0,
                                      planner_exceptions=1 if a.id in failed else 0))
        events.append(Event(st.t, a.id, Outcome.PLANNER_FAILURE, st.x, st.y, detail))
    first = errors[0]
    return History(scenario_id=str(scenario.scenario_id), backend=backend, dt=dt, realism=realism,
                   agents=tuple(histories), events=tuple(events),
                   failure=f"the planner of agent {first.agent_id} raised {first.exception} in its constructor: "
                           f"{first.message}",
                   planner_errors=tuple(errors))
