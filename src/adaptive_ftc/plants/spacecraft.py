"""Flexible spacecraft with six reaction wheels (thesis (3.66)-(3.77))."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import ClassVar, NamedTuple

import numpy as np

from adaptive_ftc._units import SQRT_KG_M
from adaptive_ftc.errors import ConfigurationError
from adaptive_ftc.plants.base import Plant, require_finite

__all__ = ["FlexibleSpacecraft", "SpacecraftParams", "dynamics"]

_PI = float(np.pi)


class SpacecraftParams(NamedTuple):
    """Numbers of (3.66)-(3.77): inertia ``J``, coupling ``delta`` (axes x modes, row-major),
    modal frequencies ``Lambda`` and damping ``xi``, orbital rate ``w0``, disturbance on/off."""

    J1: float
    J2: float
    J3: float
    d11: float
    d12: float
    d13: float
    d21: float
    d22: float
    d23: float
    d31: float
    d32: float
    d33: float
    l1: float
    l2: float
    l3: float
    xi1: float
    xi2: float
    xi3: float
    w0: float
    disturbance: float


def dynamics(t, x, uf, p, xdot):
    """Eqs. (3.66)-(3.77), rigid + flexible coupled, solved for ``w'`` (see the class docstring)."""
    w0 = p.w0
    dphi, dth, dpsi = x[1], x[3], x[5]
    w1 = dphi - w0 * x[4]
    w2 = dth - w0
    w3 = dpsi + w0 * x[0]
    # wheel momentum along the body axes: R hw with R = [I3 I3]
    h1 = x[12] + x[15]
    h2 = x[13] + x[16]
    h3 = x[14] + x[17]
    H1 = p.J1 * w1 + h1
    H2 = p.J2 * w2 + h2
    H3 = p.J3 * w3 + h3
    # w x H
    c1 = w2 * H3 - w3 * H2
    c2 = w3 * H1 - w1 * H3
    c3 = w1 * H2 - w2 * H1
    if p.disturbance != 0.0:  # T_d of (3.77)
        td1 = 1e-3 * (
            -3.0
            + 3.0 * math.cos(0.01 * t)
            - 4.5 * math.sin(0.02 * t)
            + 3.0 * w1 * math.cos(0.015 * t)
        )
        td2 = 1e-3 * (
            6.0
            + 4.5 * math.sin(0.01 * t)
            - 6.0 * math.cos(0.02 * t)
            - 6.0 * w2 * math.sin(0.015 * t)
        )
        td3 = 1e-3 * (
            -6.0
            + 6.0 * math.sin(0.01 * t)
            + 4.5 * math.cos(0.02 * t)
            - 3.0 * w3 * math.sin(0.015 * t)
        )
    else:
        td1 = 0.0
        td2 = 0.0
        td3 = 0.0
    # modal forcing: eta_dd = -2 xi L eta_d - L^2 eta - delta^T w_dot  =: g - delta^T w_dot
    l1, l2, l3 = p.l1, p.l2, p.l3
    g1 = -2.0 * p.xi1 * l1 * x[9] - l1 * l1 * x[6]
    g2 = -2.0 * p.xi2 * l2 * x[10] - l2 * l2 * x[7]
    g3 = -2.0 * p.xi3 * l3 * x[11] - l3 * l3 * x[8]
    d11, d12, d13 = p.d11, p.d12, p.d13
    d21, d22, d23 = p.d21, p.d22, p.d23
    d31, d32, d33 = p.d31, p.d32, p.d33
    # (J - delta delta^T) w_dot = R u + T_d - w x H - delta g
    b1 = uf[0] + uf[3] + td1 - c1 - (d11 * g1 + d12 * g2 + d13 * g3)
    b2 = uf[1] + uf[4] + td2 - c2 - (d21 * g1 + d22 * g2 + d23 * g3)
    b3 = uf[2] + uf[5] + td3 - c3 - (d31 * g1 + d32 * g2 + d33 * g3)
    a11 = p.J1 - (d11 * d11 + d12 * d12 + d13 * d13)
    a22 = p.J2 - (d21 * d21 + d22 * d22 + d23 * d23)
    a33 = p.J3 - (d31 * d31 + d32 * d32 + d33 * d33)
    a12 = -(d11 * d21 + d12 * d22 + d13 * d23)
    a13 = -(d11 * d31 + d12 * d32 + d13 * d33)
    a23 = -(d21 * d31 + d22 * d32 + d23 * d33)
    # symmetric 3x3 solve by Cramer's rule
    c11 = a22 * a33 - a23 * a23
    c12 = a13 * a23 - a12 * a33
    c13 = a12 * a23 - a13 * a22
    c22 = a11 * a33 - a13 * a13
    c23 = a12 * a13 - a11 * a23
    c33 = a11 * a22 - a12 * a12
    det = a11 * c11 + a12 * c12 + a13 * c13
    wd1 = (c11 * b1 + c12 * b2 + c13 * b3) / det
    wd2 = (c12 * b1 + c22 * b2 + c23 * b3) / det
    wd3 = (c13 * b1 + c23 * b2 + c33 * b3) / det
    xdot[0] = dphi
    xdot[1] = wd1 + w0 * dpsi
    xdot[2] = dth
    xdot[3] = wd2
    xdot[4] = dpsi
    xdot[5] = wd3 - w0 * dphi
    xdot[6] = x[9]
    xdot[7] = x[10]
    xdot[8] = x[11]
    xdot[9] = g1 - (d11 * wd1 + d21 * wd2 + d31 * wd3)
    xdot[10] = g2 - (d12 * wd1 + d22 * wd2 + d32 * wd3)
    xdot[11] = g3 - (d13 * wd1 + d23 * wd2 + d33 * wd3)
    for j in range(6):
        xdot[12 + j] = -uf[j]


