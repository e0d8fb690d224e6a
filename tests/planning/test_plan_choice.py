"""The choice of a Frenet cycle's plan, on hand-made verdicts (no core, no road): the cheapest
passing plan within the lateral bound wins; a faster one when traffic holds it back; one that
reaches the goal when the goal is in reach; one beyond the bound only when nothing passes within
it; none, with the reason, when nothing passes; and the second looks' picks."""

from __future__ import annotations

import math

import numpy as np
import pytest

from simgap.planning.plan_choice import (
    BLOCKED_SEARCH_SAMPLES,
    BLOCKED_SPEED_GAIN,
    CheckedChunk,
    Choice,
    ChoiceKind,
    ChoiceRules,
    Encounters,
    Pick,
    choose_plan,
    first_passing,
    latest_met,
)

DESIRED = 10.0
RULES = ChoiceRules(desired_speed=DESIRED, blocked_speed_share=0.5)


def chunk(passing, within=None, speed=None, reaches=None, traffic=0, taken=None):
    n = len(passing)
    return CheckedChunk.of(passing, [True] * n if within is None else within,
                           [DESIRED] * n if speed is None else speed, reaches, traffic, taken)


def no_more():
    """A chunk the choice must not ask for."""
    raise AssertionError("a chunk was looked at after the choice was made")
    yield


def chunks(*given, then_stop=True):
    yield from given
    if then_stop:
        yield from no_more()


# -- the cheapest ------------------------------------------------------------------------------
def test_the_cheapest_passing_plan_wins_and_nothing_after_it_is_looked_at():
    choice = choose_plan(chunks(chunk([False, False, True, True])), RULES)
    assert choice == Choice(Pick(0, 2), ChoiceKind.CHEAPEST)


def test_the_cheapest_may_come_in_a_later_chunk():
    choice = choose_plan(chunks(chunk([False] * 4), chunk([False, True])), RULES)
    assert choice.pick == Pick(1, 1) and choice.kind is ChoiceKind.CHEAPEST


def test_nothing_passing_is_no_plan_with_the_reason():
    choice = choose_plan([chunk([False] * 4), chunk([False] * 8)], RULES)
    assert choice.pick is None and choice.kind is ChoiceKind.NONE
    assert "no plan passes" in choice.reason


def test_no_samples_at_all_is_no_plan():
    assert choose_plan([], RULES).kind is ChoiceKind.NONE


# -- the lateral-acceleration bound ------------------------------------------------------------
def test_a_plan_beyond_the_lateral_bound_is_taken_only_when_nothing_passes_within_it():
    beyond_only = [chunk([True, True], within=[False, False]), chunk([False, True], within=[True, False])]
    choice = choose_plan(beyond_only, RULES)
    assert choice.pick == Pick(0, 0) and choice.kind is ChoiceKind.BEYOND_LATERAL_BOUND
    # a dearer plan within the bound beats a cheaper one beyond it
    later_within = [chunk([True, False], within=[False, True]), chunk([False, True], within=[True, True])]
    assert choose_plan(later_within, RULES) == Choice(Pick(1, 1), ChoiceKind.CHEAPEST)


def test_a_failing_plan_within_the_bound_is_no_plan():
    choice = choose_plan([chunk([False, False], within=[True, True])], RULES)
    assert choice.pick is None


# -- blocked by traffic: a faster plan ---------------------------------------------------------
SLOW = 0.5 * DESIRED - 0.1          # below blocked_speed_share of the desired speed
GAIN = BLOCKED_SPEED_GAIN * DESIRED


def test_a_plan_held_back_by_traffic_gives_way_to_a_faster_one():
    first = chunk([True, True, True], speed=[SLOW, SLOW + GAIN - 0.01, SLOW + GAIN], traffic=3)
    choice = choose_plan(chunks(first), RULES)
    assert choice == Choice(Pick(0, 2), ChoiceKind.FASTER_WHEN_BLOCKED)


def test_the_faster_plan_may_come_chunks_later():
    first = chunk([True, False], speed=[SLOW, 30.0], traffic=1)
    second = chunk([False, True, True], speed=[30.0, SLOW, SLOW + GAIN + 1.0], traffic=1)
    assert choose_plan(chunks(first, second), RULES) == Choice(Pick(1, 2), ChoiceKind.FASTER_WHEN_BLOCKED)


