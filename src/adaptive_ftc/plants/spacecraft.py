"""Flexible spacecraft with six reaction wheels (thesis (3.66)-(3.77))."""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from adaptive_ftc import _codes as kernel
from adaptive_ftc.errors import ConfigurationError
from adaptive_ftc.plants.base import Plant, require_finite

__all__ = ["FlexibleSpacecraft"]

_PI = float(np.pi)


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
    kind: ClassVar[int] = kernel.PLANT_SPACECRAFT
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

    def parameter_vector(self) -> np.ndarray:
        return np.array(
            [
                *self.inertia,
                *np.ravel(self.coupling),
                *self.modal_frequencies,
                *self.modal_damping,
                self.orbital_rate,
                float(self.disturbance),
            ],
            dtype=float,
        )
