"""The paper's case: the reference manipulator and its scenario.

Start (reference-model.md, "Initial state"): joints at ``θ1 = 0, ψ2 = 45°, x3 = 0``, flexible
coordinates from the locked statics; ``r_E,a = sqrt(x_E² + z_E²)`` and ``y_c = y_E(0) - A``, so
the motion starts on the constraints and at rest. ``start="constrained"`` then moves to the
equilibrium of the constrained system itself (no jolt when the joints are freed). Its runs are
labelled rigid or flexible, show θ1, ψ2, x3 and the prescribed height of E, and their figures
name the paper's.
"""

from __future__ import annotations

import re
from functools import cached_property

import numpy as np

from ...codegen.render import input_hash
from ...model import reference_model
from ...runtime import statics
from ...runtime.consistent import consistent, project_onto_constraints
from ...runtime.loader import BACKENDS
from .cases import Case

START_JOINTS = {"theta1": 0.0, "psi2": np.pi / 4, "x3": 0.0}
CONSTANTS = ("r_Ea", "y_c")  # set from the locked statics unless the user gives them
REACH_HINT = "is the circle radius r_Ea or the height y_c beyond the arm's reach?"


def joint_start(model) -> np.ndarray:
    """q with the joints at the paper's start and the flexible coordinates zero."""
    q = np.zeros(model.n_dof)
    for name, value in START_JOINTS.items():
        q[model.index(name)] = value
    return q


def constraint_constants(model, q) -> dict:
    """``r_Ea`` and ``y_c`` that put E of configuration ``q`` on the programmed constraints."""
    x, y, z = model.end_effector(q)
    return {"r_Ea": float(np.hypot(x, z)), "y_c": float(y - model.params["A"])}


def with_constants(model, overrides=None):
    """``model`` with ``r_Ea`` and ``y_c`` set from its locked statics at the paper's joint start
    (those of ``overrides`` kept), and that start q (n,). What both ``gpmegen.load("manipulator", nrfe=N)``
    and a run of the reference case bind."""
    overrides = dict(overrides or {})
    q = statics.locked(model, joint_start(model))
    constants = constraint_constants(model, q)
    constants.update({k: v for k, v in overrides.items() if k in constants})
    return model.with_params(**constants), q


def initial_state(model, start="locked", overrides=None):
    """The model with its constraint constants set, and the start configuration q0 (n,).

    ``overrides``: parameter values given by the user; an explicit ``r_Ea`` or ``y_c`` is kept
    and the start is moved onto the constraints it defines."""
    overrides = dict(overrides or {})
    model, q = with_constants(model, overrides)
    if set(CONSTANTS) & overrides.keys():
        q = project_onto_constraints(model, q, hint=REACH_HINT)
    if start == "constrained":
        q = statics.constrained(model, q)
    elif start != "locked":
        raise ValueError(f"unknown start {start!r}: use 'locked' or 'constrained'")
    return model, q


class ReferenceCase(Case):
    """The paper's manipulator with its arm cut into ``nrfe`` rfes (1: rigid)."""

    starts = ("locked", "constrained")
    start_constants = CONSTANTS
    start_refusal = ("--statics none is for model files; the reference case starts from statics "
                     "(--statics locked or constrained)")

    def __init__(self, nrfe: int = 5):
        self.nrfe = nrfe

    @classmethod
    def of_manifest(cls, manifest) -> ReferenceCase | None:
        """The reference case whose generated code the folder of ``manifest`` (a built folder's
        manifest.json) holds, or None: its model's name is one :func:`reference_model` gives
        and its input hash that model's."""
        match = re.fullmatch(r"manipulator_nrfe(\d+)", str(manifest["model"]))
        if not match:
            return None
        case = cls(int(match.group(1)))
        return case if input_hash(case.model, BACKENDS) == manifest.get("input_hash") else None

    @cached_property
    def model(self):
        return reference_model(self.nrfe)

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
        """The loaded model with r_Ea and y_c set, at rest at q0 (see :func:`initial_state`), as
        a :class:`gpmegen.runtime.consistent.Start`."""
        model = self.load(backend, {k: v for k, v in overrides.items() if k not in CONSTANTS}, progress)
        progress(f"statics ({start} start) for n_rfe = {self.nrfe}")
        model, q = initial_state(model, start, overrides)
        return consistent(model, q, np.zeros(model.n_dof), hint=REACH_HINT, given_qd=frozenset())

    def bound(self, loaded, params):
        """``loaded`` with r_Ea and y_c from its locked statics (:func:`with_constants`)."""
        return with_constants(loaded, params)[0]

    def shown(self, model) -> list[str]:
        return list(START_JOINTS)

    def start_note(self, model) -> str:
        return f"; r_Ea = {model.params['r_Ea']:.6g} m, y_c = {model.params['y_c']:.6g} m"

    def constants(self, model) -> str:
        """The constraint constants set at the start, as ``statics`` prints them."""
        return f"r_Ea = {model.params['r_Ea']:.9f} m, y_c = {model.params['y_c']:.9f} m"

    def metadata(self, model) -> dict:
        rigid = self.nrfe == 1
        return {
            "label": "rigid arm" if rigid else f"flexible arm, n_rfe = {self.nrfe}",
            "joints": list(START_JOINTS),
            "joint_labels": {"theta1": "θ1 [rad]", "psi2": "ψ2 [rad]", "x3": "x3 [m]"},
            "constraint_units": {"circle": "m²", "height": "m"},
            "figures": {"joint_coordinates": "paper Fig. 2", "end_effector": "paper Fig. 3", "path": "paper Fig. 4"},
            "start_tag": r"$E'_r$" if rigid else r"$E'_f$",
            "colour": "C0" if rigid else "C2",
            # the rigid and flexible starting points lie close together: tags on opposite sides
            "tag_offset": (-22, 8) if rigid else (8, -14),
            "prescribed": {"axis": 1, "label": "prescribed y_E,a"},
        }

    def locator(self) -> dict:
        return {"reference": self.nrfe}

    def extras(self, model, results) -> dict:
        """The prescribed height of E (eq. 18) at the saved times, for the figures."""
        p = model.params
        return {"prescribed": p["y_c"] + p["A"] * np.cos(2 * np.pi * results["t"] / p["T"])}
