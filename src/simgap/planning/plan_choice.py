"""The choice of a Frenet cycle's plan among its checked samples: pure functions of the checks'
verdicts, callable without the frenetix core.

The samples come in the core's cost order, cheapest first, in chunks (`CheckedChunk`: per sample
whether it passed the limit, traffic and road checks, whether it keeps within the lateral-
acceleration bound, its end speed and whether it reaches the goal). `step` folds one chunk into
the `ChoiceState`, `searching` says whether another chunk could still change the choice, and
`final` gives the `Choice`; `choose_plan` runs them over a sequence of chunks. The rules:

* The cheapest passing sample within the lateral bound wins (`ChoiceKind.CHEAPEST`) ...
* ... unless traffic holds it back: traffic rejected a sample this cycle, overtaking is allowed
  (`ChoiceRules.may_overtake`) and it ends below ``blocked_speed_share`` of the desired speed.
  Then the first sample among the next `BLOCKED_SEARCH_SAMPLES` that ends faster by
  `BLOCKED_SPEED_GAIN` x the desired speed wins (`FASTER_WHEN_BLOCKED`: a lane change, an
  overtaking); without one, the cheapest.
* With the goal in reach (`ChoiceRules.goal_in_reach`) the cheapest passing sample within the
  bound that reaches the goal wins (`REACHES_GOAL`), looked for among as many more samples once
  the cheapest is known (only those that reach it are then looked at: `only_reaching`); without
  one, the cheapest.
* When no sample passes within the bound, the cheapest that passes beyond it
  (`BEYOND_LATERAL_BOUND`).
* None passes: no plan (`ChoiceKind.NONE`, with the reason). The planner then takes a second look
  at the same samples under other rules (back onto the road from its edge; traffic that only runs
  into the ego from behind); `first_passing` and `latest_met` pick among those verdicts.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass, replace
from enum import StrEnum

import numpy as np

__all__ = ["BLOCKED_SEARCH_SAMPLES", "BLOCKED_SPEED_GAIN", "CheckedChunk", "Choice", "ChoiceKind", "ChoiceRules",
           "ChoiceState", "Encounters", "Pick", "choose_plan", "final", "first_passing", "latest_met",
           "only_reaching", "searching", "step"]

# when traffic blocks the cheapest plan (ChoiceRules.blocked_speed_share), a plan faster by
# BLOCKED_SPEED_GAIN x the desired speed is looked for among this many more samples
BLOCKED_SPEED_GAIN = 0.2
BLOCKED_SEARCH_SAMPLES = 256


class ChoiceKind(StrEnum):
    """Why the chosen sample won."""

    CHEAPEST = "cheapest"                           # the cheapest passing within the lateral bound
    FASTER_WHEN_BLOCKED = "faster_when_blocked"     # faster than the cheapest, which traffic holds back
    REACHES_GOAL = "reaches_goal"                   # the cheapest that reaches the goal
    BEYOND_LATERAL_BOUND = "beyond_lateral_bound"   # nothing passes within the bound: the cheapest beyond it
    NONE = "none"                                   # nothing passes


@dataclass(frozen=True)
class ChoiceRules:
    """What the choice of one cycle depends on besides the verdicts."""

    desired_speed: float               # [m/s]
    blocked_speed_share: float         # the cheapest plan is blocked below this share of the desired speed
    may_overtake: bool = True          # not when the goal is near: it is entered behind slower traffic
    goal_in_reach: bool = False        # a plan may reach the goal within the horizon


@dataclass(frozen=True)
class CheckedChunk:
    """Samples taken from the cost order together, cheapest first, and their verdicts (arrays of
    one entry per checked sample)."""

    taken: int                         # samples taken from the cost order (those not checked included)
    passing: np.ndarray                # within the vehicle's limits, clear of traffic, on the road
    within_bound: np.ndarray           # within the lateral-acceleration bound and the steering rate (or not enforced)
    end_speed: np.ndarray              # [m/s]
    reaches_goal: np.ndarray           # looked at for passing samples within the bound while the goal is in reach
    rejected_for_traffic: int          # samples of the cycle rejected for traffic so far, this chunk's included

    @classmethod
    def of(cls, passing, within_bound, end_speed, reaches_goal=None, rejected_for_traffic: int = 0,
           taken: int | None = None) -> CheckedChunk:
        """A chunk from sequences (tests, hand-made records); ``reaches_goal`` all False and
        ``taken`` the number of samples unless given."""
        passing = np.asarray(passing, dtype=bool)
        reaches = np.zeros(len(passing), dtype=bool) if reaches_goal is None else np.asarray(reaches_goal, dtype=bool)
        return cls(len(passing) if taken is None else taken, passing, np.asarray(within_bound, dtype=bool),
                   np.asarray(end_speed, dtype=float), reaches, rejected_for_traffic)


@dataclass(frozen=True)
class Pick:
    """A sample: its chunk (in the order the chunks came) and its row in the chunk."""

    chunk: int
    row: int


@dataclass(frozen=True)
class Choice:
    """The chosen sample (None: none) and why."""

    pick: Pick | None
    kind: ChoiceKind
    reason: str = ""


@dataclass(frozen=True)
class ChoiceState:
    """The choice so far, after ``chunks`` chunks."""

    chunks: int = 0
    cheapest: Pick | None = None        # the cheapest passing sample within the bound
    cheapest_speed: float = math.nan
    blocked: bool = False               # traffic holds the cheapest back
    beyond_bound: Pick | None = None    # the cheapest passing sample beyond the lateral bound
    beyond_cheapest: int = 0            # samples taken after the cheapest was found (its chunk included)
    decided: Choice | None = None       # a sample that ends the search


def only_reaching(state: ChoiceState) -> bool:
    """Only a sample that reaches the goal could change the choice now (so only those need checking)."""
    return state.cheapest is not None and not state.blocked


def searching(state: ChoiceState) -> bool:
    """Could another chunk change the choice?"""
    return state.decided is None and state.beyond_cheapest < BLOCKED_SEARCH_SAMPLES


def step(state: ChoiceState, chunk: CheckedChunk, rules: ChoiceRules) -> ChoiceState:
    """``state`` after the next ``chunk`` (in cost order). While `only_reaching`, the chunk's samples
    that do not reach the goal are not looked at."""
    k = state.chunks
    cheapest, speed, blocked, beyond_bound = state.cheapest, state.cheapest_speed, state.blocked, state.beyond_bound
    reaching_only = only_reaching(state)
    if reaching_only and not chunk.reaches_goal.any():
        return replace(state, chunks=k + 1, beyond_cheapest=state.beyond_cheapest + chunk.taken)
    considered = chunk.reaches_goal if reaching_only else True
    beyond = chunk.passing & ~chunk.within_bound & considered
    if beyond_bound is None and beyond.any():
        beyond_bound = Pick(k, int(np.flatnonzero(beyond)[0]))
    within = np.flatnonzero(chunk.passing & chunk.within_bound & considered)
    decided = None
    if rules.goal_in_reach and len(within):
        reaching = within[chunk.reaches_goal[within]]
        if len(reaching):
            decided = Choice(Pick(k, int(reaching[0])), ChoiceKind.REACHES_GOAL)
    if decided is None:
        for i in within:
            if cheapest is None:
                cheapest, speed = Pick(k, int(i)), chunk.end_speed[i]
                blocked = (rules.may_overtake and chunk.rejected_for_traffic > 0
                           and speed < rules.blocked_speed_share * rules.desired_speed)
                if not (blocked or rules.goal_in_reach):
                    decided = Choice(cheapest, ChoiceKind.CHEAPEST)
                    break
            elif blocked and chunk.end_speed[i] >= speed + BLOCKED_SPEED_GAIN * rules.desired_speed:
                decided = Choice(Pick(k, int(i)), ChoiceKind.FASTER_WHEN_BLOCKED)
                break
    taken = state.beyond_cheapest + chunk.taken if decided is None and cheapest is not None \
        else state.beyond_cheapest
    return ChoiceState(k + 1, cheapest, speed, blocked, beyond_bound, taken, decided)


def final(state: ChoiceState) -> Choice:
    """The choice once `searching` ends (or the samples run out)."""
    if state.decided is not None:
        return state.decided
    if state.cheapest is not None:
        why = ("no faster plan where traffic holds the cheapest back" if state.blocked
               else "no plan reaches the goal")
        return Choice(state.cheapest, ChoiceKind.CHEAPEST, why)
    if state.beyond_bound is not None:
        return Choice(state.beyond_bound, ChoiceKind.BEYOND_LATERAL_BOUND,
                      "no plan passes within the lateral-acceleration bound")
    return Choice(None, ChoiceKind.NONE, "no plan passes the limit, traffic and road checks")


def choose_plan(chunks: Iterable[CheckedChunk], rules: ChoiceRules) -> Choice:
    """The plan of a cycle whose samples, in cost order, were checked in ``chunks`` (taken no
    further than the choice needs them)."""
    state, chunks = ChoiceState(), iter(chunks)
    while searching(state):
        chunk = next(chunks, None)
        if chunk is None:
            break
        state = step(state, chunk, rules)
    return final(state)


def first_passing(passing: Iterable[np.ndarray]) -> Pick | None:
    """The first passing sample of chunks of verdicts (the planner's second look at a vehicle at
    the road's edge: the cheapest that gets back onto the road within the recovery time)."""
    for k, chunk in enumerate(passing):
        if chunk.any():
            return Pick(k, int(np.flatnonzero(chunk)[0]))
    return None


@dataclass(frozen=True)
class Encounters:
    """Per sample of a chunk: does it pass except that traffic runs into it from behind
    (``innocent``), and the step at which it first meets traffic (inf: never within the horizon)."""

    innocent: np.ndarray
    met_at: np.ndarray


def latest_met(chunks: Iterable[Encounters]) -> tuple[Pick, float] | None:
    """Of the innocent samples, the one met by traffic latest (the cheapest of equals), and when;
    a sample never met ends the search (chunks after it are not looked at). None: none innocent."""
    best: tuple[float, Pick] | None = None
    for k, chunk in enumerate(chunks):
        innocent = np.flatnonzero(chunk.innocent)
        if len(innocent):
            i = int(innocent[np.argmax(chunk.met_at[innocent])])        # the first of the latest met
            if best is None or chunk.met_at[i] > best[0]:
                best = (float(chunk.met_at[i]), Pick(k, i))
            if math.isinf(best[0]):
                break
    return None if best is None else (best[1], best[0])
