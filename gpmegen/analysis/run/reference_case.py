"""The paper's case: the reference manipulator and its scenario.

Its start is the model's own declaration (:func:`gpmegen.model.reference.start_constants`, as a
model file's ``[initial] set``): the locked statics at ``θ1 = 0, ψ2 = 45°, x3 = 0`` set
``r_E,a`` and ``y_c``, so the motion starts on the constraints and at rest. It starts from those
statics only: ``start="constrained"`` then moves to the equilibrium of the constrained system
itself (no jolt when the joints are freed). Its runs are labelled as the model presents them
(:func:`gpmegen.model.reference.presentation`: rigid or flexible, the prescribed height of E, the
paper's figures), as any case's are (:meth:`Case.metadata`).
"""

from __future__ import annotations

from functools import cached_property
from pathlib import Path

import numpy as np

from ...codegen.render import input_hash
from ...folder import START
from ...model import reference_model
from ...model.reference import start_constants
from ...model.size import coordinate_count
from ...runtime import statics
from ...runtime.consistent import consistent, project_onto_constraints
from ...runtime.loader import BACKENDS
from . import set_at_start
from .cases import Case


def joint_start(model) -> np.ndarray:
    """q with the joints at the paper's start and the flexible coordinates zero."""
    return set_at_start.configuration(start_constants(), model)


def initial_state(model, start="locked", overrides=None, declared=None):
    """The model with the parameters its start sets bound (``declared``, default the paper's
    :func:`start_constants`), and the start configuration q0 (n,): their locked statics.

    ``overrides``: parameter values given by the user; an explicit one of those set is kept and
    the start is moved onto the constraints it defines."""
    declared = declared or start_constants()
    overrides = dict(overrides or {})
    model, q = set_at_start.bind(declared, model, overrides)
    if set(declared.names) & overrides.keys():
        q = project_onto_constraints(model, q, hint=set_at_start.reach_hint(declared))
    if start == "constrained":
        q = statics.constrained(model, q)
    elif start != "locked":
        raise ValueError(f"unknown start {start!r}: use 'locked' or 'constrained'")
    return model, q


class ReferenceCase(Case):
    """The paper's manipulator with its arm cut into ``nrfe`` rfes (1: rigid)."""

    starts = ("locked", "constrained")
    start_refusal = ("--statics none is for model files; the reference case starts from statics "
                     "(--statics locked or constrained)")

    def __init__(self, nrfe: int = 5):
        self.nrfe = nrfe

    @classmethod
    def of_manifest(cls, manifest) -> ReferenceCase | None:
        """The reference case whose generated code the folder of ``manifest`` (a built folder's
        manifest.json) holds, or None: the one with as many coordinates as the folder's
        (``n_dof``), when its input hash is the folder's. The model's name is not read: a model
        of another's called like the reference arm is not taken for it."""
        n_dof = manifest.get("n_dof")
        if type(n_dof) is not int:
            return None
        # each rfe beyond the first adds as many coordinates as the second does
        rigid = coordinate_count(reference_model(1))
        extra, rest = divmod(n_dof - rigid, coordinate_count(reference_model(2)) - rigid)
        if extra < 0 or rest:
            return None
        case = cls(extra + 1)
        return case if input_hash(case.model, BACKENDS) == manifest.get("input_hash") else None

    @cached_property
    def model(self):
        return reference_model(self.nrfe)

    def record_start(self, folder) -> None:
        """None: the folder runs the paper's scenario (:func:`~gpmegen.analysis.run.opening.case_of_path`
        opens it as the reference case), so a start a model file's build left there is removed."""
        (Path(folder) / START).unlink(missing_ok=True)

    @property
    def command(self) -> str:
        return f"gpmegen build --nrfe {self.nrfe}"

    @property
    def label(self) -> str:
        return f"n_rfe = {self.nrfe}"

    @property
    def name(self) -> str:
        return f"nrfe{self.nrfe}"

    @property
    def results_stem(self) -> str:
        return f"run_{self.name}"

    def start(self, backend, start, overrides, progress):
        """The loaded model with the parameters its start sets bound, at rest at q0 (see
        :func:`initial_state`), as a :class:`gpmegen.runtime.consistent.Start`."""
        declared = self.model.start_constants
        model = self.load(backend, {k: v for k, v in overrides.items() if k not in declared.names}, progress)
        progress(f"statics ({start} start) for n_rfe = {self.nrfe}")
        model, q = initial_state(model, start, overrides, declared)
        return consistent(model, q, np.zeros(model.n_dof), hint=set_at_start.reach_hint(declared),
                          given_qd=frozenset())

    def shown(self, model) -> list[str]:
        return [name for name, _ in self.model.start_constants.at]

    def locator(self) -> dict:
        return {"reference": self.nrfe}
