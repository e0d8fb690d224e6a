"""What produced a run — its fidelity: the backend, the vehicle(s) and, for the physics backends,
the controller. One label names it everywhere (job keys, run directories, the store, reports):
``ideal``, ``dynamic/sedan``, ``mujoco/suv``, ``mujoco/sedan/stanley`` (the default controller,
pure pursuit, is left out; several vehicles are joined by ``+``)."""

from __future__ import annotations

from dataclasses import dataclass

REFERENCE = "ideal"                  # the world of the planner's assumptions: every other is compared with it
DEFAULT_CONTROLLER = "pure_pursuit"


@dataclass(frozen=True)
class Fidelity:
    backend: str
    vehicle: str = "sedan"              # the vehicle's name (several: joined by '+')
    controller: str | None = None       # None: the backend's default (physics backends: pure pursuit)

    @property
    def label(self) -> str:
        if self.backend == REFERENCE:
            return REFERENCE
        label = f"{self.backend}/{self.vehicle}"
        return label if self.controller in (None, DEFAULT_CONTROLLER) else f"{label}/{self.controller}"

    def __str__(self) -> str:
        return self.label

    @classmethod
    def parse(cls, label: str) -> "Fidelity":
        """The fidelity a `label` names."""
        backend, _, rest = label.partition("/")
        if not rest:
            return cls(backend)
        vehicle, _, controller = rest.partition("/")
        return cls(backend, vehicle, controller or None)

    @classmethod
    def of_run(cls, run) -> "Fidelity":
        """The fidelity of a recorded `Run`."""
        vehicles = "+".join(sorted({a.vehicle for a in run.agents}))
        controller = (run.settings.get("backend") or {}).get("controller")
        return cls(run.backend, vehicles, controller)
