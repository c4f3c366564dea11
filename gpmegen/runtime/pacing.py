"""How many steps a compiled loop takes per call, so that its driver gets back the hand (to show
progress and to hear Ctrl-C or SIGTERM, which Python handles only between calls) every
:data:`CALL_SECONDS` of wall time, however long a step or a saved interval lasts."""

from __future__ import annotations

import time

#: Wall time (s) one call of a compiled loop aims at: a signal waits at most about this long.
CALL_SECONDS = 0.1
#: Steps of the first call, before a step's cost is known.
FIRST_STEPS = 16
#: A call takes at most this many times the steps of the one before: one fast call (a cheap
#: stretch of the motion) does not commit the next to seconds.
GROWTH = 4
#: More steps than this are never asked of one call (a C long holds them).
MOST_STEPS = 2**40


class StepBudget:
    """The steps the next call may take (:attr:`steps`), from the wall time the calls before
    took per step; ``fixed`` (steps) gives every call that many instead, for runs that must not
    depend on the machine (the results do not in any case: a loop stopped and called again goes
    on to the same bits)."""

    def __init__(self, fixed: int | None = None):
        if fixed is not None and int(fixed) < 1:
            raise ValueError(f"need at least one step per call, got {fixed}")
        self.fixed = None if fixed is None else int(fixed)
        self.steps = self.fixed or FIRST_STEPS
        self._began = time.perf_counter()

    def start(self) -> int:
        """Mark the start of a call; returns the steps it may take."""
        self._began = time.perf_counter()
        return self.steps

    def spent(self, steps: int) -> None:
        """The call started by :meth:`start` took ``steps`` steps: size the next one."""
        if self.fixed is not None or steps < 1:
            return
        seconds = time.perf_counter() - self._began
        wanted = steps * CALL_SECONDS / seconds if seconds > 0 else GROWTH * self.steps
        self.steps = int(max(1, min(wanted, GROWTH * self.steps, MOST_STEPS)))
