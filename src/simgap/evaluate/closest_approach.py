"""How close each agent came to the other road users, and how far its footprint reached beyond
the road, over the states the loop's monitors saw.

The loop only decides (a contact ends a run, a footprint beyond the tolerance ends it off road);
these are the measures. They are taken at the instants the monitors look: every state after the
first, including those of an agent that stands in the world after its outcome while others drive
on, against every other agent in the world then and every obstacle where the traffic had it (as
recorded, or where the loop's IDM drove it: `History.traffic`).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

from commonroad.scenario.scenario import Scenario

from simgap.cosim.history import History, Outcome
from simgap.cosim.traffic import ReplayedTraffic
from simgap.scenario.obstacles import RecordedObstacle
from simgap.scenario.road_frame import DrivableArea, footprint
from simgap.trajectory import State

_LEFT_THE_WORLD = (Outcome.GOAL_REACHED, Outcome.DIVERGED)


@dataclass(frozen=True)
class Approach:
    """One agent's closest approach to any other road user (None: there was none) and its largest
    road excursion [m]."""

    min_distance_m: float | None
    max_road_excursion_m: float


def _step(t: float, dt: float) -> int:
    return int(round(t / dt))


def closest_approaches(history: History, scenario: Scenario, offroad_tolerance_m: float,
                       road: DrivableArea | None = None,
                       obstacles: Sequence[RecordedObstacle] | None = None) -> dict[int, Approach]:
    """Every agent's `Approach` over the monitored states of ``history`` on ``scenario`` (the
    scenario the loop ran: recorded egos left out); ``road``: its drivable area widened by
    ``offroad_tolerance_m``, and ``obstacles`` its `recorded_obstacles`, when the caller has them
    (made here otherwise)."""
    dt = history.dt
    if road is None:
        road = DrivableArea(scenario.lanelet_network, offroad_tolerance_m)
    replayed = ReplayedTraffic(scenario, obstacles)
    driven_traffic = {oid: {_step(t, dt): traj[k] for k, t in enumerate(traj.t)}
                      for oid, traj in history.traffic.items()}
    sizes = {o.id: (o.length, o.width) for o in replayed.participants()}
    reach = replayed.reach

    # the monitored states, by step: agent -> state (a state from reset, at step 0, is not monitored)
    at_step: dict[int, dict[int, State]] = {}
    for a in history.agents:
        for k, traj in enumerate((a.driven, a.standing)):
            if traj is None:
                continue
            for i, t in enumerate(traj.t):
                if k == 0 and i == 0 and _step(t, dt) == 0:
                    continue
                at_step.setdefault(_step(t, dt), {})[a.id] = traj[i]
    left_after = {a.id: _step(a.driven.t[-1], dt) for a in history.agents if a.outcome in _LEFT_THE_WORLD}
    vehicles = history.vehicles
    closest = {a.id: math.inf for a in history.agents}
    excursion = {a.id: 0.0 for a in history.agents}
    for step in sorted(at_step):
        states = {aid: st for aid, st in at_step[step].items() if aid not in left_after or step <= left_after[aid]}
        t = (step - 1) * dt + dt                         # the loop's own arithmetic for the monitor's time
        shapes = {aid: footprint(st, vehicles[aid].length, vehicles[aid].width) for aid, st in states.items()}
        near: set[int] = set()
        for aid, st in states.items():
            radius = math.hypot(vehicles[aid].length, vehicles[aid].width) / 2
            near.update(int(i) for i in reach.ids[reach.near(t, st.x, st.y, radius, closest[aid])]
                        if int(i) not in driven_traffic)
        poses = replayed.poses(t, sorted(near)) if near else {}
        around = {oid: footprint(st, length, width) for oid, (st, length, width) in poses.items()}
        for oid, by_step in driven_traffic.items():
            if step in by_step:
                around[oid] = footprint(by_step[step], *sizes[oid])
        for aid, shape in shapes.items():
            excursion[aid] = max(excursion[aid], road.excursion(shape))
            for oid, other in shapes.items():
                if oid != aid:
                    closest[aid] = min(closest[aid], shape.distance(other))
            for other in around.values():
                closest[aid] = min(closest[aid], shape.distance(other))
    return {aid: Approach(None if math.isinf(closest[aid]) else closest[aid], excursion[aid]) for aid in closest}
