"""The synchronous multi-agent co-simulation loop.

Every dt: observe each agent's state from the backend → every active agent plans (every
``replan_every`` steps, or at once if its plan failed or ran out) → the backend advances one dt
→ the loop checks goal, collision, road departure and timeout. The loop knows nothing about
any concrete backend or planner: it is handed a `Backend` and one `Planner` per agent.

Observation noise (a reality knob, off by default as in the ideal world): each time an agent
plans, it sees its own state with seeded Gaussian noise on position, heading and speed; the
backend, the record and the monitors keep the true state.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import Callable, Mapping

from commonroad.planning.planning_problem import PlanningProblem, PlanningProblemSet
from commonroad.scenario.scenario import Scenario
from commonroad.scenario.state import CustomState
import numpy as np
from pydantic import BaseModel, ConfigDict, Field

from simgap.cosim.record import AgentOutcome, Event, Outcome, Run
from simgap.cosim.traffic import DrivableArea, footprint, non_agent_traffic
from simgap.planning.protocol import Planner, TrafficParticipant, World
from simgap.sim.protocol import Agent, Backend, PhysicsDiverged
from simgap.trajectory import State, Trajectory, wrap_angle


class ObservationNoise(BaseModel):
    """Standard deviations of the noise on the state a planner observes (0: none)."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    position_m: float = Field(0.0, ge=0, le=5.0, description="on x and y, each [m]")
    yaw_deg: float = Field(0.0, ge=0, le=30.0, description="on the heading [deg]")
    speed_mps: float = Field(0.0, ge=0, le=5.0, description="on the speed [m/s]")

    @property
    def active(self) -> bool:
        return bool(self.position_m or self.yaw_deg or self.speed_mps)

    def observe(self, state: State, rng: np.random.Generator) -> State:
        if not self.active:
            return state
        dx, dy, dyaw, dv = rng.standard_normal(4)
        return state.replace(x=state.x + self.position_m * dx, y=state.y + self.position_m * dy,
                             yaw=wrap_angle(state.yaw + math.radians(self.yaw_deg) * dyaw),
                             v=max(0.0, state.v + self.speed_mps * dv))


class CosimSettings(BaseModel):
    """Settings of the loop (not of the planner or backend)."""

    model_config = ConfigDict(extra="forbid")

    replan_every: int = Field(1, ge=1, description="replan every N steps (the paper's Frenetix: 3)")
    max_time_s: float = Field(60.0, gt=0, description="hard limit on simulated time [s]")
    emergency_decel: float = Field(8.0, gt=0, description="deceleration of the emergency stop [m/s^2]")
    planner_failure_limit: int = Field(
        10, ge=1, description="consecutive failed planning cycles before an agent is given up")
    offroad_tolerance: float = Field(0.05, ge=0, description="footprint may exceed the road by [m]")
    observation_noise: ObservationNoise = Field(default_factory=ObservationNoise,
                                                description="noise on the state each planner observes")


@dataclass
class _AgentProgress:
    agent: Agent
    planner: Planner
    problem: PlanningProblem
    driven: list[State] = field(default_factory=list)
    plans: list[Trajectory] = field(default_factory=list)
    plan: Trajectory | None = None
    plan_age: int = 0
    outcome: Outcome | None = None
    time_to_goal: float | None = None
    failures_in_row: int = 0
    failures: int = 0
    min_distance: float = math.inf
    max_excursion: float = 0.0

    @property
    def active(self) -> bool:
        return self.outcome is None


def emergency_stop(state: State, dt: float, decel: float, horizon_s: float = 3.0) -> Trajectory:
    """Brake along the current heading to standstill (the loop's fallback when planning fails)."""
    n = max(2, int(round(horizon_s / dt)) + 1)
    states, x, y, v = [], state.x, state.y, state.v
    for k in range(n):
        a = -decel if v > 0 else 0.0
        states.append(State(state.t + k * dt, x, y, state.yaw, v, a, 0.0, state.steer))
        v_next = max(0.0, v - decel * dt)
        dist = 0.5 * (v + v_next) * dt
        x, y, v = x + dist * math.cos(state.yaw), y + dist * math.sin(state.yaw), v_next
    return Trajectory.from_states(states, dt)


def _goal_reached(problem: PlanningProblem, state: State, dt: float) -> bool:
    cr_state = CustomState(position=state.position, orientation=state.yaw, velocity=state.v,
                           time_step=int(round(state.t / dt)))
    return bool(problem.goal.is_reached(cr_state))


