"""What a planner sees of its own car: the state through a localisation, not the truth (nuPlan's
"observation"). The loop asks `Localisation.observe` for an agent's state each time it plans.

A localisation's error drifts as a real estimator's does: each of position (x and y), heading and
speed carries a first-order Gauss–Markov error — correlated in time with ``correlation_time_s``,
of standard deviation ``*_drift`` in the long run — plus, if asked, white noise per observation
(``*_noise``). The estimate is ``latency_s`` old when the planner gets it: the state the car had
then, stamped now. Profiles give published accuracies of common localisations; any field can be
set over its profile's. Errors are seeded per run and agent, so a run repeats exactly.

The ideal world, and a physics world under ``realism: ideal``, observe the exact state.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from enum import Enum

import numpy as np
from pydantic import BaseModel, ConfigDict, Field

from simgap.sim.protocol import Realism
from simgap.trajectory import STATE_FIELDS, State, wrap_angle


class SensingProfile(str, Enum):
    PERFECT = "perfect"
    RTK_INS = "rtk_ins"
    LIDAR_MAP = "lidar_map"
    GNSS = "gnss"


class LocalisationAccuracy(BaseModel):
    """A localisation's errors: drifts (1-sigma, long run), their correlation time, white noise,
    and the estimate's latency."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    position_drift_m: float = Field(0.0, ge=0, le=10.0, description="drifting error on x and y, each, 1-sigma [m]")
    heading_drift_deg: float = Field(0.0, ge=0, le=10.0, description="drifting error on the heading, 1-sigma [deg]")
    speed_drift_mps: float = Field(0.0, ge=0, le=2.0, description="drifting error on the speed, 1-sigma [m/s]")
    correlation_time_s: float = Field(10.0, gt=0, le=3600.0, description="correlation time of the drifts [s]")
    position_noise_m: float = Field(0.0, ge=0, le=5.0, description="white noise on x and y, each, 1-sigma [m]")
    heading_noise_deg: float = Field(0.0, ge=0, le=30.0, description="white noise on the heading, 1-sigma [deg]")
    speed_noise_mps: float = Field(0.0, ge=0, le=5.0, description="white noise on the speed, 1-sigma [m/s]")
    latency_s: float = Field(0.0, ge=0, le=1.0, description="age of the estimate when the planner gets it [s]")
    source: str = Field("", description="where the numbers come from")

    @property
    def exact(self) -> bool:
        return not any((self.position_drift_m, self.heading_drift_deg, self.speed_drift_mps, self.position_noise_m,
                        self.heading_noise_deg, self.speed_noise_mps, self.latency_s))


PROFILES: dict[SensingProfile, LocalisationAccuracy] = {
    SensingProfile.PERFECT: LocalisationAccuracy(source="the exact state (the ideal world's assumption)"),
    SensingProfile.RTK_INS: LocalisationAccuracy(
        position_drift_m=0.02, heading_drift_deg=0.1, speed_drift_mps=0.02, correlation_time_s=10.0, latency_s=0.005,
        source="RTK-GNSS aided inertial navigation as AV test vehicles carry (OxTS RT user manuals: 1-2 cm RTK "
               "position, dual-antenna heading 0.2 deg per metre of antenna separation, i.e. 0.1 deg at 2 m; outputs at "
               "100-250 Hz, 3.5 ms latency); speed drift and correlation time estimated"),
    SensingProfile.LIDAR_MAP: LocalisationAccuracy(
        position_drift_m=0.10, heading_drift_deg=0.3, speed_drift_mps=0.05, correlation_time_s=5.0, latency_s=0.1,
        source="lidar scan matching against a prior map (Levinson and Thrun, ICRA 2010: about 0.1 m RMS lateral "
               "error), one 10 Hz scan old when it is used; heading, speed and correlation time estimated"),
    SensingProfile.GNSS: LocalisationAccuracy(
        position_drift_m=2.1, heading_drift_deg=0.3, speed_drift_mps=0.05, correlation_time_s=60.0, latency_s=0.1,
        source="single-frequency GNSS receiver without corrections (u-blox M8 class datasheet: 2.5 m CEP "
               "horizontal, i.e. 2.1 m 1-sigma per axis; 0.05 m/s speed, 0.3 deg heading of motion; 10 Hz); "
               "correlation time estimated"),
}
DEFAULT_PROFILE = SensingProfile.RTK_INS


