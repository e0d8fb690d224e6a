"""What produced a run — its fidelity: the backend, the vehicle(s) and, for the physics backends,
the controller. One label names it everywhere (job keys, run directories, the store, reports):
``ideal``, ``dynamic/sedan``, ``mujoco/suv``, ``mujoco/sedan/stanley`` (the default controller,
pure pursuit, is left out; several vehicles are joined by ``+``), ``mujoco/sedan/ideal-car`` (a
physical world under ``realism: ideal``: a perfect machine; the default, ``real``, is left out). A run record says its own
(`simgap.cosim.Run.fidelity`). The names it is made of belong to their owners: the ideal
backend's (`REFERENCE`) to `simgap.sim`, the default controller to `simgap.control`."""

from __future__ import annotations

from dataclasses import dataclass

from simgap.control.registry import DEFAULT_CONTROLLER
from simgap.sim.protocol import REFERENCE, Realism
from simgap.vehicles import DEFAULT_VEHICLE

IDEAL_CAR = "/ideal-car"      # the label's mark of a physical world under realism: ideal


@dataclass(frozen=True)
class Fidelity:
    backend: str
    vehicle: str = DEFAULT_VEHICLE      # the vehicle's name (several: joined by '+')
    controller: str | None = None       # None: the backend's default (physics backends: pure pursuit)
    realism: Realism = Realism.REAL     # a physical world's car (the ideal world is always ideal)

    @property
    def label(self) -> str:
        if self.backend == REFERENCE:
            return REFERENCE
        label = f"{self.backend}/{self.vehicle}"
        if self.controller not in (None, DEFAULT_CONTROLLER):
            label += f"/{self.controller}"
        return label + IDEAL_CAR if self.realism is Realism.IDEAL else label

    @classmethod
    def realism_of_label(cls, label: str) -> Realism:
        return Realism.IDEAL if label.endswith(IDEAL_CAR) else Realism.REAL

    def __str__(self) -> str:
        return self.label
