"""Stages 4 and 5 of a cycle of the Frenet planner (`simgap.planning.frenet`): in the core's cost
order, a few samples at a time, **check** them (the vehicle's limits from exact values, traffic, the
road and the lateral-acceleration bound: `frenet_checks`) and **choose** (`plan_choice`, pure); when
none passes, a **second look** at the same samples from the road's edge or with traffic that runs
into the ego from behind."""

from __future__ import annotations

import numpy as np

from simgap.planning.collision import RoadBand, TrafficPrediction
from simgap.planning.cost_order import CostOrder
from simgap.planning.frenet_checks import PlanChecks, RoadLeeway, within_limits
from simgap.planning.frenet_cycle import PlanningCycle, Start
from simgap.planning.frenet_frame import CartesianBatch, FrenetFrame
from simgap.planning.plan_choice import (
    CheckedChunk,
    Choice,
    ChoiceRules,
    ChoiceState,
    final,
    first_passing,
    latest_met,
    only_reaching,
    searching,
    step,
)
from simgap.planning.protocol import PlanOutcome
from simgap.planning.settings import FrenetSettings
from simgap.scenario.goal import Goal

# plans are checked in cost order in chunks growing from FIRST_CHUNK to MAX_CHUNK
FIRST_CHUNK, MAX_CHUNK = 4, 64


