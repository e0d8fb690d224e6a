"""Planners: the `Planner` protocol and the Frenet sampling planner on the frenetix core.

``FrenetPlanner``, ``FrenetSettings`` and ``ReferencePath`` are imported on first use, so that
code needing only the protocol does not load frenetix and the route planner.
"""

from simgap.planning.protocol import Planner, PlannerSetup, TrafficParticipant, World

__all__ = ["FrenetPlanner", "FrenetSettings", "Planner", "PlannerSetup", "ReferencePath", "TrafficParticipant", "World"]

_LAZY = {"FrenetPlanner": "simgap.planning.frenet", "FrenetSettings": "simgap.planning.settings",
         "ReferencePath": "simgap.planning.reference_path"}


def __getattr__(name: str):
    if name in _LAZY:
        import importlib

        return getattr(importlib.import_module(_LAZY[name]), name)
    raise AttributeError(f"module 'simgap.planning' has no attribute {name!r}")
