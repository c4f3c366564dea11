"""What an integrator is to the rest of gpmegen: :class:`Integrator` (its name, options, checks,
run estimate and entry), its :class:`Option` s and the :class:`Effort` a run reports."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import ClassVar, NamedTuple

from ...errors import SimulationError
from ...limits import Integration
from .registry import carrying_actuated, carrying_controller_states


class Effort(NamedTuple):
    """What an integration took: steps accepted and rejected (None: not reported, as by SciPy's
    solve_ivp), GPME solves (right-hand sides), Jacobians, LU factorizations and the constraint
    evaluations of generalized-α's projection onto the constraints (its Newton iterations on Φ
    and one velocity correction a step). The compiled loops add to an int64 array of
    :data:`COUNTS` entries in this order."""

    steps: int | None
    rejected: int | None
    solves: int
    jacobians: int
    factorizations: int
    projections: int = 0

    def describe(self) -> str:
        """One phrase for a run's summary."""
        steps = "steps not reported" if self.steps is None else f"{self.steps} steps ({self.rejected} rejected)"
        projected = f", {self.projections} constraint evaluations projecting" if self.projections else ""
        return (f"{steps}, {self.solves} GPME solves, {self.jacobians} Jacobians, "
                f"{self.factorizations} LU factorizations{projected}")


#: Entries of the counts array the compiled loops add to (see :class:`Effort`): generalized-α
#: all of them, the adaptive loops (dop853, radau) all but the projection's.
COUNTS = len(Effort._fields)
ADAPTIVE_COUNTS = Effort._fields.index("projections")


@dataclass(frozen=True)
class Option:
    """A number an integrator takes beyond the run's step and save interval: the field ``name`` of
    a :class:`gpmegen.analysis.run.runspec.RunSpec` (and ``--name`` with dashes on the command
    line), its ``default`` in ``unit``, ``accept`` the check a given value passes, ``problem`` what
    the refusal says otherwise, ``kind`` the command line's parser of it ("positive": a positive
    float, "fraction": a number from 0 to 1) and ``help`` the flag's help."""

    name: str
    default: float
    unit: str
    accept: Callable[[float], bool]
    problem: str
    kind: str
    help: str

    @property
    def flag(self) -> str:
        """The command line's flag: ``--rho-inf`` for ``rho_inf``."""
        return "--" + self.name.replace("_", "-")


#: Defaults of the adaptive methods' tolerances (relative, and absolute in the units of q and q̇):
#: at these, DOP853 meets the reference case's q(10 s) to about 1e-7 (benchmarks/integrators.py).
RTOL, ATOL = 1e-8, 1e-10

#: The tolerances of the methods that choose their own steps, shared by them.
TOLERANCES = (
    Option("rtol", RTOL, "", lambda v: v > 0, "must be a positive finite number", "positive",
           "relative tolerance of the adaptive methods (default 1e-8)"),
    Option("atol", ATOL, "rad, m, rad/s, m/s", lambda v: v > 0, "must be a positive finite number", "positive",
           "absolute tolerance of the adaptive methods, in the units of q and q' (default 1e-10)"),
)


