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
import time
from collections.abc import Callable, Mapping, Sequence
from typing import ClassVar

import numpy as np
from commonroad.planning.planning_problem import PlanningProblemSet
from commonroad.scenario.scenario import Scenario
from pydantic import BaseModel, ConfigDict, Field

from simgap.cosim.agent_progress import AgentProgress
from simgap.cosim.history import History, Outcome
from simgap.cosim.history_building import HistoryBuilder
from simgap.cosim.interruptions import WallClockExceeded, interruptions
from simgap.cosim.judging import Judge
from simgap.cosim.plan_delivery import MEASURED, Latency, PlanDelivery, traffic_snapshot
from simgap.cosim.sensing import Localisation, SensingProfile, SensingSettings, localisation_accuracy
from simgap.cosim.traffic import Traffic, TrafficMode, make_traffic
from simgap.planning.protocol import Planner, as_planner
from simgap.scenario.goal import Goal
from simgap.scenario.obstacles import RecordedObstacle
from simgap.scenario.relief import Surface
from simgap.scenario.road_frame import DrivableArea
from simgap.sim.assumptions import Assumption, Restorations
from simgap.sim.protocol import Agent, Backend, PhysicsDiverged
from simgap.trajectory import State

DEFAULT_TIME_LIMIT_S = 60.0
MAX_SIMULATED_TIME_S = 600.0     # no run simulates longer, whatever its goal's time window


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
    road: DrivableArea | None = None,
    obstacles: Sequence[RecordedObstacle] | None = None,
) -> History:
    """Run the co-simulation of ``agents`` (one per planning problem) in ``backend`` on the road's
    ``relief`` (None: flat); ``seed`` seeds the localisations' errors. A run still going after
    ``wall_time_limit_s`` (even in a planning call that does not return) is stopped and recorded as
    failed. ``replayed_latencies`` (agent id -> the latency of each of its plans, in order, as a
    record keeps them) replace the ``measured`` latencies, so a run made on a loaded machine
    replays exactly on an idle one. ``road``: the scenario's drivable area widened by the settings'
    ``offroad_tolerance``, and ``obstacles`` its `recorded_obstacles`, when the caller has them
    (made here otherwise)."""
    settings = settings or CosimSettings()
    if road is None:
        road = DrivableArea(scenario.lanelet_network, settings.offroad_tolerance)
    return _CoSimulation(scenario, problems, backend, agents, planners, settings, seed,
                         wall_time_limit_s, relief, replayed_latencies or {}, road, obstacles).run(progress)


class _CoSimulation:
    """One run of the loop: it orchestrates the run's parts — the plans' delivery to the cars
    (`PlanDelivery`), the judge (`Judge`), the history (`HistoryBuilder`) — around the backend and
    the traffic, and keeps the timings."""

    def __init__(self, scenario: Scenario, problems: PlanningProblemSet, backend: Backend, agents: list[Agent],
                 planners: Mapping[int, Planner], settings: CosimSettings, seed: int, wall_time_limit_s: float | None,
                 relief: Surface | None, replayed_latencies: Mapping[int, tuple[float, ...]], road: DrivableArea,
                 obstacles: Sequence[RecordedObstacle] | None):
        self.scenario, self.backend, self.settings, self.relief = scenario, backend, settings, relief
        self.realism = backend.realism
        self.wall_time_limit_s = wall_time_limit_s
        self.dt = float(scenario.dt)
        self.timings = {"planning": 0.0, "execution": 0.0, "monitoring": 0.0}
        self.traffic: Traffic = make_traffic(scenario, settings.traffic, obstacles)
        self.progress_of: dict[int, AgentProgress] = {}
        accuracy = localisation_accuracy(settings.sensing, self.realism)
        for a in agents:
            problem = problems.planning_problem_dict[a.id]
            goal = Goal.of(problem.goal, self.dt)
            localisation = Localisation(accuracy, np.random.default_rng((seed, a.id)))
            self.progress_of[a.id] = AgentProgress(a, as_planner(planners[a.id]), problem, goal, deadline(goal, settings),
                                                   localisation)
        self.horizon = max(p.deadline for p in self.progress_of.values())
        self.agents = agents
        self.judge = Judge(self.progress_of, backend, self.traffic, road)
        self.delivery = PlanDelivery(scenario.lanelet_network, self.dt, self.realism, settings.latency,
                                     settings.replan_every, settings.emergency_decel, settings.planner_failure_limit,
                                     self.traffic, self.judge, replayed_latencies)
        self.history = HistoryBuilder(self.progress_of, backend, self.traffic, self.dt)

    def run(self, progress: Callable[[float], None] | None) -> History:
        wall_start = time.perf_counter()
        self.backend.load(self._scenario_for_backend(), self.agents, self.relief)
        failure = None
        limit = self.wall_time_limit_s
        step = 0
        try:
            with interruptions(limit):
                states = self.backend.reset()
                self.history.drove(states)
                self.history.traffic_at(0.0)
                while any(p.active for p in self.progress_of.values()):
                    if limit is not None and time.perf_counter() - wall_start > limit:
                        raise WallClockExceeded(limit)
                    states = self._step(step, states)
                    step += 1
                    if progress is not None:
                        progress(min(1.0, step * self.dt / self.horizon))
        except WallClockExceeded as exc:
            planning = self.delivery.planning_agent
            where = "" if planning is None else f" in agent {planning}'s planning call"
            failure = f"timeout: {exc}{where} at t = {step * self.dt:.1f} s"
            self._finish_active(Outcome.TIMEOUT, failure)
        except PhysicsDiverged as exc:
            failure = f"physics diverged: {exc}"
            self._finish_active(Outcome.DIVERGED, str(exc))
        else:
            diverged = [e for e in self.judge.events if e.kind == Outcome.DIVERGED]
            if diverged and len(diverged) == len(self.progress_of):   # no agent has a verdict of the scenario
                failure = f"physics diverged: agent {diverged[0].agent_id}: {diverged[0].detail}"
        finally:
            backend_timings = dict(self.backend.timings)
            backend_notes = list(self.backend.notes)
            controls = dict(self.backend.control_traces() or {})
            self.backend.close()
        self.timings.update(backend_timings)
        return self.history.build(self.scenario, self.realism, self.judge.events, self.timings,
                                  time.perf_counter() - wall_start, failure, self.delivery.planner_errors,
                                  backend_notes, controls)

    def _finish_active(self, outcome: Outcome, detail: str) -> None:
        """The run stopped: every agent still driving ends with ``outcome`` where it was last seen."""
        for p in self.progress_of.values():
            if p.active:
                self.judge.finish(p, outcome, p.last_state, detail)

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
        progress_of, delivery, history = self.progress_of, self.delivery, self.history
        clock = time.perf_counter()
        snapshot = traffic_snapshot(progress_of, states, self.dt)   # every agent plans from it
        for aid, state in states.items():          # agents that have entered the world
            delivery.plan(progress_of[aid], state, t, snapshot)
        self.timings["planning"] += time.perf_counter() - clock
        clock = time.perf_counter()
        states = self.backend.step({aid: plan for aid, p in progress_of.items()      # an agent without a plan yet: none
                                    if (plan := delivery.in_force(p, t)) is not None})
        self.timings["execution"] += time.perf_counter() - clock
        clock = time.perf_counter()
        self.traffic.advance(t, self.dt, snapshot)
        history.drove({aid: st for aid, st in states.items() if progress_of[aid].active})
        history.stood(states)
        history.traffic_at(t + self.dt)
        self.judge.monitor(states, t + self.dt)
        self.timings["monitoring"] += time.perf_counter() - clock
        return states