class PlanSearch:
    """Checks a cycle's samples in cost order and chooses the plan (None: none will do)."""

    def __init__(self, vehicle, settings: FrenetSettings, frame: FrenetFrame, checks: PlanChecks):
        self.vehicle, self.settings, self.frame, self.checks = vehicle, settings, frame, checks

    # -- stage 4: check ------------------------------------------------------------------------
    def check(self, batch: CartesianBatch, traffic: TrafficPrediction, leeway: RoadLeeway, start: Start,
              cycle: PlanningCycle) -> tuple[np.ndarray, np.ndarray]:
        """Per plan of ``batch``: passes the limit, traffic and road checks?; within the lateral-
        acceleration bound? Counts the rejections in ``cycle``."""
        feasible_ok = within_limits(batch, self.vehicle.limits, self.vehicle.wheelbase)
        verdicts = self.checks.check(batch, traffic, leeway, start.dt, start.lateral_bound)
        hit, on_road = verdicts.hit, verdicts.on_road
        cycle.checked += len(feasible_ok)
        cycle.rejected_infeasible += int((~feasible_ok).sum())
        cycle.rejected_traffic += int((feasible_ok & hit).sum())
        cycle.rejected_road += int((feasible_ok & ~hit & ~on_road).sum())
        return feasible_ok & ~hit & on_road, verdicts.lateral_ok

    def _checked_chunk(self, batch: CartesianBatch, taken: int, reaching: bool, traffic: TrafficPrediction,
                       leeway: RoadLeeway, start: Start, cycle: PlanningCycle, goal: Goal) -> CheckedChunk:
        """``batch`` (of ``taken`` samples; all of it reaching the goal when ``reaching``) checked,
        as the choice sees it."""
        passing, lateral_ok = self.check(batch, traffic, leeway, start, cycle)
        within_bound = lateral_ok | (not self.settings.speed.enforce_lateral_acceleration)
        cycle.rejected_lateral_acceleration += int((passing & ~within_bound).sum())
        if reaching:
            reaches = np.ones(len(passing), dtype=bool)
        else:
            reaches = np.zeros(len(passing), dtype=bool)
            candidates = np.flatnonzero(passing & within_bound)
            if start.goal_in_reach and len(candidates):       # only these are looked at
                reaches[candidates] = self.reaches_goal(batch, candidates, start, goal)
        return CheckedChunk(taken, passing, within_bound, batch.v[:, -1], reaches, cycle.rejected_traffic)

    # -- stage 5: choose -----------------------------------------------------------------------
    def choose(self, order: CostOrder, start: Start, traffic: TrafficPrediction, cycle: PlanningCycle,
               goal: Goal) -> CartesianBatch | None:
        """In cost order, a few at a time: check the samples and choose (`plan_choice`): the
        first within the limits, clear of traffic and on the road (and within the lateral-
        acceleration bound if any is), unless traffic blocks it or the goal is in reach. With
        none, a `second_look`."""
        leeway = self.checks.leeway(start.x_rear, start.y_rear, start.yaw_local, start.dt)
        rules = ChoiceRules(start.desired, self.settings.speed.blocked_speed_share, start.may_overtake,
                            start.goal_in_reach)
        state = ChoiceState()
        batches: list[CartesianBatch | None] = []        # per chunk (None: none of it checked)
        chunk = FIRST_CHUNK
        while searching(state):
            samples = order.take(chunk)
            if not samples:
                break
            chunk = min(chunk * 2, MAX_CHUNK)
            batch = self.frame.cartesian(samples, start.low_velocity, start.yaw_local)
            reaching = only_reaching(state)      # only a plan that reaches the goal would do now
            if reaching:
                rows = np.flatnonzero(self.reaches_goal(batch, np.arange(len(samples)), start, goal))
                if not len(rows):
                    batches.append(None)
                    state = step(state, CheckedChunk.of([], [], [], taken=len(samples)), rules)
                    continue
                batch = rows_of(batch, rows)
            batches.append(batch)
            state = step(state, self._checked_chunk(batch, len(samples), reaching, traffic, leeway, start, cycle, goal),
                         rules)
        choice: Choice = final(state)
        if choice.pick is not None:
            cycle.choice = choice.kind
            picked = batches[choice.pick.chunk]
            assert picked is not None, "a pick is from a checked chunk"
            return row_of(picked, choice.pick.row)
        return self.second_look([b for b in batches if b is not None], start, traffic, leeway, cycle)

    def second_look(self, checked: list[CartesianBatch], start: Start, traffic: TrafficPrediction,
                    leeway: RoadLeeway, cycle: PlanningCycle) -> CartesianBatch | None:
        """When no plan passes: from a vehicle at the road's edge (within `ROAD_EDGE_M`) whose
        plans all leave the road, the cheapest that gets back onto the safe cells within the
        recovery time (`first_passing`, the rejections of this second look not counted); when
        traffic rejected plans, the one that traffic meets latest of those whose every encounter
        is another road user running into the ego from behind (`latest_met`), ``cycle.outcome``
        saying so. None: every plan runs into someone (the planner fails, and says so)."""
        if leeway.steps == 0 and cycle.rejected_road and self.checks.at_road_edge(start.x_rear, start.y_rear,
                                                                                  start.yaw_local):
            recovery = RoadLeeway(self.checks.recovery_steps(start.dt), RoadBand.ROAD)
            pick = first_passing(self.check(batch, traffic, recovery, start, PlanningCycle())[0] for batch in checked)
            if pick is not None:
                return row_of(checked[pick.chunk], pick.row)
        if cycle.rejected_traffic:
            found = latest_met(self.checks.encounters(batch, leeway, start.dt, start.lateral_bound, traffic)
                               for batch in checked)
            if found is not None:
                cycle.outcome = PlanOutcome.STRUCK_FROM_BEHIND
                return row_of(checked[found[0].chunk], found[0].row)
        return None

    def reaches_goal(self, batch: CartesianBatch, rows: np.ndarray, start: Start, goal: Goal) -> np.ndarray:
        """Per plan ``rows`` of ``batch``: does it reach the goal (every window of a goal state,
        judged at the vehicle's centre) at one of its states?"""
        yaw = batch.yaw[rows]
        x, y = self.frame.xy_to_world(*self.vehicle.centre_of(batch.x[rows], batch.y[rows], yaw))
        t = np.broadcast_to(start.t + start.dt * np.arange(yaw.shape[1]), yaw.shape)
        return goal.reached_at(t, x, y, yaw + self.frame.rotation, batch.v[rows]).any(axis=1)


def row_of(batch: CartesianBatch, i: int) -> CartesianBatch:
    """Plan ``i`` of ``batch``, as a batch of one."""
    return CartesianBatch(*(getattr(batch, f)[i:i + 1] for f in CartesianBatch.__dataclass_fields__))


def rows_of(batch: CartesianBatch, rows: np.ndarray) -> CartesianBatch:
    """The plans ``rows`` of ``batch``."""
    return CartesianBatch(*(getattr(batch, f)[rows] for f in CartesianBatch.__dataclass_fields__))
