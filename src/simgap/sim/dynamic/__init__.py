"""The mid-fidelity ``dynamic`` world: controllers driving CommonRoad's single-track model.

For now it holds the plant (`SingleTrackPlant`) and a closed loop that tracks a sequence of
plans with one controller (`track_plans`); the backend built on them comes later.
"""

from simgap.sim.dynamic.closed_loop import track_plans
from simgap.sim.dynamic.plant import SingleTrackPlant, single_track_parameters

__all__ = ["SingleTrackPlant", "single_track_parameters", "track_plans"]
