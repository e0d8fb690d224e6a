"""Planners: the `Planner` protocol and the Frenet sampling planner on the frenetix core."""

from simgap.planning.protocol import Planner, TrafficParticipant, World

__all__ = ["Planner", "TrafficParticipant", "World"]
