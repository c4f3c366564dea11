"""How a solve or a run ended, listed once.

:class:`SolveStatus` holds the status codes of the compiled GPME solve and RK4 loop (the C enum is
rendered from it) and of the NumPy loop, which returns the same codes; :data:`MESSAGES` says what
each failure means and what to do. :class:`Outcome` is how a whole integration ended.
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import Enum, IntEnum


class SolveStatus(IntEnum):
    """What a compiled solve or integration returned."""

    OK = 0             # done
    SINGULAR = 1       # the GPME system is singular (D lost rank, or BᵀMB is not positive definite)
    NONFINITE = 2      # a state or a GPME term is not finite
    BAD_ARGUMENTS = 3  # the arguments of the call are invalid
    STEP_TOO_SMALL = 4  # an adaptive step fell to the round-off of t
    NO_CONVERGENCE = 5  # the Newton iterations of an implicit step did not converge


#: What a failed solve or step means for a run, and the fix.
MESSAGES = {
    SolveStatus.SINGULAR: "singular GPME system (D or BᵀMB); either the motion blew up (try a smaller --dt) or the "
                          "constraints are not independent there (their Jacobian D lost rank: keep the prescribed "
                          "motion away from such configurations)",
    SolveStatus.NONFINITE: "non-finite state; try a smaller --dt (the flexible modes bound the RK4 step) or check "
                           "the parameters",
    SolveStatus.BAD_ARGUMENTS: "invalid arguments",
    SolveStatus.STEP_TOO_SMALL: "the adaptive step fell to the round-off of t (the motion is singular there, or the "
                                "tolerances cannot be met in double precision); try a larger --rtol/--atol",
    SolveStatus.NO_CONVERGENCE: "the Newton iterations of an implicit step did not converge, even with a fresh "
                                "Jacobian; try a smaller --dt",
}


class Ending(Enum):
    """How an integration ended."""

    COMPLETE = "complete"
    INTERRUPTED = "interrupted"  # Ctrl-C or SIGTERM
    DIVERGED = "diverged"


@dataclass(frozen=True)
class Outcome:
    """How an integration ended: ``ending``, the time ``t`` (s) of the last state computed and,
    when it diverged, ``why`` (the cause and the fix). ``str()`` is the text a results file
    stores: ``complete``, ``interrupted`` or ``diverged: <why>``."""

    ending: Ending
    t: float
    why: str = ""

    @property
    def complete(self) -> bool:
        return self.ending is Ending.COMPLETE

    @classmethod
    def diverged(cls, t: float, why: str) -> Outcome:
        return cls(Ending.DIVERGED, float(t), why)

    @classmethod
    def failed(cls, t: float, status: SolveStatus) -> Outcome:
        """The run stopped after ``t`` (s) because a step returned ``status``."""
        return cls.diverged(t, f"after t = {float(t):.6g} s, {MESSAGES[SolveStatus(status)]}")

    def __str__(self) -> str:
        return f"diverged: {self.why}" if self.ending is Ending.DIVERGED else self.ending.value
