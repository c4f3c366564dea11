"""The status codes of the compiled GPME solve and RK4 loop, listed once: the C enum is rendered
from this one, and Python reads every status the C code returns through it."""

from enum import IntEnum


class SolveStatus(IntEnum):
    """What a compiled solve or integration returned."""

    OK = 0             # done
    SINGULAR = 1       # the GPME system is singular (D lost rank, or BᵀMB is not positive definite)
    NONFINITE = 2      # a state or a GPME term is not finite
    BAD_ARGUMENTS = 3  # the arguments of the call are invalid
