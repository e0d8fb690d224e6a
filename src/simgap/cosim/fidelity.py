"""What produced a run — its fidelity: the backend, the vehicle(s) and, for the physics backends,
the controller. One label names it everywhere (job keys, run directories, the store, reports):
``ideal``, ``dynamic/sedan``, ``mujoco/suv``, ``mujoco/sedan/stanley`` (the default controller,
pure pursuit, is left out; several vehicles are joined by ``+``). A run record says its own
(`simgap.cosim.Run.fidelity`). The names it is made of belong to their owners: the ideal
backend's (`REFERENCE`) to `simgap.sim`, the default controller to `simgap.control`."""

from __future__ import annotations

from dataclasses import dataclass

from simgap.control.registry import DEFAULT_CONTROLLER
from simgap.sim.protocol import REFERENCE
from simgap.vehicles import DEFAULT_VEHICLE


@dataclass(frozen=True)
class Fidelity:
    backend: str
    vehicle: str = DEFAULT_VEHICLE      # the vehicle's name (several: joined by '+')
    controller: str | None = None       # None: the backend's default (physics backends: pure pursuit)

    @property
    def label(self) -> str:
        if self.backend == REFERENCE:
            return REFERENCE
        label = f"{self.backend}/{self.vehicle}"
        return label if self.controller in (None, DEFAULT_CONTROLLER) else f"{label}/{self.controller}"

    def __str__(self) -> str:
        return self.label
