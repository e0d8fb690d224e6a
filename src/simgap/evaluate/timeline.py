"""Why a run parted from its plan, against time: the series a run's timeline draws, each from
the record alone (`simgap.cosim.history.AgentHistory`) — no rerun.

* tracking: where the car was against where its plan in force said (lateral, in the route's frame,
  and heading), at every driven step;
* commands: the steering the controller asked for against the road wheels' angle, and the
  acceleration asked for against the one achieved, per control tick (a physical world's
  `ControlTrace`; none in the ideal world);
* planning: each plan's latency (how long after its planning time it reached the car) and each
  planning call's wall time;
* sensing: how far the state the planner observed was from the true one, per planning call.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from simgap.cosim.history import AgentHistory
from simgap.evaluate.errors import frenet_tracking_errors, tracking_errors
from simgap.scenario.road_frame import PathFrame
from simgap.trajectory import ControlTrace

EMPTY = np.array([])


@dataclass(frozen=True)
class Series:
    """Values over time (``t`` [s])."""

    t: np.ndarray
    values: np.ndarray

    def __len__(self) -> int:
        return len(self.t)


@dataclass(frozen=True)
class AgentTimeline:
    """One agent's run against time (empty series where the record holds none)."""

    lateral_error: Series           # driven minus promised, in the route frame [m] (> 0: left of the plan)
    heading_error: Series           # driven minus promised yaw [rad]
    controls: ControlTrace | None   # per control tick (None: plans executed exactly)
    plan_latency: Series            # per plan, at its planning time [s]
    planning_call: Series           # per planning call, its wall time [s]
    sensing_error: Series           # per planning call, |observed - true| position [m]


def agent_timeline(agent: AgentHistory, frame: PathFrame | None) -> AgentTimeline:
    """The series of ``agent``'s timeline (``frame``: its route's centre line; None: no lateral
    error)."""
    driven, plans = agent.driven, list(agent.plans)
    tracking = tracking_errors(driven, plans)
    lateral = Series(EMPTY, EMPTY)
    if frame is not None:
        frenet = frenet_tracking_errors(driven, plans, frame)
        lateral = Series(frenet.t, frenet.lateral)
    starts = np.array([float(p.t[0]) for p in agent.plans])
    latency = Series(starts, np.array(agent.plan_latency_s)) if len(starts) == len(agent.plan_latency_s) \
        else Series(EMPTY, EMPTY)
    observed = agent.observed
    call, sensing = Series(EMPTY, EMPTY), Series(EMPTY, EMPTY)
    if observed is not None and len(observed):
        if len(agent.planning_call_s) == len(observed):
            call = Series(observed.t, np.array(agent.planning_call_s))
        true = [driven.at(float(t)) for t in observed.t]
        sensing = Series(observed.t, np.hypot(observed.x - np.array([s.x for s in true]),
                                              observed.y - np.array([s.y for s in true])))
    return AgentTimeline(lateral, Series(tracking.t, tracking.orientation), agent.controls, latency, call, sensing)
