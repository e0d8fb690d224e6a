"""Backends: the worlds a plan is executed in. They know nothing about planners."""

from simgap.sim.protocol import Agent, Backend, BackendEvent, PhysicsDiverged

__all__ = ["Agent", "Backend", "BackendEvent", "PhysicsDiverged"]
