"""Whether a trajectory is feasible for the kinematic single-track model (KS), with the verdicts of
commonroad-drivability-checker's `trajectory_feasibility` at a fraction of its cost.

The library checks each transition between two consecutive states on its own: an optimiser (SLSQP,
from zero input, within the input bounds) looks for the steering velocity and acceleration whose
simulation over one step (``odeint``) lands nearest the next state — position, speed and heading
— and the transition is feasible when the simulation from the input found lands within 2 cm in x
and y and 0.03 rad in heading (rounded to 4 decimals). That costs milliseconds a transition.

Most transitions need no search: the inputs that reproduce the next steering angle and speed
exactly are the finite differences ``(delta1 - delta0) / dt`` and ``(v1 - v0) / dt``. Where those
inputs lie well inside every constraint the model applies (the input bounds, the friction circle,
the acceleration limit above the switching speed, the steering and speed limits over the step),
the model is a plain ODE; its simulation (RK4, 20 substeps, vectorised over every transition) lands
within ``SURE_COST`` (< 0.02) of the next state, and the optimiser, which minimises that same
distance, ends as near or nearer: within the criteria. Every other transition — near a limit, or farther
from the next state — is checked by the library itself, in order, and the first it finds
infeasible is the verdict. `bench/scores/validity.py` holds the verdicts against the library's alone.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from commonroad.common.solution import VehicleModel
from commonroad.scenario.trajectory import Trajectory

# the library's criteria are 0.02 m in x and y and 0.03 rad; its optimiser ends at a distance no
# larger than the finite-difference input's, so a distance under 0.02 passes them: 0.018 leaves room
SURE_COST = 0.018
MARGIN = 0.95          # a constraint within 95 % of its limit does not act
SUBSTEPS = 20


@dataclass(frozen=True)
class Feasibility:
    """The verdict on a trajectory: feasible, else the time step of the state whose transition to
    the next is not; and how many transitions the library had to check."""

    feasible: bool
    infeasible_from: int | None
    library_checks: int


def ks_feasibility(trajectory: Trajectory, vehicle_dynamics, dt: float) -> Feasibility:
    """The library's verdict on ``trajectory`` for ``vehicle_dynamics`` (its KS model), found
    as the module doc says."""
    from commonroad_dc.feasibility.feasibility_checker import state_transition_feasibility

    if vehicle_dynamics.vehicle_model != VehicleModel.KS:
        raise ValueError(f"the fast path is for the KS model, not {vehicle_dynamics.vehicle_model.name}")
    states = trajectory.state_list
    x = np.array([vehicle_dynamics.state_to_array(s)[0] for s in states])
    sure = sure_transitions(x, vehicle_dynamics.parameters, dt)
    checks = 0
    for k in np.flatnonzero(~sure):
        checks += 1
        feasible, _ = state_transition_feasibility(states[k], states[k + 1], vehicle_dynamics, dt)
        if not feasible:
            return Feasibility(False, states[k].time_step, checks)
    return Feasibility(True, None, checks)


def sure_transitions(x: np.ndarray, p, dt: float) -> np.ndarray:
    """For each transition between the rows of ``x`` (n, 5: rear axle x, y, steering angle, speed,
    heading), whether the finite-difference input reaches the next state within `SURE_COST` with
    no constraint acting."""
    x0, x1 = x[:-1], x[1:]
    steer_rate = (x1[:, 2] - x0[:, 2]) / dt
    accel = (x1[:, 3] - x0[:, 3]) / dt
    lo, hi = p.steering, p.longitudinal
    faster = np.maximum(np.abs(x0[:, 3]), np.abs(x1[:, 3]))
    drive_limit = np.where(faster > hi.v_switch, hi.a_max * hi.v_switch / np.maximum(faster, 1e-9), hi.a_max)
    wheelbase = p.a + p.b
    lateral = x0[:, 3] * x0[:, 3] / wheelbase * np.tan(x0[:, 2])
    inside = (
        (np.abs(steer_rate) <= MARGIN * min(-lo.v_min, lo.v_max))
        & (np.abs(accel) <= MARGIN * hi.a_max) & (accel <= MARGIN * drive_limit)
        & (accel * accel + lateral * lateral <= (MARGIN * hi.a_max) ** 2)             # the friction circle
        & (np.maximum(np.abs(x0[:, 2]), np.abs(x1[:, 2])) <= MARGIN * min(-lo.min, lo.max))
        & (np.minimum(x0[:, 3], x1[:, 3]) > hi.v_min * MARGIN) & (faster < hi.v_max * MARGIN)
    )
    end = _simulate(x0, steer_rate, accel, wheelbase, dt)
    heading = np.angle(np.exp(1j * (x1[:, 4] - end[:, 4])))
    cost = np.sqrt((x1[:, 0] - end[:, 0]) ** 2 + (x1[:, 1] - end[:, 1]) ** 2 + (x1[:, 3] - end[:, 3]) ** 2
                   + heading ** 2)
    return inside & (cost <= SURE_COST)


def _simulate(x0: np.ndarray, steer_rate: np.ndarray, accel: np.ndarray, wheelbase: float, dt: float) -> np.ndarray:
    """The KS model without its constraints from every row of ``x0`` over ``dt`` (RK4)."""
    def rate(x: np.ndarray) -> np.ndarray:
        return np.column_stack([x[:, 3] * np.cos(x[:, 4]), x[:, 3] * np.sin(x[:, 4]), steer_rate, accel,
                                x[:, 3] / wheelbase * np.tan(x[:, 2])])

    x, h = x0.astype(float).copy(), dt / SUBSTEPS
    for _ in range(SUBSTEPS):
        k1 = rate(x)
        k2 = rate(x + h / 2 * k1)
        k3 = rate(x + h / 2 * k2)
        k4 = rate(x + h * k3)
        x = x + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
    return x
