"""A vehicle's tyres: Magic Formula coefficients (PAC2002 form), vertical stiffness, relaxation.

The force coefficients follow the PAC2002 Magic Formula as CommonRoad's multi-body model uses it
(`commonroad-vehicle-models`, ``vehiclemodels/utils/tire_model.py``; Pacejka, *Tire and Vehicle
Dynamics*, ch. 4): pure longitudinal and lateral slip,

    F = D sin(C atan(B x - E (B x - atan(B x)))),  D = mu F_z,  B = K / (C D),

with the peak friction mu = p_d1 + p_d2 dF_z, dF_z = (F_z - F_z0) / F_z0 (load sensitivity: a
tyre at twice its nominal load grips less than twice as hard; CommonRoad's model leaves it out,
p_d2 = 0), the slip stiffness K = p_k1 F_z (or PAC2002's degressive K_y = p_ky1 F_z0 sin(2
atan(F_z / (p_ky2 F_z0))) when ``p_ky2`` and ``nominal_load`` are given), and combined slip by the cosine
weighting functions G_x(alpha) and G_y(kappa). Slip is ISO: kappa > 0 when the wheel drives,
alpha > 0 when the contact patch moves to the tyre's left; ``p_ky1`` < 0, so the lateral force
opposes the slip.

Only the coefficients that are alike for a left and a right tyre are modelled (shape, peak,
curvature, stiffness, their load and camber^2 terms, the combined-slip weights). The shift terms that
differ between mirrored tyres — conicity, ply-steer, camber thrust (PAC2002's p_hx1, p_vx1,
p_hy*, p_vy*, r_hx1, r_hy1, r_vy*) — cancel across an axle and are left out.
"""

from __future__ import annotations

import math

from pydantic import BaseModel, ConfigDict, Field, model_validator


class MagicFormula(BaseModel):
    """PAC2002 coefficients of one tyre (dimensionless; camber in rad)."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    p_cx1: float = Field(gt=1.0, lt=2.0, description="shape factor C of the longitudinal force")
    p_dx1: float = Field(gt=0.1, lt=2.5, description="peak longitudinal friction mu_x on the reference road")
    p_dx2: float = Field(0.0, gt=-0.5, lt=0.5, description="variation of mu_x with load, per (F_z - F_z0) / F_z0")
    p_dx3: float = Field(0.0, description="variation of mu_x with camber^2")
    p_ex1: float = Field(lt=1.0, description="curvature factor E of the longitudinal force")
    p_kx1: float = Field(gt=0.0, description="longitudinal slip stiffness K_x / F_z")
    p_cy1: float = Field(gt=1.0, lt=2.0, description="shape factor C of the lateral force")
    p_dy1: float = Field(gt=0.1, lt=2.5, description="peak lateral friction mu_y on the reference road")
    p_dy2: float = Field(0.0, gt=-0.5, lt=0.5, description="variation of mu_y with load, per (F_z - F_z0) / F_z0")
    p_dy3: float = Field(0.0, description="variation of mu_y with camber^2")
    p_ey1: float = Field(lt=1.0, description="curvature factor E of the lateral force")
    p_ky1: float = Field(lt=0.0, description="cornering stiffness K_y / F_z (PAC2002 sign: negative)")
    p_ky2: float | None = Field(None, gt=0.0, description="load at which K_y peaks, / nominal_load (None: K_y = p_ky1 F_z)")
    r_bx1: float = Field(gt=0.0, description="slope factor of the combined-slip reduction of F_x")
    r_bx2: float = Field(description="variation of that slope with kappa")
    r_cx1: float = Field(gt=0.0, description="shape factor of the combined-slip reduction of F_x")
    r_ex1: float = Field(lt=1.0, description="curvature factor of the combined-slip reduction of F_x")
    r_by1: float = Field(gt=0.0, description="slope factor of the combined-slip reduction of F_y")
    r_by2: float = Field(description="variation of that slope with alpha")
    r_cy1: float = Field(gt=0.0, description="shape factor of the combined-slip reduction of F_y")
    r_ey1: float = Field(lt=1.0, description="curvature factor of the combined-slip reduction of F_y")


class Tyres(BaseModel):
    """The four (alike) tyres of a car."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    source: str = Field(description="where the coefficients come from")
    size: str = Field("", description="tyre size, for the reader (e.g. 205/55 R16)")
    magic_formula: MagicFormula
    nominal_load: float | None = Field(None, gt=0, description="F_z0 of the coefficients [N] (needed with p_ky2)")
    vertical_stiffness: float = Field(gt=1e4, lt=2e6, description="radial stiffness [N/m]")
    vertical_damping: float = Field(ge=0, description="radial damping [N s/m]")
    relaxation_length_longitudinal: float = Field(gt=0.01, lt=2.0, description="sigma_kappa: distance over which longitudinal slip builds up [m]")
    relaxation_length_lateral: float = Field(gt=0.01, lt=2.0, description="sigma_alpha: distance over which the slip angle builds up [m]")
    low_speed: float = Field(2.0, gt=0.1, le=10.0, description="below this speed [m/s] a damping term fades in, so a car at walking pace or standing is calm")

    @model_validator(mode="after")
    def _nominal_load_with_load_terms(self) -> Tyres:
        mf = self.magic_formula
        for name, needs in (("p_ky2", mf.p_ky2 is not None), ("p_dx2", mf.p_dx2 != 0.0), ("p_dy2", mf.p_dy2 != 0.0)):
            if needs and self.nominal_load is None:
                raise ValueError(f"magic_formula.{name} needs nominal_load (the F_z0 it is relative to)")
        return self

    def cornering_stiffness(self, load: float) -> float:
        """dF_y/dalpha at zero slip [N/rad] (negative, PAC2002 sign) at tyre load ``load`` [N]."""
        mf, f_z0 = self.magic_formula, self.nominal_load
        if mf.p_ky2 is not None:
            assert f_z0 is not None, "the validator requires nominal_load with p_ky2"
            return mf.p_ky1 * f_z0 * math.sin(2.0 * math.atan(load / (mf.p_ky2 * f_z0)))
        return mf.p_ky1 * load

    @property
    def peak_friction(self) -> float:
        """The larger of the longitudinal and lateral peak friction on the reference road (at the
        nominal load)."""
        return max(self.magic_formula.p_dx1, self.magic_formula.p_dy1)
