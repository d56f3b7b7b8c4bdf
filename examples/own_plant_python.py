"""Bring your own plant from Python: a ship's heading with two redundant rudders.

Nomoto's second-order steering model with a nonlinear manoeuvring term,
``psi' = r``, ``T r' = -r - a r^3 + K (delta_1 + delta_2)``, written as an ordinary Python
function. The §2.3 direct adaptive design keeps the ship on a zig-zag heading while rudder 2
jams at 5 degrees and rudder 1 loses half its effectiveness.

Run: ``python examples/own_plant_python.py``
"""

from typing import NamedTuple

import numpy as np

from adaptive_ftc import (
    ClosedLoop,
    DirectAdaptive,
    FuzzyBasis,
    LossOfEffectiveness,
    Stuck,
    simulate,
)
from adaptive_ftc.plants import plant


class ShipParams(NamedTuple):
    T: float  # time constant (s)
    K: float  # rudder gain (1/s)
    a: float  # nonlinear manoeuvring coefficient (s^2)


@plant(
    states=("psi", "r"),
    outputs={"psi": "r"},  # the heading is controlled; its rate is the state r
    actuators=("rudder1", "rudder2"),
    params=ShipParams(T=10.0, K=0.2, a=30.0),
    units=("rad", "rad/s"),
)
def ship(t, x, u, p, xdot):
    """Nomoto model with a cubic term: T r' = -r - a r^3 + K (delta_1 + delta_2)."""
    r = x[1]
    xdot[0] = r
    xdot[1] = (-r - p.a * r * r * r + p.K * (u[0] + u[1])) / p.T


loop = ClosedLoop(
    plant=ship,
    controller=DirectAdaptive(
        regressor=FuzzyBasis(
            inputs=("psi", "r"),
            centers=((-0.4, -0.2, 0.0, 0.2, 0.4), (-0.05, 0.0, 0.05)),
            width=(0.2, 0.05),  # heading and yaw rate have different scales
            normalised=False,
        ),
        lam=0.5,
        k=2.0,
        k0=0.1,
        eps0=0.01,
        gamma=20.0,
        sigma=0.001,
    ),
    allocation=(1.0, 1.0),
    reference=("0.2*sin(0.05*t)",),
    failures=(
        Stuck(actuator=2, onset=100.0, value=0.0873),  # jammed at 5 degrees
        LossOfEffectiveness(actuator=1, onset=200.0, effectiveness=0.5),
    ),
    t_final=300.0,
    name="ship heading",
)

if __name__ == "__main__":
    result = simulate(loop)
    frozen = simulate(loop.frozen())
    rms = float(result.rms_error(250, 300)[0])
    rms_frozen = float(frozen.rms_error(250, 300)[0])
    print(f"status: {result.status}")
    print(f"RMS heading error over 250-300 s: {rms:.2e} rad (adaptation frozen: {rms_frozen:.2e})")
    print(f"peak rudder command: {np.max(np.abs(result.u_cmd)):.3f} rad")
    assert result.status == "completed" and rms < 0.1 * rms_frozen
