"""The mid-fidelity ``dynamic`` world: controllers driving CommonRoad's single-track model.

The vehicle models (`plant`: CommonRoad's single-track model, and its multi-body model on
request), the backend that drives them under the tracking controllers (`backend`), and a closed
loop that tracks a sequence of plans with one controller (`track_plans`, for studies).
"""

from simgap.sim.dynamic.closed_loop import track_plans
from simgap.sim.dynamic.plant import SingleTrackPlant, single_track_parameters

__all__ = ["SingleTrackPlant", "single_track_parameters", "track_plans"]
