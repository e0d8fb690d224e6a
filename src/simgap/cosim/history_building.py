"""The `History` of a run, built as it goes: after every step the agents' driven states and
attitudes, where finished cars stand, and where the traffic the loop drives itself is; at the end
the frozen `History` (`HistoryBuilder.build`), or that of a run that could not start (`not_started`)."""

from __future__ import annotations

from collections.abc import Mapping

from commonroad.scenario.scenario import Scenario

from simgap.cosim.agent_progress import LEFT_THE_WORLD, AgentProgress
from simgap.cosim.history import AgentHistory, Event, History, Outcome, PlannerError
from simgap.cosim.traffic import Traffic
from simgap.sim.protocol import Agent, Backend, Realism
from simgap.trajectory import ControlTrace, State, Trajectory


class HistoryBuilder:
    """Records what each agent and the loop's own traffic did, step by step, and builds the `History`."""

    def __init__(self, progress_of: Mapping[int, AgentProgress], backend: Backend, traffic: Traffic, dt: float):
        self.progress_of, self.backend, self.traffic, self.dt = progress_of, backend, traffic, dt
        self.traffic_driven: dict[int, list[State]] = {}     # the IDM traffic's states, by obstacle

    def drove(self, states: Mapping[int, State]) -> None:
        """Record the agents' ``states`` (a finished agent's record ends where it finished) and
        their attitudes."""
        attitudes = self.backend.attitudes()
        for aid, st in states.items():
            self.progress_of[aid].driven.append(st)
            if aid in attitudes:
                self.progress_of[aid].attitudes.append(attitudes[aid])

    def stood(self, states: Mapping[int, State]) -> None:
        """Record where the finished agents still in the world stand (their cars stay there)."""
        for aid, st in states.items():
            p = self.progress_of[aid]
            if not p.active and p.outcome not in LEFT_THE_WORLD:
                p.standing.append(st)

    def traffic_at(self, t: float) -> None:
        """Record where the road users the loop drives itself (IDM traffic) are at ``t``."""
        if self.traffic.driven_ids:
            for oid, (state, _, _) in self.traffic.poses(t, self.traffic.driven_ids).items():
                self.traffic_driven.setdefault(oid, []).append(state)

    def build(self, scenario: Scenario, realism: Realism, events: list[Event], timings: dict[str, float],
              wall_time: float, failure: str | None, planner_errors: list[PlannerError], backend_notes: list[str],
              controls: Mapping[int, ControlTrace]) -> History:
        """The run's frozen `History`."""
        dt = self.dt
        agents: list[AgentHistory] = []
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
            scenario_id=str(scenario.scenario_id), backend=self.backend.name, dt=dt, realism=realism,
            agents=tuple(agents), events=tuple(events), timings=timings, wall_time_s=wall_time,
            failure=failure, planner_errors=tuple(planner_errors), backend_notes=tuple(backend_notes),
            traffic={oid: Trajectory.from_states(states, dt) for oid, states in self.traffic_driven.items()})


def not_started(scenario: Scenario, backend: str, agents: list[Agent], errors: list[PlannerError],
                realism: Realism = Realism.IDEAL) -> History:
    """The history of a run that could not start because planners raised in their constructors:
    every agent a planner failure where it stands, the exceptions with their tracebacks."""
    dt = float(scenario.dt)
    failed = {e.agent_id: e for e in errors}
    histories: list[AgentHistory] = []
    events: list[Event] = []
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
