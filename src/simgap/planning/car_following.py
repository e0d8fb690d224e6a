"""The Intelligent Driver Model (Treiber, Hennecke, Helbing 2000), the car-following law of the
`idm` planner and of the recorded traffic that reacts (`simgap.cosim.idm`): its parameters and
its interaction with the leader, written once.

    a = a_max [1 - (v / v0)^delta - (s* / s)^2],   s* = s0 + max(0, v T + v dv / (2 sqrt(a_max b)))

with gap s to the leader and closing speed dv = v - v_leader.
"""

from __future__ import annotations

import math

from pydantic import BaseModel, ConfigDict, Field

MIN_GAP_M = 0.1          # gaps below this count as this (the interaction term stays finite)


class IdmParameters(BaseModel):
    """The IDM's parameters (Treiber's defaults for city traffic)."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    max_acceleration: float = Field(1.5, gt=0, description="IDM a: acceleration [m/s^2]")
    comfortable_deceleration: float = Field(2.0, gt=0, description="IDM b: comfortable deceleration [m/s^2]")
    max_deceleration: float = Field(8.0, gt=0, description="the IDM's braking is clipped to this [m/s^2]")
    time_headway_s: float = Field(1.2, ge=0, description="IDM T: time gap to the leader [s]")
    standstill_gap_m: float = Field(2.0, ge=0, description="IDM s0: gap to the leader at standstill [m]")
    exponent: float = Field(4.0, gt=0, description="IDM delta: acceleration exponent")

    def desired_gap(self, v: float, dv: float) -> float:
        """s* [m] at speed ``v``, closing on the leader at ``dv``."""
        return self.standstill_gap_m + max(0.0, v * self.time_headway_s
                                           + v * dv / (2.0 * math.sqrt(self.max_acceleration
                                                                       * self.comfortable_deceleration)))

    def interaction(self, v: float, dv: float, gap: float) -> float:
        """The leader's term (s* / s)^2 of the law (``gap`` floored at `MIN_GAP_M`)."""
        return (self.desired_gap(v, dv) / max(gap, MIN_GAP_M)) ** 2
