"""The names the integrators' modules (:mod:`gpmegen.runtime.integrators`) define, under their
former module, for the scripts and tests that import them from here; gpmegen itself imports them
from their own modules."""

from __future__ import annotations

import time  # noqa: F401 (the clock Progress reads)

from .integrators.adaptive import compiled_adaptive  # noqa: F401
from .integrators.base import ADAPTIVE_COUNTS, ATOL, COUNTS, RTOL, Effort  # noqa: F401
from .integrators.dop853 import dop853
from .integrators.genalpha import RHO_INF, genalpha  # noqa: F401
from .integrators.loop import (  # noqa: F401
    CHUNK_SECONDS,
    PROGRESS_LINES,
    SAVE_INTERVAL,
    STEP_ROUND_OFF,
    Grid,
    Progress,
    check_start,
    chunked,
    default_save_every,
    grid,
    interruptible,
    out_of_reach,
    save_steps,
    shortest_force,
    start_state,
    state_derivative,
    violation,
)
from .integrators.radau import radau
from .integrators.rk4 import LONG_STEPS, rk4, rk4_effort, rk4_steps, unstable_step  # noqa: F401
from .integrators.scipy_radau import SCIPY, adaptive, scipy_solve  # noqa: F401

#: The adaptive methods in the compiled loop, by name.
ADAPTIVE = {"dop853": dop853, "radau": radau}
