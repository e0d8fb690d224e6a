"""simgap: validate motion planners across simulation fidelities."""

__version__ = "0.1.0"
