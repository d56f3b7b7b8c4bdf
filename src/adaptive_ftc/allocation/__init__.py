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

__all__ = [
    "ALLOCATORS",
    "AdaptiveAllocation",
    "Allocator",
    "FixedAllocation",
    "PseudoInverse",
    "WeightedLeastSquares",
    "allocator_from_spec",
]
