"""What a run is evaluated by (`EvaluationSettings`): the CommonRoad cost function its driven
trajectories are costed with, and the thresholds and weights of the closed-loop score (the settings
``evaluation.cost_function`` and ``evaluation.score``; the scoring itself is
`simgap.evaluate.solution` and `simgap.evaluate.closed_loop_score`). The loop knows nothing of them.

The closed-loop score is built like nuPlan's closed-loop score (CLS). Every default below is
nuPlan's, read from ``motional/nuplan-devkit``; the description of each setting names the file
it comes from (``…/simulation_metric/`` stands for
``nuplan/planning/script/config/common/simulation_metric/``).
"""

from __future__ import annotations

from enum import Enum

from pydantic import BaseModel, ConfigDict, Field, model_validator

_NUPLAN_METRICS = "nuplan/planning/script/config/common/simulation_metric"
_NUPLAN_WEIGHTS = "nuplan/planning/script/config/simulation/metric_aggregator/" \
                  "closed_loop_nonreactive_agents_weighted_average.yaml"


class CostFunctionId(str, Enum):
    """The cost functions commonroad-drivability-checker evaluates (its ``cost_function_mapping``)."""

    JB1 = "JB1"
    SA1 = "SA1"
    WX1 = "WX1"
    SM1 = "SM1"
    SM2 = "SM2"
    SM3 = "SM3"
    MW1 = "MW1"
    TR1 = "TR1"


DEFAULT_COST_FUNCTION = CostFunctionId.SM1
COST_FUNCTION_DESCRIPTION = (
    "CommonRoad cost function of each agent's solution when the scenario's benchmark ID names none: JB1, SA1, "
    "WX1, SM1, SM2, SM3, MW1, TR1; default SM1 (acceleration, steering angle and rate, path length, velocity "
    "and orientation offset: the smoothness cost of CommonRoad's benchmark solutions); SA1, WX1 and TR1 hold the "
    "distance-to-obstacles term, which commonroad-drivability-checker 2025.3.1 cannot evaluate with numpy 2: their "
    "cost is reported as not evaluated, with the library's error")


class ComfortBounds(BaseModel):
    """nuPlan's comfort bounds (``ego_is_comfortable``): the run is comfortable when every filtered
    sample lies strictly inside every bound."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    min_lon_accel: float = Field(-4.05, lt=0, description="longitudinal acceleration above [m/s^2] (nuPlan: "
                                 f"{_NUPLAN_METRICS}/low_level/ego_lon_acceleration_statistics.yaml, min_lon_accel)")
    max_lon_accel: float = Field(2.40, gt=0, description="longitudinal acceleration below [m/s^2] (nuPlan: "
                                 f"{_NUPLAN_METRICS}/low_level/ego_lon_acceleration_statistics.yaml, max_lon_accel)")
    max_abs_lat_accel: float = Field(4.89, gt=0, description="|lateral acceleration| below [m/s^2] (nuPlan: "
                                     f"{_NUPLAN_METRICS}/low_level/ego_lat_acceleration_statistics.yaml)")
    max_abs_jerk: float = Field(8.37, gt=0, description="|jerk of the acceleration's magnitude| below [m/s^3] "
                                f"(nuPlan: {_NUPLAN_METRICS}/low_level/ego_jerk_statistics.yaml, max_abs_mag_jerk)")
    max_abs_lon_jerk: float = Field(4.13, gt=0, description="|longitudinal jerk| below [m/s^3] (nuPlan: "
                                    f"{_NUPLAN_METRICS}/low_level/ego_lon_jerk_statistics.yaml)")
    max_abs_yaw_rate: float = Field(0.95, gt=0, description="|yaw rate| below [rad/s] (nuPlan: "
                                    f"{_NUPLAN_METRICS}/low_level/ego_yaw_rate_statistics.yaml)")
    max_abs_yaw_accel: float = Field(1.93, gt=0, description="|yaw acceleration| below [rad/s^2] (nuPlan: "
                                     f"{_NUPLAN_METRICS}/low_level/ego_yaw_acceleration_statistics.yaml)")


class ScoreWeights(BaseModel):
    """Weights of the score's weighted mean (nuPlan's metric aggregator)."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    progress: float = Field(5.0, ge=0, description=f"progress along the route (nuPlan: {_NUPLAN_WEIGHTS}, "
                            "ego_progress_along_expert_route)")
    time_to_collision: float = Field(5.0, ge=0, description=f"TTC within bound (nuPlan: {_NUPLAN_WEIGHTS}, "
                                     "time_to_collision_within_bound)")
    speed_limit: float = Field(4.0, ge=0, description=f"speed-limit compliance (nuPlan: {_NUPLAN_WEIGHTS}, "
                               "speed_limit_compliance)")
    comfort: float = Field(2.0, ge=0, description=f"comfort (nuPlan: {_NUPLAN_WEIGHTS}, ego_is_comfortable)")

    @model_validator(mode="after")
    def _some_weight(self) -> ScoreWeights:
        if not any((self.progress, self.time_to_collision, self.speed_limit, self.comfort)):
            raise ValueError("at least one weight must be positive")
        return self


