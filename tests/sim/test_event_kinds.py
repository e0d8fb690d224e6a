"""One vocabulary of how a run ends: an event's kind is an `Outcome` (a backend reports collisions and
blow-ups in it too) or one of the few `EventKind`s that end nothing; no value is both."""

import pytest

from simgap.cosim import Event
from simgap.sim.protocol import EventKind, Outcome, event_kind


def test_no_value_is_both_an_outcome_and_an_event_kind():
    assert not {o.value for o in Outcome} & {k.value for k in EventKind}


@pytest.mark.parametrize("value, kind", [("collision", Outcome.COLLISION), ("diverged", Outcome.DIVERGED),
                                         ("planner_no_solution", EventKind.PLANNER_NO_SOLUTION),
                                         ("damage", EventKind.DAMAGE)])
def test_an_events_kind_read_from_its_value_is_typed(value, kind):
    assert event_kind(value) is kind
    assert Event(1.0, 1, value).kind is kind


def test_an_unknown_kind_is_refused():
    with pytest.raises(ValueError):
        event_kind("teleported")
