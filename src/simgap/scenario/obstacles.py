"""Non-agent obstacles of a scenario as the simulation sees them: their size and recorded motion."""

from __future__ import annotations

from dataclasses import dataclass

from commonroad.scenario.obstacle import DynamicObstacle
from commonroad.scenario.scenario import Scenario

from simgap.trajectory import State, Trajectory


@dataclass(frozen=True)
class RecordedObstacle:
    """A dynamic obstacle that follows its recorded trajectory (``motion``), whatever happens."""

    id: int
    length: float
    width: float
    motion: Trajectory


def obstacle_trajectory(obstacle: DynamicObstacle, dt: float) -> Trajectory:
    """A dynamic obstacle's recorded motion (initial state + trajectory prediction)."""
    states = [obstacle.initial_state]
    prediction = obstacle.prediction
    if prediction is not None and hasattr(prediction, "trajectory"):
        states += list(prediction.trajectory.state_list)
    rows = []
    for st in states:
        rows.append(State(
            t=st.time_step * dt, x=float(st.position[0]), y=float(st.position[1]),
            yaw=float(getattr(st, "orientation", 0.0) or 0.0),
            v=float(getattr(st, "velocity", 0.0) or 0.0),
            a=float(getattr(st, "acceleration", 0.0) or 0.0),
            yaw_rate=float(getattr(st, "yaw_rate", 0.0) or 0.0)))
    return Trajectory.from_states(rows, dt)


def recorded_obstacles(scenario: Scenario) -> list[RecordedObstacle]:
    """Every dynamic obstacle of the scenario (rectangles; circles as their bounding square)."""
    out = []
    for obs in scenario.dynamic_obstacles:
        shape = obs.obstacle_shape
        length = float(getattr(shape, "length", 0.0) or 2 * getattr(shape, "radius", 1.0))
        width = float(getattr(shape, "width", 0.0) or 2 * getattr(shape, "radius", 1.0))
        out.append(RecordedObstacle(obs.obstacle_id, length, width, obstacle_trajectory(obs, scenario.dt)))
    return out
