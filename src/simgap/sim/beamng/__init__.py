"""The optional BeamNG.tech backend (``pip install 'simgap[beamng]'``, a running server)."""

from simgap.sim.beamng.backend import BeamngBackend

__all__ = ["BeamngBackend"]