def _deadline(problem: PlanningProblem, dt: float, max_time: float) -> float:
    ends = [gs.time_step.end for gs in problem.goal.state_list
            if getattr(gs, "time_step", None) is not None and hasattr(gs.time_step, "end")]
    return min([max_time] + [e * dt for e in ends])


def simulate(
    scenario: Scenario,
    problems: PlanningProblemSet,
    backend: Backend,
    agents: list[Agent],
    planners: Mapping[int, Planner],
    settings: CosimSettings | None = None,
    progress: Callable[[float], None] | None = None,
    seed: int = 0,
) -> Run:
    """Run the co-simulation of ``agents`` (one per planning problem) in ``backend``; ``seed``
    seeds the observation noise."""
    settings = settings or CosimSettings()
    noise, rng = settings.observation_noise, np.random.default_rng(seed)
    dt = float(scenario.dt)
    wall_start = time.perf_counter()
    timings = {"planning": 0.0, "execution": 0.0, "monitoring": 0.0}
    events: list[Event] = []
    obstacles = non_agent_traffic(scenario)
    road = DrivableArea(scenario.lanelet_network, settings.offroad_tolerance)
    progress_of = {
        a.id: _AgentProgress(a, planners[a.id], problems.planning_problem_dict[a.id]) for a in agents
    }
    deadlines = {aid: _deadline(p.problem, dt, settings.max_time_s) for aid, p in progress_of.items()}
    horizon = max(deadlines.values())

    def finish(p: _AgentProgress, outcome: Outcome, state: State, detail: str = "",
               other: int | None = None) -> None:
        p.outcome = outcome
        if outcome == Outcome.GOAL_REACHED:
            p.time_to_goal = state.t
        events.append(Event(state.t, p.agent.id, outcome, state.x, state.y, detail, other))

    backend.load(scenario, agents)
    failure: str | None = None
    try:
        states = backend.reset()
        for aid, st in states.items():
            progress_of[aid].driven.append(st)
        step = 0
        while any(p.active for p in progress_of.values()):
            t = step * dt
            # 1. plan
            t0 = time.perf_counter()
            # every agent plans from the same snapshot: the others' plans of the previous step
            snapshot = _traffic_snapshot(progress_of, states, dt)
            for aid, p in progress_of.items():
                state = states[aid]
                if not p.active:
                    if p.plan is None or p.plan.t_end < t + dt:
                        p.plan = emergency_stop(state, dt, settings.emergency_decel)
                    continue
                due = (p.plan is None or p.plan_age >= settings.replan_every
                       or p.plan.t_end < t + dt or p.failures_in_row > 0)
                if not due:
                    p.plan_age += 1
                    continue
                world = World(scenario.lanelet_network, p.problem.goal, dt,
                              tuple(_traffic_for(aid, snapshot, obstacles)))
                reason = "no feasible collision-free sample; emergency stop"
                try:
                    plan = p.planner.plan(noise.observe(state, rng), t, world)
                except Exception as exc:  # a planner that crashes fails its cycle, not the run
                    plan, reason = None, f"planner raised {type(exc).__name__}: {exc}; emergency stop"
                if plan is None:
                    p.failures += 1
                    p.failures_in_row += 1
                    events.append(Event(t, aid, "planner_no_solution", state.x, state.y, reason))
                    if p.failures_in_row == 1:
                        p.plan = emergency_stop(state, dt, settings.emergency_decel)
                    p.plan_age = 0
                    if p.failures_in_row >= settings.planner_failure_limit or state.v < 0.1:
                        finish(p, Outcome.PLANNER_FAILURE, state,
                               f"{p.failures_in_row} consecutive cycles without a plan")
                else:
                    p.failures_in_row = 0
                    p.plan, p.plan_age = plan, 1
                    p.plans.append(plan)
            timings["planning"] += time.perf_counter() - t0
            # 2. execute
            t0 = time.perf_counter()
            states = backend.step({aid: p.plan for aid, p in progress_of.items()})
            timings["execution"] += time.perf_counter() - t0
            step += 1
            # 3. monitor
            t0 = time.perf_counter()
            for aid, st in states.items():
                if progress_of[aid].active:      # a finished agent's record ends where it finished
                    progress_of[aid].driven.append(st)
            _monitor(progress_of, states, obstacles, road, backend, dt, deadlines, finish)
            timings["monitoring"] += time.perf_counter() - t0
            if progress is not None:
                progress(min(1.0, step * dt / horizon))
    except PhysicsDiverged as exc:
        failure = f"physics diverged: {exc}"
        for p in progress_of.values():
            if p.active:
                last = p.driven[-1]
                finish(p, Outcome.DIVERGED, last, str(exc))
    finally:
        backend_timings = dict(backend.timings)
        backend_notes = list(backend.notes)
        backend.close()
    timings.update(backend_timings)

    outcomes = []
    for aid, p in progress_of.items():
        driven = Trajectory.from_states(p.driven, dt)
        outcomes.append(AgentOutcome(
            id=aid, vehicle=p.agent.vehicle.name, outcome=p.outcome or Outcome.TIMEOUT,
            time_to_goal_s=None if p.time_to_goal is None else round(p.time_to_goal, 6),
            distance_m=round(driven.path_length(), 3),
            min_distance_to_traffic_m=None if math.isinf(p.min_distance) else round(p.min_distance, 3),
            max_road_excursion_m=round(p.max_excursion, 3), planner_failures=p.failures))
    return Run(
        scenario_id=str(scenario.scenario_id), backend=backend.name, dt=dt, agents=outcomes,
        driven={aid: Trajectory.from_states(p.driven, dt) for aid, p in progress_of.items()},
        plans={aid: p.plans for aid, p in progress_of.items()},
        events=events, timings=timings, wall_time_s=time.perf_counter() - wall_start,
        settings={"cosim": settings.model_dump()} | ({"backend_notes": backend_notes} if backend_notes else {}),
        failure=failure,
    )


