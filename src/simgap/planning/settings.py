"""Settings of the Frenet sampling planner (a pydantic model, readable from YAML).

Defaults follow the paper's Frenetix configuration where it states one: horizon 3.0 s, end times
1.1-3.0 s, lateral offsets within +-3 m, about 800 samples per cycle, cost weights lateral jerk
0.2, longitudinal jerk 0.2, velocity offset 1.0, distance to the reference path 5.0.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

from pydantic import BaseModel, ConfigDict, Field, model_validator

from simgap.errors import validated
from simgap.files import read_model


class _Section(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)


class SamplingSettings(_Section):
    """What the planner samples each cycle: end time x end speed x lateral offset."""

    horizon_s: float = Field(3.0, gt=0, le=20, description="length of every plan [s]")
    t_min_s: float = Field(1.1, gt=0, description="shortest end time of a manoeuvre [s]")
    time_samples: int = Field(10, ge=1, le=100, description="end times between t_min_s and horizon_s")
    speed_samples: int = Field(7, ge=1, le=100, description="end speeds, the desired speed among them")
    lateral_samples: int = Field(11, ge=1, le=201,
                                 description="lateral end offsets in [-lateral_range_m, +lateral_range_m]")
    lateral_range_m: float = Field(3.0, ge=0, le=20, description="largest lateral end offset [m]")
    speed_below_m_s: float = Field(
        4.0, ge=0, description="end speeds reach this far below min(current, desired) speed [m/s]")
    speed_above_m_s: float = Field(
        1.0, ge=0, description="end speeds reach this far above max(current, desired) speed [m/s]")
    low_velocity_threshold_m_s: float = Field(
        2.0, ge=0, description="below this speed the lateral motion is planned over distance, not time")

    @model_validator(mode="after")
    def _times_fit_the_horizon(self) -> SamplingSettings:
        if self.t_min_s > self.horizon_s:
            raise ValueError(f"t_min_s ({self.t_min_s}) must not exceed horizon_s ({self.horizon_s})")
        return self

    @property
    def samples_per_cycle(self) -> int:
        """Samples generated per cycle (770 by default)."""
        return self.time_samples * self.speed_samples * self.lateral_samples


class CostWeights(_Section):
    """Weights of the frenetix cost functions; a weight of 0 leaves the function out."""

    lateral_jerk: float = Field(0.2, ge=0)
    longitudinal_jerk: float = Field(0.2, ge=0)
    velocity_offset: float = Field(1.0, ge=0, description="deviation from the desired speed")
    distance_to_reference_path: float = Field(5.0, ge=0)
    orientation_offset: float = Field(0.0, ge=0, description="heading relative to the reference path")
    acceleration: float = Field(0.0, ge=0)


class SpeedSettings(_Section):
    """The desired speed: the goal's velocity interval or a cruise speed, slowed for curvature."""

    cruise_m_s: float = Field(10.0, gt=0, description="desired speed [m/s]; a faster start keeps its speed, and a goal velocity window above it raises it")
    max_lateral_acceleration: float = Field(
        4.0, gt=0, description="bound on v^2 * curvature along plans and the reference path [m/s^2]")
    late_lateral_acceleration: float = Field(
        6.0, gt=0, description="the bound instead, for a vehicle that would enter its goal after the time window "
                               "closes within max_lateral_acceleration [m/s^2]")
    comfortable_deceleration: float = Field(
        2.0, gt=0, description="deceleration assumed when slowing down ahead of a curve [m/s^2]")
    lookahead_s: float = Field(
        3.0, ge=0, description="the desired speed is the lowest of the speed profile this far ahead [s]")
    enforce_lateral_acceleration: bool = Field(
        True, description="prefer plans within max_lateral_acceleration and the vehicle's steering rate "
                          "(others only if none is)")
    blocked_speed_share: float = Field(
        0.8, ge=0, le=1, description="when traffic holds the cheapest plan below this share of the desired "
                                     "speed, a clearly faster plan (a lane change, an overtaking) is taken "
                                     "if one passes; 0: always the cheapest (wait behind)")


class ReferencePathSettings(_Section):
    """How the route's centre line becomes the reference path."""

    spacing_m: float = Field(1.0, gt=0.05, le=5, description="distance between reference points [m]")
    smoothing_m: float = Field(1.0, ge=0, le=20,
                               description="standard deviation of the Gaussian smoothing along the path [m]")
    extension_m: float | None = Field(
        None, gt=0, description="straight extension beyond the route's end [m]; "
                                "default: horizon x vehicle max speed + 20 m")
    extension_back_m: float = Field(20.0, ge=0, description="straight extension before the route's start [m]")


class CollisionSettings(_Section):
    """Collision checks of the sampled plans (the frenetix core does none)."""

    traffic_margin_m: float = Field(0.1, ge=0, description="clearance kept to other traffic [m]")
    road_margin_m: float = Field(0.0, ge=0, description="clearance kept to the road edge [m]")
    road_grid_resolution_m: float = Field(
        0.1, gt=0.01, le=1.0, description="cell size of the drivable-area grid [m]")
    road_grid_max_cells: int = Field(
        30_000_000, ge=10_000, description="the grid is coarsened when it would exceed this size")
    footprint_point_spacing_m: float = Field(
        0.5, gt=0.05, le=2.0, description="spacing of the footprint-outline points tested on the grid [m]")
    stopping_deceleration: float | None = Field(
        6.0, gt=0, description="a plan must end where braking at this deceleration along the reference "
                               "path stops clear of traffic braking from where it is at the horizon's end "
                               "[m/s^2]; null: no such check")
    traffic_deceleration: float | None = Field(
        8.0, gt=0, description="beyond the horizon, other traffic is assumed to brake at this deceleration "
                               "[m/s^2]; null: it is assumed to stop at once where it is at the horizon's end")
    recovery_s: float = Field(
        1.0, ge=0, description="when the vehicle is not safely on the road (within a grid cell of its edge, or off "
                               "it), plans get this long to get back, going no further out than it is [s]")


class FrenetSettings(_Section):
    """Everything the Frenet sampling planner can be told."""

    sampling: SamplingSettings = Field(default_factory=SamplingSettings)
    costs: CostWeights = Field(default_factory=CostWeights)
    speed: SpeedSettings = Field(default_factory=SpeedSettings)
    reference_path: ReferencePathSettings = Field(default_factory=ReferencePathSettings)
    collision: CollisionSettings = Field(default_factory=CollisionSettings)
    check_whole_trajectory: bool = Field(
        False, description="feasibility checks include the constant-velocity tail after the end time")
    continue_plan_within_m: float | None = Field(
        0.3, ge=0, description="a plan starts from the last plan's state when the vehicle is this close to "
                               "it (and within 0.1 rad and 1 m/s), else from the observed state [m]; "
                               "null: always from the observed state")
    relax_initial_state: bool = Field(
        True, description="when no sample is feasible, retry once from the observed pose and speed "
                          "with zero acceleration and the reference path's curvature")
    concurrent_evaluation: bool = Field(
        False, description="evaluate samples on all cores (frenetix taskflow); deterministic either way")

    @classmethod
    def from_mapping(cls, data: Mapping[str, Any] | None, file: str | Path | None = None) -> FrenetSettings:
        """Validate ``data``; a bad field becomes an `InputError` naming its path."""
        return validated(cls, data, file=file)

    @classmethod
    def from_yaml(cls, path: str | Path) -> FrenetSettings:
        return read_model(path, cls, "planner settings file", empty_ok=True)