def test_without_a_faster_plan_the_cheapest_wins_and_the_search_ends_after_the_budget():
    first = chunk([True] + [False] * 3, speed=[SLOW] * 4, traffic=2)
    slow = [chunk([True] * 64, speed=[SLOW] * 64, traffic=2) for _ in range(BLOCKED_SEARCH_SAMPLES // 64 - 1)]
    # the cheapest's chunk counts: 4 + 3 x 64 = 196 samples, one more chunk reaches 260 > 256
    last = chunk([True] * 64, speed=[SLOW] * 64, traffic=2)
    choice = choose_plan(chunks(first, *slow, last), RULES)
    assert choice.pick == Pick(0, 0) and choice.kind is ChoiceKind.CHEAPEST
    assert "traffic" in choice.reason


@pytest.mark.parametrize("rules, traffic", [
    (RULES, 0),                                                                    # traffic rejected nothing
    (ChoiceRules(desired_speed=DESIRED, blocked_speed_share=0.5, may_overtake=False), 5),   # the goal is near
    (ChoiceRules(desired_speed=DESIRED, blocked_speed_share=0.0), 5),              # never blocked
])
def test_a_slow_plan_is_not_blocked_without_traffic_rejections_or_overtaking(rules, traffic):
    first = chunk([True, True], speed=[SLOW, 30.0], traffic=traffic)
    assert choose_plan(chunks(first), rules) == Choice(Pick(0, 0), ChoiceKind.CHEAPEST)


def test_a_plan_at_the_blocked_speed_is_not_blocked():
    first = chunk([True, True], speed=[0.5 * DESIRED, 30.0], traffic=5)
    assert choose_plan(chunks(first), RULES).pick == Pick(0, 0)


# -- the goal in reach -------------------------------------------------------------------------
GOAL = ChoiceRules(desired_speed=DESIRED, blocked_speed_share=0.5, goal_in_reach=True)


def test_with_the_goal_in_reach_the_cheapest_plan_that_reaches_it_wins():
    first = chunk([True, True, True], reaches=[False, False, True])
    assert choose_plan(chunks(first), GOAL) == Choice(Pick(0, 2), ChoiceKind.REACHES_GOAL)


def test_a_reaching_plan_beyond_the_bound_or_failing_does_not_count():
    first = chunk([True, False, True], within=[True, True, False], reaches=[False, True, True])
    choice = choose_plan([first], GOAL)
    assert choice.pick == Pick(0, 0) and choice.kind is ChoiceKind.CHEAPEST
    assert "goal" in choice.reason


def test_after_the_cheapest_only_plans_that_reach_the_goal_are_looked_at():
    first = chunk([True, False], reaches=[False, False])
    # not reaching: ignored, though it passes beyond the bound (no fallback) or within it
    skipped = chunk([True, True], within=[False, True], reaches=[False, False])
    reaching = chunk([False, True, True], reaches=[True, False, True])
    assert choose_plan(chunks(first, skipped, reaching), GOAL) == Choice(Pick(2, 2), ChoiceKind.REACHES_GOAL)


def test_a_reaching_plan_is_looked_for_only_among_the_next_samples():
    first = chunk([True] * 4, reaches=[False] * 4)
    nothing = [chunk([False] * 64, reaches=[False] * 64) for _ in range(3)]
    # a chunk of which none reaches the goal counts whole: 4 + 3 x 64 + 64 > 256
    choice = choose_plan(chunks(first, *nothing, chunk([], taken=64)), GOAL)
    assert choice.pick == Pick(0, 0) and choice.kind is ChoiceKind.CHEAPEST


def test_a_reaching_plan_wins_before_a_blocked_cheapest_is_looked_at():
    first = chunk([True, True, True], speed=[SLOW, SLOW, SLOW], reaches=[False, False, True], traffic=1)
    assert choose_plan(chunks(first), GOAL) == Choice(Pick(0, 2), ChoiceKind.REACHES_GOAL)


# -- second looks ------------------------------------------------------------------------------
def test_the_second_look_from_the_road_edge_takes_the_first_passing_plan():
    assert first_passing([np.array([False, False]), np.array([False, True, True])]) == Pick(1, 1)
    assert first_passing([np.array([False]), np.zeros(0, dtype=bool)]) is None


def test_struck_from_behind_takes_the_plan_met_latest_and_the_cheapest_of_equals():
    a = Encounters(np.array([True, True, True, False]), np.array([3.0, 7.0, 5.0, 20.0]))
    b = Encounters(np.array([True, True]), np.array([7.0, 5.0]))
    assert latest_met([a, b]) == (Pick(0, 1), 7.0)
    assert latest_met([Encounters(np.array([True, True]), np.array([6.0, 6.0]))]) == (Pick(0, 0), 6.0)
    assert latest_met([Encounters(np.array([False]), np.array([9.0]))]) is None


def test_a_plan_never_met_ends_the_second_look():
    never = Encounters(np.array([True, True]), np.array([4.0, math.inf]))
    assert latest_met(chunks(never)) == (Pick(0, 1), math.inf)


def test_without_traffic_holding_it_back_a_faster_plan_does_not_beat_the_cheapest():
    # the goal in reach keeps the search going past the cheapest, for a plan that reaches it only
    first = chunk([True, True], speed=[SLOW, 30.0], reaches=[False, False], traffic=0)
    assert choose_plan([first, chunk([True], speed=[30.0], reaches=[False])], GOAL) == \
        Choice(Pick(0, 0), ChoiceKind.CHEAPEST, "no plan reaches the goal")
