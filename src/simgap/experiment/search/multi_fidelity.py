"""The ``multi_fidelity`` strategy: the cheap fidelities screen, the expensive one confirms (see
`simgap.experiment.search.strategies` for the whole story). Its parts: the promotion threshold, which
learns from what promotions found (`PromotionThreshold`); the map of confirmed failures and open
proposals, which says how new a candidate is and where to look (`FailureMap`); and the allocation
of proposals to moves and parents by Thompson sampling on what they found per CPU second
(`MoveAllocation`)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from simgap.experiment.run_row import RunRow
from simgap.experiment.search.space import Candidate, SearchSpace, Strategy, uniform_candidate
from simgap.experiment.search.spec import DimensionKind

EXPLORE_EVERY = 10          # one candidate in this many is promoted whatever its risk
# --- multi_fidelity's numbers ---------------------------------------------------------------
SCREEN_FAILURE_RISK = 2.0     # the risk of a candidate that already fails in the screen (above any other)
MOVES = ("global", "knobs", "scenario")
COST_PRIOR_S = 20.0           # a move's yield starts as the pooled yield, worth this many CPU seconds
PROPOSAL_TRIES = 30           # neighbours drawn before a move gives up and proposes a global candidate
NEIGHBOUR_DISTANCE = (1.0, 1.5)   # a neighbour's distance from its parent, in distinct radii: new, yet close
MIN_TRY_COST_S = 0.1          # a try around a parent costs at least this (no job is free) [s]
SKIP_SCREEN_AT = 0.5          # a neighbourhood whose neighbours fail this often goes straight to high fidelity
# The promotion threshold (a risk) starts where the screen's grip use reaches the road's limit or the
# objective reaches risk_scale, and then is the risk that best separates the promoted candidates that
# failed in high fidelity from those that passed:
START_THRESHOLD = 1.0
FIT_MIN = 4                   # ... once this many verdicts, of both kinds, are in
LOWEST_THRESHOLD = 0.2        # never below: a candidate this safe in the screen is not worth the high fidelity


@dataclass
class PromotionThreshold:
    """The risk a screened candidate needs to go up the ladder, learned from what promotions found:
    the threshold that would have promoted the fewest passing candidates plus missed the fewest
    failing ones among every screened candidate judged in high fidelity so far (those promoted by
    their risk and those promoted regardless, which keep the estimate honest below it)."""

    value: float = START_THRESHOLD
    judged_risks: list[tuple[float, bool]] = field(default_factory=list)   # (risk, failed in high)

    def judged(self, risk: float, failed: bool) -> None:
        """The high-fidelity verdict on a screened candidate of this ``risk``."""
        self.judged_risks.append((risk, failed))
        failing = sum(f for _, f in self.judged_risks)
        if len(self.judged_risks) < FIT_MIN or failing in (0, len(self.judged_risks)):
            return
        self.value = min(max(separating_risk(self.judged_risks), LOWEST_THRESHOLD), SCREEN_FAILURE_RISK)


def separating_risk(verdicts: list[tuple[float, bool]]) -> float:
    """The risk threshold with the fewest errors on ``verdicts`` (risk, failed): passing candidates
    at or above it plus failing ones below it; midway between the two risks it falls between (the
    lowest such threshold on a tie, so that no failure is given up for nothing)."""
    risks = sorted(verdicts)
    errors = sum(not f for _, f in risks)          # threshold below every risk: each pass is promoted
    best, best_at = errors, risks[0][0]
    for i, (risk, failed) in enumerate(risks):
        errors += 1 if failed else -1               # the threshold moves above this one
        above = risks[i + 1][0] if i + 1 < len(risks) else risk + 1.0
        if errors < best and above > risk:
            best, best_at = errors, (risk + above) / 2.0
    return best_at


@dataclass
class _Yield:
    """What one kind of proposal (or one parent) has cost and found."""
    cost_s: float = 0.0
    found: float = 0.0
    tried: int = 0


class FailureMap:
    """The high-fidelity failures confirmed so far and the proposals still open: how far a
    candidate is from them, which failures are worth searching around (parents), and how crowded
    each failure's scenario is — the failures whose road and start lie within a distinct radius of
    it (the search table counts failing scenarios that far apart)."""

    def __init__(self, radius: float, scenario_dims: list[int]):
        self.radius, self.scenario_dims = radius, list(scenario_dims)
        self.failures: dict[int, Candidate] = {}     # high-fidelity failures, by index
        self.scenario_of: dict[int, tuple] = {}      # ... what the ideal world sees of them
        self._points: dict[tuple[str, str], np.ndarray] = {}     # ... their points, per driver
        self._indices: dict[tuple[str, str], list[int]] = {}     # ... and their indices, in that order
        self._crowd: dict[int, int] = {}             # ... the failures within a radius of each one's scenario
        self.live: dict[int, Candidate] = {}         # proposed, verdict still open
        self.ideal_fails: set[tuple] = set()         # scenarios that already fail in the ideal world

    def add(self, candidate: Candidate) -> None:
        """``candidate`` failed in the high fidelity."""
        near = self.near_scenario(candidate)
        for i in near:
            self._crowd[i] += 1
        self._crowd[candidate.index] = len(near) + 1
        self.failures[candidate.index] = candidate
        self.scenario_of[candidate.index] = _scenario_key(candidate)
        points = self._points.get(candidate.driver, np.empty((0, len(candidate.unit))))
        self._points[candidate.driver] = np.vstack([points, candidate.unit])
        self._indices.setdefault(candidate.driver, []).append(candidate.index)

    def near_scenario(self, c: Candidate) -> list[int]:
        """The failures of ``c``'s driver whose road and start lie within a distinct radius of its own."""
        points = self._points.get(c.driver)
        if points is None or not self.scenario_dims:
            return list(self._indices.get(c.driver, []))
        d = points[:, self.scenario_dims] - np.asarray(c.unit)[self.scenario_dims]
        close = np.flatnonzero(np.sqrt((d ** 2).sum(axis=1)) < self.radius)
        return [self._indices[c.driver][k] for k in close]

    def crowd(self, failure: int) -> int:
        """The failures (itself among them) within a distinct radius of ``failure``'s scenario."""
        return self._crowd[failure]

    def parents(self) -> list[int]:
        """The failures to search around: those whose scenario passes in the ideal world."""
        return [i for i, key in self.scenario_of.items() if key not in self.ideal_fails]

    def novelty(self, c: Candidate, include_live: bool = False) -> float:
        """Distance to the nearest failure (and open proposal), in distinct radii, at most 1."""
        points = self._points.get(c.driver)
        nearest = math.inf if points is None else float(np.sqrt(((points - c.unit) ** 2).sum(axis=1)).min())
        if include_live:
            nearest = min([nearest] + [c.distance(o) for o in self.live.values() if o.index != c.index])
        return min(1.0, nearest / self.radius)


