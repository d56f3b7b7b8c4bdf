"""Plants of the thesis: one module per plant and the :class:`Plant` interface."""

from adaptive_ftc.plants.base import Plant
from adaptive_ftc.plants.custom import CustomPlant, ExpressionPlant, check_plant, plant
from adaptive_ftc.plants.hypersonic import HypersonicAngleOfAttack
from adaptive_ftc.plants.manipulator import TwoLinkManipulator
from adaptive_ftc.plants.pendulum import Pendulum
from adaptive_ftc.plants.spacecraft import FlexibleSpacecraft
from adaptive_ftc.plants.wingrock import WingRock

#: Registered plants by the name used in scenario files.
PLANTS: dict[str, type[Plant]] = {
    "hypersonic": HypersonicAngleOfAttack,
    "wingrock": WingRock,
    "manipulator": TwoLinkManipulator,
    "spacecraft": FlexibleSpacecraft,
    "pendulum": Pendulum,
    "equations": ExpressionPlant,
}

__all__ = [
    "PLANTS",
    "CustomPlant",
    "ExpressionPlant",
    "check_plant",
    "plant",
    "FlexibleSpacecraft",
    "HypersonicAngleOfAttack",
    "Pendulum",
    "Plant",
    "TwoLinkManipulator",
    "WingRock",
]
