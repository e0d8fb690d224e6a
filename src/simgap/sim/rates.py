"""Rates shared by the physics backends: how many physics steps a controller period holds, and
the acceleration a backend reports when its world only gives speeds."""

from __future__ import annotations

from simgap.errors import InputError

ACCEL_FILTER_S = 0.05       # s, time constant of the measured acceleration's low-pass filter


def steps_per_tick(physics_hz: float, controller_hz: float, field: str = "backend_settings.physics_hz",
                   allowed: str | None = None) -> int:
    """Physics steps per controller period; an `InputError` on ``field`` unless it is whole."""
    if not is_multiple(physics_hz, controller_hz):
        raise InputError(f"physics rate {physics_hz:g} Hz must be a whole multiple of the controller rate "
                         f"{controller_hz:g} Hz", field=field, allowed=allowed)
    return int(round(physics_hz / controller_hz))


def nearest_multiple(rate_hz: float, base_hz: float) -> float:
    """The whole multiple of ``base_hz`` nearest ``rate_hz`` (``base_hz`` itself at least)."""
    return base_hz * max(1, round(rate_hz / base_hz))


def is_multiple(rate_hz: float, base_hz: float) -> bool:
    """Whether ``rate_hz`` is a whole multiple of ``base_hz``."""
    ratio = rate_hz / base_hz
    return abs(ratio - round(ratio)) <= 1e-6 and round(ratio) >= 1


class SpeedRate:
    """Acceleration as the speed's rate of change between measurements, low-pass filtered with
    `ACCEL_FILTER_S`; starts from a known (t, speed, acceleration)."""

    def __init__(self, t: float, speed: float, accel: float):
        self.t, self.speed, self.accel = t, speed, accel

    def update(self, t: float, speed: float) -> float:
        """The filtered acceleration at ``t`` (a repeated ``t`` changes nothing)."""
        if t > self.t + 1e-9:
            raw = (speed - self.speed) / (t - self.t)
            self.accel += (raw - self.accel) * min(1.0, (t - self.t) / ACCEL_FILTER_S)
            self.t, self.speed = t, speed
        return self.accel