@dataclass(frozen=True, kw_only=True)
class FlexibleSpacecraft(Plant):
    """Coupled rigid + flexible attitude dynamics with redundant reaction wheels.

    Simulated in full (not the decoupled design model (3.71)-(3.73)):
    ``J w' + w x (J w + R h) + delta eta'' = R u^f + T_d``,
    ``eta'' + 2 xi Lambda eta' + Lambda^2 eta + delta^T w' = 0``, ``h' = -u^f`` (wheel momenta,
    from ``u = -J_s Omega_s'``), with the small-angle kinematics (3.66)
    ``w1 = phi' - w0 psi``, ``w2 = theta' - w0``, ``w3 = psi' + w0 phi`` and ``R = [I3 I3]``
    (roll: wheels 1, 4; pitch: 2, 5; yaw: 3, 6). ``T_d`` is the disturbance (3.77).

    State: ``[phi, phi', theta, theta', psi, psi', eta1..3, eta1'..3', h1..6]`` (18 states);
    the controller uses the first six, as in the thesis.
    """

    name: ClassVar[str] = "spacecraft"
    #: UDUNITS units (adaptive_ftc._units); the modal coordinates are in sqrt(kg) m (3.67)
    units: ClassVar[tuple[str, ...]] = (
        ("rad", "rad s-1") * 3 + (SQRT_KG_M,) * 3 + (f"{SQRT_KG_M} s-1",) * 3 + ("N m s",) * 6
    )
    actuator_units: ClassVar[str] = "N m"
    equations = staticmethod(dynamics)
    # the small-angle kinematics (3.66) mean nothing beyond 90 degrees
    envelope: ClassVar[tuple[float, ...]] = (1.5707963267948966, float("inf")) * 3 + (
        float("inf"),
    ) * 12
    state_names: ClassVar[tuple[str, ...]] = (
        "phi",
        "phi_dot",
        "theta",
        "theta_dot",
        "psi",
        "psi_dot",
        "eta1",
        "eta2",
        "eta3",
        "eta1_dot",
        "eta2_dot",
        "eta3_dot",
        "h1",
        "h2",
        "h3",
        "h4",
        "h5",
        "h6",
    )
    output_names: ClassVar[tuple[str, ...]] = ("phi", "theta", "psi")
    position_index: ClassVar[tuple[int, ...]] = (0, 2, 4)
    velocity_index: ClassVar[tuple[int, ...]] = (1, 3, 5)

    inertia: tuple[float, float, float] = (973.4, 354.8, 808.5)
    coupling: tuple[tuple[float, float, float], ...] = (
        (1.0, 0.1, 0.1),
        (0.5, 0.1, 0.01),
        (-1.0, 0.3, 0.01),
    )
    modal_frequencies: tuple[float, float, float] = (0.602 * _PI, 1.088 * _PI, 1.846 * _PI)
    modal_damping: tuple[float, float, float] = (0.01, 0.01, 0.01)
    orbital_rate: float = 0.0011
    disturbance: bool = True

    def __post_init__(self) -> None:
        require_finite(
            "FlexibleSpacecraft",
            inertia=self.inertia,
            coupling=self.coupling,
            modal_frequencies=self.modal_frequencies,
            modal_damping=self.modal_damping,
            orbital_rate=self.orbital_rate,
        )
        if np.shape(self.coupling) != (3, 3):
            raise ConfigurationError(
                f"`coupling` of FlexibleSpacecraft must be 3x3 (axes x modes); got shape "
                f"{np.shape(self.coupling)}."
            )
        if len(self.inertia) != 3 or min(self.inertia) <= 0:
            raise ConfigurationError(
                f"`inertia` of FlexibleSpacecraft must be three positive numbers; got "
                f"{self.inertia}."
            )
        d = np.asarray(self.coupling, dtype=float)
        if np.min(np.linalg.eigvalsh(np.diag(self.inertia) - d @ d.T)) <= 0:
            raise ConfigurationError(
                "FlexibleSpacecraft: J - delta delta^T must be positive definite (the rigid "
                "body would have no inertia left); reduce `coupling` or raise `inertia`."
            )

    @property
    def n_actuators(self) -> int:
        return 6

    @property
    def actuator_names(self) -> tuple[str, ...]:
        return tuple(f"wheel{j + 1}" for j in range(6))

    def parameter_values(self) -> SpacecraftParams:
        return SpacecraftParams._make(  # from one flat sequence (sizes mypy cannot count)
            (
                *self.inertia,
                *np.ravel(self.coupling).tolist(),
                *self.modal_frequencies,
                *self.modal_damping,
                self.orbital_rate,
                float(self.disturbance),
            )
        )
