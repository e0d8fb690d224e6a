"""The planner's assumptions, named: what a planner validated in the ideal world takes for granted
and a physical world can break. The ideal world *is* these assumptions; each physical world's
settings declare which of them they can break and the values of their fields that restore one
(`restoring`), as they declare their knobs, so a counterfactual world in which any subset holds is
the run's own settings with those values put in (`simgap.experiment.attribution`).

``vehicle_dynamics`` (the body, tyres and suspension move as the plan's model says) has no setting
that restores it: its counterfactual is the ideal world itself. An attribution treats it as the
base: its share is what is left between the perfect machine and the ideal run.
"""

from __future__ import annotations

from collections.abc import Mapping
from enum import StrEnum
from typing import Any

from pydantic import BaseModel


class Assumption(StrEnum):
    VEHICLE_DYNAMICS = "vehicle_dynamics"   # the car moves as the plan's model says (the base: the ideal world)
    ACTUATORS = "actuators"                 # steering, drive and brakes act at once (the perfect machine)
    SENSING = "sensing"                     # the planner observes the exact state
    LATENCY = "latency"                     # a plan reaches the car the moment it is made
    RELIEF = "relief"                       # the road is flat
    FRICTION = "friction"                   # the road grips as the tyres' own friction says (dry)


#: declared on a settings model (a class variable): the assumptions its fields can break, each with
#: the values of those fields under which it holds
Restorations = Mapping[Assumption, Mapping[str, Any]]


def restorations(settings: BaseModel | type[BaseModel] | None) -> dict[Assumption, dict[str, Any]]:
    """The assumptions ``settings`` (a model or its class) can break, each with the field values that
    restore it: the ``ASSUMPTIONS`` every class of its model declares (none for the ideal world's)."""
    if settings is None:
        return {}
    cls = settings if isinstance(settings, type) else type(settings)
    out: dict[Assumption, dict[str, Any]] = {}
    for base in reversed(cls.__mro__):
        for assumption, values in vars(base).get("ASSUMPTIONS", {}).items():
            out.setdefault(assumption, {}).update(values)
    return out


def restoring(settings: BaseModel, assumptions: set[Assumption] | frozenset[Assumption]) -> BaseModel:
    """``settings`` with each of ``assumptions`` that they can break restored (the others as they are)."""
    declared = restorations(settings)
    update = {field: value for a in assumptions if a in declared for field, value in declared[a].items()}
    return settings.model_copy(update=update) if update else settings