def _traffic_snapshot(progress_of: Mapping[int, _AgentProgress], states: Mapping[int, State],
                      dt: float) -> dict[int, TrafficParticipant]:
    """Each agent as the others see it: its latest plan (or where it stands, before it has one).

    Agents that reached their goal have left the scenario and are not shown.
    """
    snapshot = {}
    for aid, p in progress_of.items():
        if p.outcome == Outcome.GOAL_REACHED:
            continue
        prediction = p.plan if p.plan is not None else Trajectory.from_states([states[aid]], dt)
        snapshot[aid] = TrafficParticipant(aid, p.agent.vehicle.length, p.agent.vehicle.width, prediction)
    return snapshot


def _traffic_for(aid: int, snapshot: Mapping[int, TrafficParticipant],
                 obstacles: list[TrafficParticipant]) -> list[TrafficParticipant]:
    """What agent ``aid`` sees: the other agents' latest plans and the obstacles' recordings."""
    return [tp for oid, tp in snapshot.items() if oid != aid] + list(obstacles)


def _monitor(progress_of, states, obstacles, road, backend, dt, deadlines, finish) -> None:
    shapes = {aid: footprint(st, progress_of[aid].agent.vehicle.length, progress_of[aid].agent.vehicle.width)
              for aid, st in states.items()}
    present = [aid for aid, p in progress_of.items() if p.outcome != Outcome.GOAL_REACHED]
    t = next(iter(states.values())).t
    obstacle_shapes = {o.id: footprint(o.prediction.at(t), o.length, o.width) for o in obstacles
                       if o.prediction.t[0] - 1e-9 <= t <= o.prediction.t_end + 1e-9}
    contacts = {}
    for ev in backend.events():
        if ev.kind == "collision":
            contacts.setdefault(ev.agent_id, ev.other_id)
    for aid in present:
        p = progress_of[aid]
        state, shape = states[aid], shapes[aid]
        others = {oid: shapes[oid] for oid in present if oid != aid}
        others.update(obstacle_shapes)
        hit = None
        for oid, other_shape in others.items():
            dist = shape.distance(other_shape)
            p.min_distance = min(p.min_distance, dist)
            if dist <= 0.0 and hit is None:
                hit = oid
        if aid in contacts and hit is None:
            hit = contacts[aid]
        excursion = road.excursion(shape) if not road.contains(shape) else 0.0
        p.max_excursion = max(p.max_excursion, excursion)
        if not p.active:
            continue
        if hit is not None:
            finish(p, Outcome.COLLISION, state, "footprints overlap", hit)
        elif excursion > 0.0:
            finish(p, Outcome.OFF_ROAD, state, f"footprint {excursion:.2f} m beyond the road")
        elif _goal_reached(p.problem, state, dt):
            finish(p, Outcome.GOAL_REACHED, state)
        elif state.t >= deadlines[aid] - 1e-9:
            finish(p, Outcome.TIMEOUT, state, f"goal not reached by t = {deadlines[aid]:.1f} s")
