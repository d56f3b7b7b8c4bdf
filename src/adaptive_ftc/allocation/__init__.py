"""Control allocation: from the design's virtual control to actuator commands."""

from adaptive_ftc.allocation.allocators import (
    ALLOCATORS,
    AdaptiveAllocation,
    Allocator,
    FixedAllocation,
    PseudoInverse,
    WeightedLeastSquares,
    allocator_from_spec,
)
from adaptive_ftc.allocation.inloop import Annunciation
from adaptive_ftc.allocation.reachable import (
    Reachability,
    ReachabilityEvent,
    reachability,
    reachability_timeline,
)

__all__ = [
    "ALLOCATORS",
    "AdaptiveAllocation",
    "Allocator",
    "Annunciation",
    "FixedAllocation",
    "PseudoInverse",
    "Reachability",
    "ReachabilityEvent",
    "WeightedLeastSquares",
    "allocator_from_spec",
    "reachability",
    "reachability_timeline",
]
