"""Search strategies: what to run next, given what has been seen.

Every strategy proposes *candidates* — a point of the search space: scenario parameters, reality
knobs, a vehicle — and says in which fidelity of the ladder each starts. The search loop
(`simgap.experiment.search`) runs them, checks every high-fidelity failure in the ideal world,
and tells the strategy each result.

* ``grid``: ``grid_levels`` values per dimension, every combination, visited in a seeded random
  order so that a budget ending before the grid does still covers the whole space evenly.
* ``random``: uniform, seeded per candidate.
* ``lhs``: a Latin hypercube design of ``lhs_samples`` points, in its order.
* ``bo``: Bayesian optimisation in the high fidelity alone: optuna's TPE (multivariate, with a
  constant liar for runs in flight) maximising the objective.
* ``multi_fidelity``: the cheap fidelities screen, the expensive one confirms. Each candidate
  runs first in the screening fidelity; one whose *risk* reaches the promotion threshold goes up
  a rung, ending in the high fidelity. Risk is the largest of: 2 if the screen run already fails,
  the peak grip use (combined acceleration over what the road's friction allows — a single-track
  screen can ask for more than the road gives without failing), and the objective over
  ``risk_scale``. A candidate within the distinct radius of a confirmed failure is never
  promoted: it would find nothing new.

  Candidates come from three kinds of move: *global* (uniform over the space), *knobs* (a
  confirmed failure's road, start and vehicle under reality knobs one to one and a half distinct
  radii away — the ideal world takes no knob, so its verdict on that scenario is already known
  and is not paid for again) and *scenario* (the same distance away in every dimension: a new
  road or start). The allocation adapts as evidence comes in, at two levels: Thompson sampling
  on each move's failures per CPU second picks the move (one candidate in ten is global
  regardless), and on each failure's share of failing neighbours picks whose neighbourhood to
  search. Both weigh the n-th failure on one road, start and vehicle by ``1/n^scenario_spread``
  (a spec field, default 0.5), so that new scenarios keep being sought. A neighbourhood whose
  neighbours fail at least half the time skips the screen: there a failing high-fidelity run,
  which ends early, costs about what the screen would. The promotion threshold falls when most
  promoted candidates fail in high fidelity (the screen is trustworthy: cast a wider net) and
  rises when few do; one candidate in ten is promoted whatever its risk, and if such a candidate
  fails in high fidelity the threshold drops to its risk (the screen missed it).
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy.stats import qmc

from simgap.experiment.search_spec import SearchSpec
from simgap.planning.registry import DEFAULT_PLANNER
from simgap.scenario.logical import LogicalScenario

EXPLORE_EVERY = 10          # multi_fidelity: one candidate in this many is promoted whatever its risk


@dataclass
class Candidate:
    index: int
    unit: tuple[float, ...]            # the continuous dimensions, normalised to [0, 1]
    vehicle: str
    params: dict[str, float]           # every scenario parameter (defaults filled in)
    knobs: dict[str, float]
    trial: Any = None                  # the optuna trial that proposed it, if any
    start_rung: int | None = None      # the rung it runs in first, if not the strategy's usual one
    planner: str = DEFAULT_PLANNER     # the name of the planner of every agent

    @property
    def driver(self) -> tuple[str, str]:
        """Who drives: the vehicle and the planner (failures of different drivers are distinct)."""
        return (self.vehicle, self.planner)

    def distance(self, other: "Candidate") -> float:
        if self.driver != other.driver:
            return math.inf
        return float(np.linalg.norm(np.subtract(self.unit, other.unit)))


class SearchSpace:
    """The continuous dimensions of a spec (scenario parameters, then knobs), its vehicles and its
    planners (by name)."""

    def __init__(self, spec: SearchSpec, logical: LogicalScenario, vehicles: list[str] | None = None,
                 planners: list[str] | None = None):
        self.spec, self.logical = spec, logical
        self.dims = spec.dimensions
        self.vehicles = list(vehicles or spec.vehicles)      # as runs load them (data files resolved)
        self.planners = list(planners or [DEFAULT_PLANNER])

    def candidate(self, index: int, unit: Any, vehicle: str, trial: Any = None, planner: str | None = None
                  ) -> Candidate:
        unit = tuple(float(min(max(u, 0.0), 1.0)) for u in unit)
        params = {n: p.coerce(p.default) for n, p in self.logical.parameters.items()}
        knobs = {}
        for (kind, name, lo, hi), u in zip(self.dims, unit):
            value = round(lo + u * (hi - lo), 6)
            if kind == "param":
                params[name] = self.logical.parameters[name].coerce(value)
            else:
                knobs[name] = value
        return Candidate(index, unit, vehicle, params, knobs, trial, planner=planner or self.planners[0])

    def distributions(self) -> dict[str, Any]:
        import optuna

        out: dict[str, Any] = {f"u{i}": optuna.distributions.FloatDistribution(0.0, 1.0) for i in range(len(self.dims))}
        if len(self.vehicles) > 1:
            out["vehicle"] = optuna.distributions.CategoricalDistribution(self.vehicles)
        if len(self.planners) > 1:
            out["planner"] = optuna.distributions.CategoricalDistribution(self.planners)
        return out

    def trial_params(self, c: Candidate) -> dict[str, Any]:
        out: dict[str, Any] = {f"u{i}": u for i, u in enumerate(c.unit)}
        if len(self.vehicles) > 1:
            out["vehicle"] = c.vehicle
        if len(self.planners) > 1:
            out["planner"] = c.planner
        return out

    def from_trial(self, index: int, params: dict[str, Any], trial: Any = None) -> Candidate:
        unit = [params[f"u{i}"] for i in range(len(self.dims))]
        return self.candidate(index, unit, params.get("vehicle", self.vehicles[0]), trial, params.get("planner"))


class Strategy:
    """Base: propose candidates by index (deterministic strategies) and ignore results."""

    name = ""
    first_rung = -1          # the high fidelity

    def __init__(self, space: SearchSpace, seed: int):
        self.space, self.seed = space, seed
        self.high = len(space.spec.ladder) - 1

    def propose(self, index: int) -> Candidate | None:
        raise NotImplementedError

    def observe(self, candidate: Candidate, rung: int, row: dict[str, Any], failed: bool) -> list[int]:
        """Record a finished run of ``candidate`` in ``rung``; return the rungs to run it in next."""
        return []

    def restore(self, candidate: Candidate, rung: int, row: dict[str, Any], failed: bool) -> None:
        """Replay a result stored by an earlier invocation (resume)."""
        self.observe(candidate, rung, row, failed)

    def confirmed(self, candidate: Candidate, failed: bool) -> None:
        """The high-fidelity verdict on ``candidate`` (for strategies that learn from it)."""


class GridStrategy(Strategy):
    name = "grid"

    def __init__(self, space: SearchSpace, seed: int, levels: int):
        super().__init__(space, seed)
        axes = [np.linspace(0.0, 1.0, levels) for _ in space.dims]
        points = [(u, v, p) for p in space.planners for v in space.vehicles for u in itertools.product(*axes)]
        order = np.random.default_rng(seed).permutation(len(points))
        self.points = [points[i] for i in order]

    def propose(self, index: int) -> Candidate | None:
        if index >= len(self.points):
            return None
        unit, vehicle, planner = self.points[index]
        return self.space.candidate(index, unit, vehicle, planner=planner)


class RandomStrategy(Strategy):
    name = "random"

    def propose(self, index: int) -> Candidate | None:
        return _uniform(self.space, index, np.random.default_rng([self.seed, index]))


def _uniform(space: SearchSpace, index: int, rng: np.random.Generator) -> Candidate:
    unit = rng.random(len(space.dims))
    vehicle = space.vehicles[rng.integers(len(space.vehicles))]
    planner = space.planners[rng.integers(len(space.planners))] if len(space.planners) > 1 else None
    return space.candidate(index, unit, vehicle, planner=planner)


class LatinHypercubeStrategy(Strategy):
    name = "lhs"

    def __init__(self, space: SearchSpace, seed: int, samples: int):
        super().__init__(space, seed)
        d = len(space.dims) + (1 if len(space.vehicles) > 1 else 0) + (1 if len(space.planners) > 1 else 0)
        self.design = qmc.LatinHypercube(d=max(d, 1), seed=seed).random(samples)

    def propose(self, index: int) -> Candidate | None:
        if index >= len(self.design):
            return None
        row = self.design[index]
        n = len(self.space.dims)
        vehicles, planners = self.space.vehicles, self.space.planners
        vehicle = vehicles[min(int(row[n] * len(vehicles)), len(vehicles) - 1)] if len(vehicles) > 1 else vehicles[0]
        n += len(vehicles) > 1
        planner = planners[min(int(row[n] * len(planners)), len(planners) - 1)] if len(planners) > 1 else None
        return self.space.candidate(index, row[:len(self.space.dims)], vehicle, planner=planner)


class BayesianStrategy(Strategy):
    """A TPE study over the space, maximising the objective in the high fidelity."""

    name = "bo"

    def __init__(self, space: SearchSpace, seed: int, objective: str):
        import optuna

        super().__init__(space, seed)
        self.objective = objective
        optuna.logging.set_verbosity(optuna.logging.WARNING)
        sampler = optuna.samplers.TPESampler(seed=seed, multivariate=True, constant_liar=True,
                                             n_startup_trials=10)
        self.study = optuna.create_study(direction="maximize", sampler=sampler)
        self.distributions = space.distributions()

    def propose(self, index: int) -> Candidate | None:
        trial = self.study.ask(self.distributions)
        return self.space.from_trial(index, trial.params, trial)

    def tell(self, candidate: Candidate, score: float | None) -> None:
        import optuna

        state = optuna.trial.TrialState.FAIL if score is None or not math.isfinite(score) else None
        if candidate.trial is not None:
            if state is None:
                self.study.tell(candidate.trial, score)
            else:
                self.study.tell(candidate.trial, state=state)
            candidate.trial = None
        elif state is None:            # a result from an earlier invocation
            self.study.add_trial(optuna.trial.create_trial(
                params=self.space.trial_params(candidate), distributions=self.distributions, value=score))

    def observe(self, candidate, rung, row, failed):
        if rung == self.high:
            self.tell(candidate, _value(row, self.objective) if row.get("status") == "ok" else None)
        return []


# --- multi_fidelity's numbers ---------------------------------------------------------------
SCREEN_FAILURE_RISK = 2.0     # the risk of a candidate that already fails in the screen (above any other)
MOVES = ("global", "knobs", "scenario")
COST_PRIOR_S = 20.0           # a move's yield starts as one failure per this many CPU seconds
PROPOSAL_TRIES = 30           # neighbours drawn before a move gives up and proposes a global candidate
NEIGHBOUR_DISTANCE = (1.0, 1.5)   # a neighbour's distance from its parent, in distinct radii: new, yet close
SKIP_SCREEN_AT = 0.5          # a neighbourhood whose neighbours fail this often goes straight to high fidelity
# The promotion threshold (a risk) starts where the screen's grip use reaches the road's limit or the
# objective reaches risk_scale, and follows the precision of the recent promotions:
START_THRESHOLD = 1.0
PRECISION_WINDOW = 10         # the promotions the precision is measured over ...
PRECISION_MIN = 4             # ... once there are this many
TRUSTED_PRECISION = 0.6       # above: most promoted candidates fail in high fidelity, cast a wider net ...
WIDEN = 0.9                   # ... by lowering the threshold by this factor
POOR_PRECISION = 0.3          # below: few do, promote fewer ...
NARROW = 1.1                  # ... by raising it by this factor
LOWEST_THRESHOLD = 0.2        # never below: a candidate this safe in the screen is not worth the high fidelity


@dataclass
class PromotionThreshold:
    """The risk a screened candidate needs to go up the ladder, learned from what promotions found."""

    value: float = START_THRESHOLD
    promoted: list[tuple[float, bool]] = field(default_factory=list)   # (risk, failed in high)

    def missed(self, risk: float) -> None:
        """A candidate promoted regardless of its ``risk`` failed in high fidelity: the screen missed it."""
        self.value = min(self.value, risk)

    def judged(self, risk: float, failed: bool) -> None:
        """The high-fidelity verdict on a candidate the threshold promoted."""
        self.promoted.append((risk, failed))
        recent = self.promoted[-PRECISION_WINDOW:]
        if len(recent) < PRECISION_MIN:
            return
        precision = sum(f for _, f in recent) / len(recent)
        if precision > TRUSTED_PRECISION:
            self.value *= WIDEN
        elif precision < POOR_PRECISION:
            self.value *= NARROW
        # never above a screen failure's risk: what fails in the screen always goes up
        self.value = min(max(self.value, LOWEST_THRESHOLD), SCREEN_FAILURE_RISK)


@dataclass
class _Yield:
    """What one kind of proposal (or one parent) has cost and found."""
    cost_s: float = 0.0
    found: float = 0.0
    tried: int = 0


class MultiFidelityStrategy(Strategy):
    name = "multi_fidelity"
    first_rung = 1

    def __init__(self, space: SearchSpace, seed: int, objective: str, risk_scale: float,
                 distinct_radius: float, scenario_spread: float = 0.5):
        super().__init__(space, seed)
        self.objective, self.risk_scale, self.radius = objective, risk_scale, distinct_radius
        self.spread = scenario_spread
        self.knob_dims = [i for i, d in enumerate(space.dims) if d[0] == "knob"]
        self.threshold = PromotionThreshold()
        self.failures: dict[int, Candidate] = {}     # high-fidelity failures, by index
        self.scenario_of: dict[int, tuple] = {}      # ... their scenarios
        self._failure_points: dict[tuple[str, str], np.ndarray] = {}     # ... their points, per driver
        self.live: dict[int, Candidate] = {}         # proposed, verdict still open
        self.risk: dict[int, float] = {}
        self.explored: set[int] = set()
        self.move_of: dict[int, tuple[str, int | None]] = {}    # candidate -> (move, parent)
        self.moves = {m: _Yield() for m in MOVES}
        self.parents: dict[int, _Yield] = {}         # failure index -> what its neighbours found
        self.ideal_fails: set[tuple] = set()         # scenarios that already fail in the ideal world
        self.on_scenario: dict[tuple, int] = {}      # high-fidelity failures per scenario

    # --- proposing ----------------------------------------------------------------------------
    def propose(self, index: int) -> Candidate | None:
        rng = np.random.default_rng([self.seed, index])
        move, parent = self._choose_move(rng, index)
        c = None
        if move != "global":
            c = self._neighbour(index, self.failures[parent], move, rng)
            if c is None:
                move, parent = "global", None
        if c is None:
            c = _uniform(self.space, index, rng)
        elif self._fail_share(parent) >= SKIP_SCREEN_AT:
            c.start_rung = self.high        # the screen would only add its cost
        self.move_of[index] = (move, parent)
        self.moves[move].tried += 1
        if parent is not None:
            self.parents[parent].tried += 1
        self.live[index] = c
        return c

    def _parents(self) -> list[int]:
        return [i for i, key in self.scenario_of.items() if key not in self.ideal_fails]

    def _choose_move(self, rng: np.random.Generator, index: int) -> tuple[str, int | None]:
        parents = self._parents()
        if not parents or index % EXPLORE_EVERY == 0:
            return "global", None
        # Thompson sampling on each move's failures per CPU second (a gamma posterior)
        rate = {m: rng.gamma(y.found + 1.0, 1.0 / (y.cost_s + COST_PRIOR_S)) for m, y in self.moves.items()}
        move = max(rate, key=rate.get)
        if move == "global":
            return move, None
        # ... and on each parent's share of neighbours that failed (a beta posterior), discounted by
        # the failures its road and start already have: a new scenario is worth more than another knob
        found = np.array([self.parents[p].found for p in parents])
        tried = np.array([self.parents[p].tried for p in parents])
        crowd = np.array([self.on_scenario[self.scenario_of[p]] for p in parents], dtype=float)
        draws = rng.beta(found + 1.0, tried - found + 1.0) / crowd ** self.spread
        return move, parents[int(np.argmax(draws))]

    def _fail_share(self, parent: int) -> float:
        """The share of ``parent``'s neighbours that failed (Laplace's rule: 1/2 before any)."""
        y = self.parents[parent]
        return (y.found + 1.0) / (y.tried + 2.0)

    def _neighbour(self, index: int, parent: Candidate, move: str, rng: np.random.Generator) -> Candidate | None:
        """A point one to one and a half distinct radii from ``parent`` — in the knobs only (the same
        road and start, so its ideal verdict is known) or in every dimension — and at least a
        distinct radius from every failure and open proposal."""
        dims = self.knob_dims if move == "knobs" else list(range(len(self.space.dims)))
        if not dims:
            return None
        for _ in range(PROPOSAL_TRIES):
            direction = rng.normal(size=len(dims))
            direction /= np.linalg.norm(direction)
            unit = np.array(parent.unit)
            unit[dims] = np.clip(unit[dims] + rng.uniform(*NEIGHBOUR_DISTANCE) * self.radius * direction, 0.0, 1.0)
            c = self.space.candidate(index, unit, parent.vehicle, planner=parent.planner)
            if move == "scenario" and _scenario_key(c) == _scenario_key(parent):
                continue
            if self._novelty(c, include_live=True) >= 1.0:
                return c
        return None

    def _novelty(self, c: Candidate, include_live: bool = False) -> float:
        """Distance to the nearest failure (and open proposal), in distinct radii, at most 1."""
        points = self._failure_points.get(c.driver)
        nearest = math.inf if points is None else float(np.sqrt(((points - c.unit) ** 2).sum(axis=1)).min())
        if include_live:
            nearest = min([nearest] + [c.distance(o) for o in self.live.values() if o.index != c.index])
        return min(1.0, nearest / self.radius)

    # --- learning -----------------------------------------------------------------------------
    def risk_of(self, row: dict[str, Any], failed: bool) -> float | None:
        if row.get("status") != "ok":
            return None
        parts = [SCREEN_FAILURE_RISK if failed else 0.0, _value(row, "peak_grip_use"),
                 _value(row, self.objective) / self.risk_scale]
        return max(p for p in parts if math.isfinite(p))

    def _charge(self, candidate: Candidate, row: dict[str, Any]) -> None:
        move, parent = self.move_of.get(candidate.index, ("global", None))
        cost = _value(row, "job_time_s")
        self.moves[move].cost_s += cost if math.isfinite(cost) else 0.0

    def _close(self, candidate: Candidate, found: bool) -> None:
        self.live.pop(candidate.index, None)
        move, parent = self.move_of.get(candidate.index, ("global", None))
        if found:
            key = _scenario_key(candidate)
            self.on_scenario[key] = self.on_scenario.get(key, 0) + 1
            self.moves[move].found += self.on_scenario[key] ** -self.spread   # the n-th on a scenario: 1/n^spread
            if parent is not None and parent in self.parents:
                self.parents[parent].found += 1

    def observe(self, candidate, rung, row, failed):
        self._charge(candidate, row)
        if rung == 0:
            if row.get("status") == "ok" and failed:
                self.ideal_fails.add(_scenario_key(candidate))
            return []
        if rung == self.high:
            if row.get("status") != "ok":
                self._close(candidate, False)
            return []
        risk = self.risk_of(row, failed)
        if risk is None:
            self._close(candidate, False)
            return []
        self.risk[candidate.index] = risk
        explore = candidate.index % EXPLORE_EVERY == EXPLORE_EVERY - 1
        if self._novelty(candidate) >= 1.0 and (risk >= self.threshold.value or explore):
            if risk < self.threshold.value:
                self.explored.add(candidate.index)
            return [rung + 1]
        self._close(candidate, False)      # not promoted: a failure already this close, or too safe
        return []

    def restore(self, candidate, rung, row, failed):
        self.move_of.setdefault(candidate.index, ("global", None))
        self.observe(candidate, rung, row, failed)

    def confirmed(self, candidate: Candidate, failed: bool) -> None:
        self._close(candidate, failed)
        if failed:
            self.failures[candidate.index] = candidate
            self.scenario_of[candidate.index] = _scenario_key(candidate)
            points = self._failure_points.get(candidate.driver, np.empty((0, len(candidate.unit))))
            self._failure_points[candidate.driver] = np.vstack([points, candidate.unit])
            self.parents[candidate.index] = _Yield()
        risk = self.risk.get(candidate.index)
        if risk is None:
            return
        if candidate.index in self.explored:        # not the screen's judgement: no evidence on it ...
            if failed:
                self.threshold.missed(risk)         # ... unless the screen missed a failure
            return
        self.threshold.judged(risk, failed)


def _scenario_key(c: Candidate) -> tuple:
    """What the ideal world sees of a candidate: its road and start, its vehicle and its planner."""
    return (c.driver, tuple(sorted(c.params.items())))


def _value(row: dict[str, Any], name: str) -> float:
    v = row.get(name)
    return float(v) if v is not None and not (isinstance(v, float) and math.isnan(v)) else math.nan


def make_strategy(name: str, space: SearchSpace, spec: SearchSpec) -> Strategy:
    if name == "grid":
        return GridStrategy(space, spec.seed, spec.grid_levels)
    if name == "random":
        return RandomStrategy(space, spec.seed)
    if name == "lhs":
        return LatinHypercubeStrategy(space, spec.seed, spec.lhs_samples)
    if name == "bo":
        return BayesianStrategy(space, spec.seed, spec.objective)
    if name == "multi_fidelity":
        return MultiFidelityStrategy(space, spec.seed, spec.objective, spec.risk_scale, spec.distinct_radius,
                                     spec.scenario_spread)
    raise ValueError(name)
