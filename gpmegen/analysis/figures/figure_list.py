"""The figures that ``gpmegen plot`` and ``gpmegen demo`` write, in the order they are drawn:
one list, read by the code that draws them (:func:`gpmegen.analysis.figures.run_figures.figures`) and by the
help pages (:mod:`gpmegen.help_pages`), so that what a command says it writes is what it writes.

Kept free of imports (no NumPy, no Matplotlib): the help pages are built at every start of the
command line.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass


@dataclass(frozen=True)
class Figure:
    """One figure: its file name without extension, what it shows, when it is drawn (``None``:
    always) and the test of that on the runs drawn together (results dicts); ``reference``: one
    of the tracking metrics against ``plot --reference`` (:mod:`gpmegen.analysis.run.tracking`)."""

    stem: str
    shows: str
    when: str | None
    applies: Callable[[list], bool]
    reference: bool = False   # drawn by ``plot --reference`` from the runs' metrics, not by run_figures


def _always(runs) -> bool:
    return True


def _constraints(runs) -> bool:
    return len(runs[0]["constraint_names"]) > 0


def _energies(runs) -> bool:
    return all("kinetic_energy" in r for r in runs)


def _driving(runs) -> bool:
    return all("constraint_forces" in r and "drive_forces" in r for r in runs)


def _deformation(runs) -> bool:
    return _driving(runs) and any("spring_forces" in r and r["spring_forces"].any() for r in runs)


def _multipliers(runs) -> bool:
    return _driving(runs) and any("lambda" in r for r in runs)


def _closures(runs) -> bool:
    return _multipliers(runs) and any(str(key).startswith("closure_") for r in runs for key in r)


def _forces(runs) -> bool:
    names = [tuple(str(n) for n in r["force_names"]) if "force_names" in r else () for r in runs]
    return bool(names[0]) and all(n == names[0] for n in names)


def _law(runs) -> bool:
    return any("tracking_error" in r for r in runs)


def _controlled(runs) -> bool:
    """A run under control: inputs u (actuated realization), a computed-torque law, or drives on
    a plant without programmed constraints (its controllers alone move it); an ideal run's drives
    beside its constraints' reactions are the driving functions' figure."""
    return any("u" in r or "tracking_error" in r
               or (not len(r["constraint_names"]) and "drive_forces" in r and r["drive_forces"].any()) for r in runs)


FIGURES = (
    Figure("joint_coordinates", "the joint coordinates against time", None, _always),
    Figure("end_effector", "the coordinates of the end-effector against time", None, _always),
    Figure("path", "the path of the end-effector", None, _always),
    Figure("constraint_violation", "the largest |Φ| of each constraint in windows of the run",
           "when the model has programmed constraints", _constraints),
    Figure("energy_balance", "each energy term, the work of drive, constraints and dampers, and the residual",
           "when the results hold the energies", _energies),
    Figure("force_elements", "each force element's length, rate and force against time",
           "when the model has forces between points ([[forces]]) and the runs the same ones", _forces),
    Figure("driving_functions", "drive plus the constraints' reaction on each joint",
           "when the results hold the driving functions", _driving),
    Figure("elastic_deformation", "the deflection of the end-effector and the moments at the sdes",
           "when a run's springs carry load: flexible links", _deformation),
    Figure("constraint_multipliers", "the multipliers λ and the force on the constrained point",
           "when the results hold the multipliers", _multipliers),
    Figure("closure_reactions", "each closed loop's reaction force (and moment) in {0}",
           "when the model closes loops ([[closures]])", _closures),
    Figure("tracking_error", "each computed-torque coordinate's reference less the coordinate, q_r − q",
           "when a run holds them: a [controller] table", _law),
    Figure("control_effort", "each drive's force (and input u) against time, its peak marked",
           "when a run is controlled: inputs u, a [controller] table, or drives on a model without programmed "
           "constraints", _controlled),
    Figure("tracking", "the end-effector's path error |E − E_ref| against time, beside metrics.csv and "
           "metrics.md (the table of 'gpmegen metrics')", "with plot --reference REF", _always, reference=True),
)


def stems(runs) -> list[str]:
    """The stems of the figures drawn for ``runs``, in order (those of ``--reference`` apart)."""
    return [figure.stem for figure in FIGURES if not figure.reference and figure.applies(runs)]


def listing(indent: str = "  ", width: int = 96) -> str:
    """The figures as the help pages list them: one item per figure, with when it is drawn."""
    import textwrap

    return "\n".join(textwrap.fill(f"{figure.stem}: {figure.shows}" + (f" ({figure.when})" if figure.when else ""),
                                   width, initial_indent=indent, subsequent_indent=indent + "  ")
                     for figure in FIGURES)