class SensingSettings(BaseModel):
    """The localisation each planner observes its car through in a physical world: a profile, with
    any of its fields set over it."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    profile: SensingProfile = Field(DEFAULT_PROFILE, description="perfect, rtk_ins, lidar_map or gnss")
    position_drift_m: float | None = Field(None, ge=0, le=10.0, description="over the profile's [m]")
    heading_drift_deg: float | None = Field(None, ge=0, le=10.0, description="over the profile's [deg]")
    speed_drift_mps: float | None = Field(None, ge=0, le=2.0, description="over the profile's [m/s]")
    correlation_time_s: float | None = Field(None, gt=0, le=3600.0, description="over the profile's [s]")
    position_noise_m: float | None = Field(None, ge=0, le=5.0, description="white noise over the profile's [m]")
    heading_noise_deg: float | None = Field(None, ge=0, le=30.0, description="white noise over the profile's [deg]")
    speed_noise_mps: float | None = Field(None, ge=0, le=5.0, description="white noise over the profile's [m/s]")
    latency_s: float | None = Field(None, ge=0, le=1.0, description="over the profile's [s]")

    def accuracy(self) -> LocalisationAccuracy:
        """The profile's accuracy with the fields that are set over it."""
        changes = {k: v for k, v in self.model_dump(exclude={"profile"}).items() if v is not None}
        return PROFILES[self.profile].model_copy(update=changes)


def localisation_accuracy(settings: SensingSettings, realism: Realism) -> LocalisationAccuracy:
    """How exactly a planner sees its car: as ``settings`` say in a world of realism real, else exactly."""
    return settings.accuracy() if realism is Realism.REAL else PROFILES[SensingProfile.PERFECT]


class Localisation:
    """One agent's localisation in one run (see the module doc)."""

    def __init__(self, accuracy: LocalisationAccuracy, rng: np.random.Generator):
        self.accuracy, self.rng = accuracy, rng
        a = accuracy
        self._sigma = np.array([a.position_drift_m, a.position_drift_m, math.radians(a.heading_drift_deg),
                                a.speed_drift_mps])
        self._white = np.array([a.position_noise_m, a.position_noise_m, math.radians(a.heading_noise_deg),
                                a.speed_noise_mps])
        self._drift: np.ndarray | None = None
        self._t = 0.0

    def observe(self, history: Sequence[State], t: float) -> State:
        """The state the planner gets at ``t``: the driven ``history`` (its last state at ``t``) as
        it was ``latency`` ago, stamped ``t``, with the localisation's errors."""
        a = self.accuracy
        if a.exact:
            return history[-1]
        true = _state_ago(history, a.latency_s).replace(t=t)
        drift = self._drift_at(t)
        error = drift + self._white * self.rng.standard_normal(4) if self._white.any() else drift
        return true.replace(x=true.x + error[0], y=true.y + error[1], yaw=wrap_angle(true.yaw + error[2]),
                            v=max(0.0, true.v + error[3]))

    def _drift_at(self, t: float) -> np.ndarray:
        """The drifting errors at ``t``: from the stationary distribution at the first observation,
        then each a Gauss–Markov step from the last."""
        if self._drift is None:
            self._drift = self._sigma * self.rng.standard_normal(4)
        else:
            decay = math.exp(-max(t - self._t, 0.0) / self.accuracy.correlation_time_s)
            self._drift = decay * self._drift + self._sigma * math.sqrt(1.0 - decay * decay) * self.rng.standard_normal(4)
        self._t = t
        return self._drift


def _state_ago(history: Sequence[State], age: float) -> State:
    """The state ``age`` seconds before the last of ``history`` (linear between recorded states,
    the heading on the circle; the first state where the history is shorter)."""
    last = history[-1]
    if age <= 0.0 or len(history) == 1:
        return last
    when = last.t - age
    k = len(history) - 1
    while k > 0 and history[k - 1].t > when:
        k -= 1
    if k == 0:
        return history[0]
    before, after = history[k - 1], history[k]
    w = (when - before.t) / (after.t - before.t)
    values = {f: getattr(before, f) + w * (getattr(after, f) - getattr(before, f)) for f in STATE_FIELDS}
    values["yaw"] = wrap_angle(before.yaw + w * wrap_angle(after.yaw - before.yaw))
    return State(**values)


def profile_table() -> str:
    """The sensing profiles as a Markdown table (the docs' page on the real car)."""
    rows = ["| profile | position drift [m] | heading drift [deg] | speed drift [m/s] | correlation [s] | "
            "estimate latency [s] | source |", "|---|---|---|---|---|---|---|"]
    rows += [f"| `{name.value}` | {a.position_drift_m:g} | {a.heading_drift_deg:g} | {a.speed_drift_mps:g} | "
             f"{a.correlation_time_s:g} | {a.latency_s:g} | {a.source} |" for name, a in PROFILES.items()]
    return "\n".join(rows)
