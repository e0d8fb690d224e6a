"""The synchronous multi-agent co-simulation loop and the `History` it leaves behind."""

from simgap.cosim.fidelity import REFERENCE, Fidelity
from simgap.cosim.history import AgentHistory, Event, History, Outcome, PlannerError
from simgap.cosim.history_building import not_started
from simgap.cosim.loop import CosimSettings, simulate
from simgap.sim.protocol import EventKind

__all__ = ["AgentHistory", "CosimSettings", "Event", "EventKind", "Fidelity", "History", "Outcome", "PlannerError",
           "REFERENCE", "not_started", "simulate"]