class Integrator:
    """One integrator: a subclass sets the class attributes and :meth:`run` (and :meth:`estimate`
    where its work can be said before it starts), and registers itself with
    :func:`gpmegen.runtime.integrators.register`. Its :meth:`run` is its Python entry, which
    calls its compiled :attr:`entry` where it has one."""

    #: ``--method`` name, lower case.
    name: ClassVar[str]
    #: Its phrase in ``--method``'s help: "dop853 (adaptive, order 8, in C)".
    summary: ClassVar[str]
    #: Its compiled entry: the method of :class:`gpmegen.runtime.model.LoadedModel` (and of both
    #: evaluators) that runs its loop, in C on the C backend; None: it has none.
    entry: ClassVar[str | None] = None
    #: Whether it steps with the run's ``dt`` (else it chooses its own steps to ``rtol``, ``atol``).
    fixed_step: ClassVar[bool] = True
    #: Whether it saves only at the end of its steps (no dense output), every ``save_every``-th:
    #: a save interval ``save_dt`` must then be a whole number of steps.
    saves_on_steps: ClassVar[bool] = False
    #: Whether it runs only in the generated C loop (not on the NumPy backend, nor for the actuated
    #: realization unless :attr:`actuated_loop`).
    compiled: ClassVar[bool] = False
    #: Whether, on the C backend, it runs in the generated C loop (which releases Python's lock).
    c_loop: ClassVar[bool] = False
    #: Whether that loop also runs the actuated realization (servo-constraints; the others
    #: integrate the ideal GPME only).
    actuated_loop: ClassVar[bool] = False
    #: Whether :func:`gpmegen.runtime.integrators.loop.chunked` drives it (it draws a progress bar).
    chunked: ClassVar[bool] = False
    #: Whether it integrates the controller states (a compiled loop whose Newton iterations and
    #: Jacobians hold the mechanics only does not).
    controller_states: ClassVar[bool] = True
    #: The numbers it takes beyond ``dt`` and the save interval.
    options: ClassVar[tuple[Option, ...]] = ()
    #: The natural frequency at the start its :meth:`estimate` needs: "highest" (its stable step
    #: bounds an explicit method), "lowest" (whose period an implicit step does not exceed) or None.
    frequency: ClassVar[str | None] = None
    #: Whether its steps are not bound by the stiff modes (named when an explicit method is refused).
    stiff: ClassVar[bool] = False

    def run(self, model, q0, qd0, spec, progress=None, watch=None) -> tuple:
        """Integrate ``model`` from ``q0``, ``qd0`` as ``spec`` (a RunSpec) says; ``progress``: a
        :class:`gpmegen.runtime.integrators.loop.Progress`, ``watch`` a
        :class:`gpmegen.runtime.partition.Watch`. Returns ``(t, y, outcome, effort)``: the saved
        times (k,) s, the augmented states (k, 2 n + 2 + n_z), an :class:`gpmegen.status.Outcome`
        and an :class:`Effort`."""
        raise NotImplementedError

    def estimate(self, n_dof: int, t_end: float, dt: float, omega: float | None, backend: str) -> Integration | None:
        """What its integration of ``n_dof`` coordinates to ``t_end`` (s) will take
        (:class:`gpmegen.limits.Integration`), ``dt`` the fixed step (for adaptive methods the
        save grid's unit), ``omega`` the :attr:`frequency` (rad/s; None when not computed) on
        ``backend``; None when nothing can be said before it starts."""
        return None

    def unstable_step(self, dt: float, eigenvalues: Callable[[], object]) -> str | None:
        """Why its step ``dt`` (s) would blow up on the motion linearized at the start, whose
        eigenvalues (1/s) ``eigenvalues()`` computes, or None: only an explicit fixed-step method
        has a step that can (the others call nothing)."""
        return None

    def refusal(self, backend: str, actuated: bool) -> str | None:
        """Why it cannot run on ``backend`` ("c" or "numpy") with or without an ``actuated``
        realization (one line with the fix), or None when it can."""
        if not self.compiled:
            return None
        if backend != "c":
            return f"--method {self.name} runs in the compiled C loop: use --backend c (it needs a C compiler)"
        if actuated and not self.actuated_loop:
            return (f"--method {self.name} integrates the ideal GPME only: use --method {carrying_actuated()} "
                    f"for an actuated realization")
        return None

    def check_model(self, model) -> None:
        """Refuse, in one line, a model with controller states where it does not carry them."""
        if model.controller_names and not self.controller_states:
            raise SimulationError(f"--method {self.name} does not integrate controller states (the model's "
                                  f"{', '.join(model.controller_names)}) yet: use --method "
                                  f"{carrying_controller_states()}")