class MoveAllocation:
    """Which kind of move proposes the next candidate, and around which failure: Thompson sampling
    on each move's failures per CPU second, and on each parent's share of failing neighbours per
    CPU second a try around it costs (discounted by the failures its scenario already has)."""

    def __init__(self, spread: float):
        self.spread = spread
        self.move_of: dict[int, tuple[str, int | None]] = {}    # candidate -> (move, parent)
        self.moves = {m: _Yield() for m in MOVES}
        self.parents: dict[int, _Yield] = {}         # failure index -> what its neighbours found

    def choose(self, rng: np.random.Generator, index: int, failures: FailureMap) -> tuple[str, int | None]:
        parents = failures.parents()
        if not parents or index % EXPLORE_EVERY == 0:
            return "global", None
        move = self.draw_move(rng)
        if move == "global":
            return move, None
        # ... and on each parent's failures per CPU second: the share of its neighbours that failed
        # (a beta posterior) over what a try around it costs (its own failing run and its neighbours'
        # runs, averaged), discounted by the failures its road and start already have: a new scenario
        # is worth more than another knob
        yields = [self.parents[p] for p in parents]
        found = np.array([y.found for y in yields])
        tried = np.array([y.tried for y in yields])
        per_try = np.array([y.cost_s for y in yields]) / (tried + 1.0)
        crowd = np.array([failures.crowd(p) for p in parents], dtype=float)
        draws = rng.beta(found + 1.0, tried - found + 1.0) / (np.maximum(per_try, MIN_TRY_COST_S)
                                                              * crowd ** self.spread)
        return move, parents[int(np.argmax(draws))]

    def draw_move(self, rng: np.random.Generator) -> str:
        """Thompson sampling on each move's failures per CPU second: a gamma posterior whose prior
        is the pooled yield of all moves, worth `COST_PRIOR_S` of evidence — so that a move unlucky
        in its first few tries is not starved by one that was lucky (on the real curve-gaps, seed 1,
        two of the first four knob moves passed and the knob moves all but stopped: 8 of 219)."""
        pooled = (sum(y.found for y in self.moves.values()) + 1.0) / (
            sum(y.cost_s for y in self.moves.values()) + COST_PRIOR_S)
        rate = {m: rng.gamma(y.found + pooled * COST_PRIOR_S, 1.0 / (y.cost_s + COST_PRIOR_S))
                for m, y in self.moves.items()}
        return max(rate, key=rate.__getitem__)

    def proposed(self, index: int, move: str, parent: int | None) -> None:
        self.move_of[index] = (move, parent)
        self.moves[move].tried += 1
        if parent is not None:
            self.parents[parent].tried += 1

    def fail_share(self, parent: int) -> float:
        """The share of ``parent``'s neighbours that failed (Laplace's rule: 1/2 before any)."""
        y = self.parents[parent]
        return (y.found + 1.0) / (y.tried + 2.0)

    def charge(self, index: int, cost_s: float) -> None:
        move, parent = self.move_of.get(index, ("global", None))
        cost_s = _seconds(cost_s)
        self.moves[move].cost_s += cost_s
        if parent is not None and parent in self.parents:
            self.parents[parent].cost_s += cost_s

    def new_parent(self, index: int, cost_s: float) -> None:
        """The candidate ``index`` failed in the high fidelity, in a run of ``cost_s``: a parent now,
        its own run the first evidence of what a try around it costs."""
        self.parents[index] = _Yield(cost_s=_seconds(cost_s))

    def found(self, index: int, nth_on_scenario: int) -> None:
        """The candidate ``index`` failed, the ``nth_on_scenario`` failure on its scenario (it
        counts 1/n^spread for its move)."""
        move, parent = self.move_of.get(index, ("global", None))
        self.moves[move].found += nth_on_scenario ** -self.spread
        if parent is not None and parent in self.parents:
            self.parents[parent].found += 1


