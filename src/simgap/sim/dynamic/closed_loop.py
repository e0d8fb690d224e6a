"""One vehicle, one controller, a sequence of plans: the inner loop of a physics backend.

Every ``plan_period`` seconds a new plan is taken (as a backend receives one per scenario dt);
in between, the controller runs at its own rate and the plant holds each command for one
controller period.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Protocol

from simgap.control.protocol import Command, Controller
from simgap.trajectory import State, Trajectory


class Plant(Protocol):
    """One car alone, driven by commands: the single-track (`SingleTrackPlant`) and multi-body
    models, the MuJoCo car on a proving ground (`simgap.sim.mujoco.plant.MujocoPlant`)."""

    def reset(self, state: State) -> State:
        """Place the car at ``state``; the state it is measured in then."""
        ...

    def step(self, command: Command, period: float) -> State:
        """Hold ``command`` for ``period`` seconds; the state afterwards."""
        ...


def track_plans(plant: Plant, controller: Controller, plan_at: Callable[[float, State], Trajectory],
                initial: State, duration: float, *, plan_period: float = 0.1) -> list[State]:
    """Drive from ``initial`` for ``duration`` seconds; return the state after every controller
    period (the first entry is ``initial`` as the plant holds it).

    ``plan_at(t, observed)`` returns the plan in force from time ``t`` on, given the state
    observed then.
    """
    state = plant.reset(initial)
    controller.reset(state)
    period = 1.0 / controller.rate_hz
    ticks_per_plan = max(1, round(plan_period / period))
    n_plans = math.ceil(duration / (ticks_per_plan * period) - 1e-9)
    states = [state]
    t0 = initial.t
    tick = 0
    for _ in range(n_plans):
        plan = plan_at(t0 + tick * period, state)
        for _ in range(ticks_per_plan):
            t = t0 + tick * period
            cmd = controller.command(state, plan, t)
            state = plant.step(cmd, period)
            tick += 1
            # keep the clock on the grid (no drift from summing periods)
            state = state.replace(t=t0 + tick * period)
            states.append(state)
    return states