class ScoreSettings(BaseModel):
    """Thresholds and weights of the closed-loop score (``evaluation.score``)."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    at_fault_collisions_vehicle: int = Field(
        0, ge=0, description="at-fault collisions with vehicles tolerated before the multiplier is 0 (each one "
        "takes 1/(n+1)) (nuPlan: " f"{_NUPLAN_METRICS}/high_level/no_ego_at_fault_collisions_statistics.yaml, "
        "max_violation_threshold_vehicle)")
    at_fault_collisions_vru: int = Field(
        0, ge=0, description="... with pedestrians and cyclists (nuPlan: same file, max_violation_threshold_vru)")
    at_fault_collisions_object: int = Field(
        1, ge=0, description="... with static objects (nuPlan: same file, max_violation_threshold_object)")
    stopped_speed_m_s: float = Field(
        0.05, ge=0, description="a road user at or below this speed counts as stopped when a collision is judged "
        "[m/s] (nuPlan: nuplan/planning/metrics/evaluation_metrics/common/no_ego_at_fault_collisions.py, "
        "stopped_speed_threshold of _get_collision_type)")
    behind_angle_deg: float = Field(
        150.0, gt=90, le=180, description="another road user is behind the ego when the direction to it from the "
        "ego's rear axle is more than this from its heading [deg] (nuPlan: nuplan/planning/simulation/observation/"
        "idm/utils.py, is_agent_behind)")
    drivable_area_tolerance_m: float = Field(
        0.3, ge=0, description="the footprint may reach this far beyond the drivable area before the multiplier is 0 "
        f"[m] (nuPlan: {_NUPLAN_METRICS}/high_level/drivable_area_compliance_statistics.yaml, "
        "max_violation_threshold); a run the loop ended off road (beyond cosim.offroad_tolerance) scores 0 too")
    direction_compliance_m: float = Field(
        2.0, ge=0, description="driving against the lane's direction up to this far within the horizon is no "
        f"violation [m] (nuPlan: {_NUPLAN_METRICS}/high_level/driving_direction_compliance_statistics.yaml, "
        "driving_direction_compliance_threshold)")
    direction_violation_m: float = Field(
        6.0, ge=0, description="... beyond this far the multiplier is 0, in between 0.5 [m] (nuPlan: same file, "
        "driving_direction_violation_threshold)")
    direction_horizon_s: float = Field(
        1.0, gt=0, description="the window the movement against the lane is summed over [s] (nuPlan: same file, "
        "time_horizon)")
    min_progress_ratio: float = Field(
        0.2, ge=0, le=1, description="progress ratio below which the making-progress multiplier is 0 (nuPlan: "
        f"{_NUPLAN_METRICS}/high_level/ego_is_making_progress_statistics.yaml, min_progress_threshold)")
    progress_floor_m: float = Field(
        2.0, gt=0, description="progress ratio = max(progress, floor) / max(progress to the goal, floor) [m] "
        f"(nuPlan: {_NUPLAN_METRICS}/low_level/ego_progress_along_expert_route_statistics.yaml, "
        "score_progress_threshold)")
    min_time_to_collision_s: float = Field(
        0.95, ge=0, description="the TTC must stay above this at every step [s] (nuPlan: "
        f"{_NUPLAN_METRICS}/high_level/time_to_collision_within_bound_statistics.yaml, least_min_ttc)")
    ttc_horizon_s: float = Field(3.0, gt=0, description="how far road users are projected at constant velocity [s] "
                                 "(nuPlan: same file, time_horizon)")
    ttc_step_s: float = Field(0.1, gt=0, description="the projection's step [s] (nuPlan: same file, time_step_size)")
    ttc_stopped_speed_m_s: float = Field(
        0.005, ge=0, description="an ego at or below this speed has no TTC [m/s] (nuPlan: nuplan/planning/metrics/"
        "evaluation_metrics/common/time_to_collision_within_bound.py, stopped_speed_threshold of "
        "compute_time_to_collision)")
    ahead_angle_deg: float = Field(
        30.0, gt=0, lt=90, description="TTC counts road users within this angle of the ego's heading (ahead), and "
        "those not behind while the ego straddles lanes [deg] (nuPlan: nuplan/planning/simulation/observation/idm/"
        "utils.py, is_agent_ahead)")
    overspeed_scale_m_s: float = Field(
        2.23, gt=0, description="speed-limit compliance = 1 - (time integral of the overspeed) / (this x the run's "
        f"duration) [m/s] (nuPlan: {_NUPLAN_METRICS}/high_level/speed_limit_compliance_statistics.yaml, "
        "max_overspeed_value_threshold)")
    comfort: ComfortBounds = Field(default_factory=ComfortBounds, description="comfort bounds")
    weights: ScoreWeights = Field(default_factory=ScoreWeights, description="weights of the weighted mean")

    @model_validator(mode="after")
    def _ordered(self) -> ScoreSettings:
        if self.direction_violation_m < self.direction_compliance_m:
            raise ValueError("direction_violation_m must not be below direction_compliance_m")
        if self.ttc_step_s > self.ttc_horizon_s:
            raise ValueError("ttc_step_s must not exceed ttc_horizon_s")
        return self


class EvaluationSettings(BaseModel):
    """What a run is evaluated by: the cost function of its solution and the closed-loop score's
    thresholds and weights (the loop's own settings are `simgap.cosim.CosimSettings`)."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    cost_function: CostFunctionId = Field(DEFAULT_COST_FUNCTION, description=COST_FUNCTION_DESCRIPTION)
    score: ScoreSettings = Field(default_factory=ScoreSettings,
                                 description="thresholds and weights of the closed-loop score (nuPlan's defaults)")