class MultiFidelityStrategy(Strategy):
    name = "multi_fidelity"
    first_rung = 1

    def __init__(self, space: SearchSpace, seed: int, objective: str, risk_scale: float,
                 distinct_radius: float, scenario_spread: float = 1.0):
        super().__init__(space, seed)
        self.objective, self.risk_scale, self.radius = objective, risk_scale, distinct_radius
        self.knob_dims = [i for i, d in enumerate(space.dims) if d.kind is DimensionKind.KNOB]
        self.scenario_dims = [i for i, d in enumerate(space.dims) if d.kind is not DimensionKind.KNOB]
        self.threshold = PromotionThreshold()
        self.map = FailureMap(distinct_radius, self.scenario_dims)
        self.allocation = MoveAllocation(scenario_spread)
        self.risk: dict[int, float] = {}
        self.high_cost: dict[int, float] = {}       # a high-fidelity run's job time, until confirmed

    # --- proposing ----------------------------------------------------------------------------
    def propose(self, index: int) -> Candidate | None:
        rng = np.random.default_rng([self.seed, index])
        move, parent = self.allocation.choose(rng, index, self.map)
        c = None
        if move != "global" and parent is not None:      # (a move around a parent names it)
            c = self._neighbour(index, self.map.failures[parent], move, rng)
            if c is None:
                move, parent = "global", None
            elif self.allocation.fail_share(parent) >= SKIP_SCREEN_AT:
                c.start_rung = self.high        # the screen would only add its cost
        if c is None:
            c = uniform_candidate(self.space, index, rng)
        self.allocation.proposed(index, move, parent)
        self.map.live[index] = c
        return c

    def _neighbour(self, index: int, parent: Candidate, move: str, rng: np.random.Generator) -> Candidate | None:
        """A point one to one and a half distinct radii from ``parent`` — in the knobs only (the same
        road and start, so its ideal verdict is known) or in the road and start only (a new
        scenario, under the knobs that made the parent fail, a distinct radius from every failing
        scenario) — and at least a distinct radius from every failure and open proposal."""
        dims = self.knob_dims if move == "knobs" else self.scenario_dims
        if not dims:
            return None
        for _ in range(PROPOSAL_TRIES):
            direction = rng.normal(size=len(dims))
            direction /= np.linalg.norm(direction)
            unit = np.array(parent.unit)
            unit[dims] = np.clip(unit[dims] + rng.uniform(*NEIGHBOUR_DISTANCE) * self.radius * direction, 0.0, 1.0)
            c = self.space.candidate(index, unit, parent.vehicle, planner=parent.planner)
            if move == "scenario" and self.map.near_scenario(c):
                continue        # a failing scenario of this driver already lies within a distinct radius
            if self.map.novelty(c, include_live=True) >= 1.0:
                return c
        return None

    # --- learning -----------------------------------------------------------------------------
    def risk_of(self, row: RunRow, failed: bool) -> float | None:
        if row.status != "ok":
            return None
        parts = [SCREEN_FAILURE_RISK if failed else 0.0, row.value("peak_grip_use"),
                 row.value(self.objective) / self.risk_scale]
        return max(p for p in parts if math.isfinite(p))

    def _close(self, candidate: Candidate, found: bool) -> None:
        self.map.live.pop(candidate.index, None)
        if found:
            self.allocation.found(candidate.index, self.map.crowd(candidate.index))

    def observe(self, candidate, rung, row, failed):
        self.allocation.charge(candidate.index, row.value("job_time_s"))
        if rung == 0:
            if row.status == "ok" and failed:
                self.map.ideal_fails.add(_scenario_key(candidate))
            return []
        if rung == self.high:
            if row.status == "ok":
                self.high_cost[candidate.index] = row.value("job_time_s")
            else:
                self._close(candidate, False)
            return []
        risk = self.risk_of(row, failed)
        if risk is None:
            self._close(candidate, False)
            return []
        self.risk[candidate.index] = risk
        explore = candidate.index % EXPLORE_EVERY == EXPLORE_EVERY - 1
        if self.map.novelty(candidate) >= 1.0 and (risk >= self.threshold.value or explore):
            return [rung + 1]
        self._close(candidate, False)      # not promoted: a failure already this close, or too safe
        return []

    def restore(self, candidate, rung, row, failed):
        self.allocation.move_of.setdefault(candidate.index, ("global", None))
        self.observe(candidate, rung, row, failed)

    def confirmed(self, candidate: Candidate, failed: bool) -> None:
        cost_s = self.high_cost.pop(candidate.index, math.nan)
        if failed:
            self.map.add(candidate)
            self.allocation.new_parent(candidate.index, cost_s)
        self._close(candidate, failed)
        risk = self.risk.get(candidate.index)
        if risk is not None:
            self.threshold.judged(risk, failed)


def _seconds(cost_s: float) -> float:
    """A job's time in seconds, 0 where it is not known (nan)."""
    return cost_s if math.isfinite(cost_s) else 0.0


def _scenario_key(c: Candidate) -> tuple:
    """What the ideal world sees of a candidate: its road and start, its vehicle and its planner."""
    return (c.driver, tuple(sorted(c.params.items())))


