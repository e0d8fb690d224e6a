"""The loop's judge: after every step, each agent still driving is checked for a collision, a road
departure, its goal and its deadline, in that order; the first that holds is its outcome. The judge
keeps the run's events, and words a collision for a reader (`collision_detail`)."""

from __future__ import annotations

import math
from collections.abc import Mapping

from simgap.cosim.agent_progress import LEFT_THE_WORLD, AgentProgress
from simgap.cosim.history import Event, Outcome
from simgap.cosim.traffic import Traffic
from simgap.scenario.road_frame import DrivableArea, footprint
from simgap.sim.protocol import Backend
from simgap.trajectory import State


class Judge:
    """Decides when an agent is done and why, and keeps the events of the run."""

    def __init__(self, progress_of: Mapping[int, AgentProgress], backend: Backend, traffic: Traffic,
                 road: DrivableArea):
        self.progress_of, self.backend, self.traffic, self.road = progress_of, backend, traffic, road
        self.events: list[Event] = []

    def finish(self, p: AgentProgress, outcome: Outcome, state: State, detail: str = "",
               other: int | None = None) -> None:
        """``p``'s run ends with ``outcome`` at ``state``."""
        p.outcome = outcome
        self.events.append(Event(state.t, p.agent.id, outcome, state.x, state.y, detail, other))

    def monitor(self, states: Mapping[int, State], t: float) -> None:
        """Collision, road departure, goal and deadline of every agent in the scene at ``t``."""
        progress_of = self.progress_of
        shapes = {aid: footprint(st, progress_of[aid].agent.vehicle.length, progress_of[aid].agent.vehicle.width)
                  for aid, st in states.items()}
        contacts: dict[int, int | None] = {}
        for ev in self.backend.events():       # a car that reached its goal has left the scenario
            gone = ev.other_id is not None and ev.other_id in progress_of \
                and progress_of[ev.other_id].outcome == Outcome.GOAL_REACHED
            if ev.kind == Outcome.COLLISION and not gone:
                contacts.setdefault(ev.agent_id, ev.other_id)
            elif ev.kind == Outcome.DIVERGED and ev.agent_id in states and progress_of[ev.agent_id].active:   # taken out
                self.finish(progress_of[ev.agent_id], Outcome.DIVERGED, states[ev.agent_id], ev.detail)
        present = [aid for aid in states if progress_of[aid].outcome not in LEFT_THE_WORLD]
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
        near: set[int] = set()
        for aid in present:
            p, st = self.progress_of[aid], states[aid]
            near.update(reach.near(t, st.x, st.y, math.hypot(p.agent.vehicle.length, p.agent.vehicle.width) / 2,
                                   0.0).tolist())
        return self.traffic.poses(t, [int(i) for i in reach.ids[sorted(near)]])

    def _judge(self, p: AgentProgress, state: State, hit: int | None, excursion: float, detail: str = "") -> None:
        if hit is not None:
            self.finish(p, Outcome.COLLISION, state, detail, hit)
        elif excursion > 0.0:
            self.finish(p, Outcome.OFF_ROAD, state, f"footprint {excursion:.3f} m beyond the road")
        elif p.goal.is_reached(state):
            self.finish(p, Outcome.GOAL_REACHED, state)
        elif state.t >= p.deadline - 1e-9:
            self.finish(p, Outcome.TIMEOUT, state, f"goal not reached by t = {p.deadline:.1f} s: "
                                             f"{p.goal.miss_reason(p.driven)}")


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
