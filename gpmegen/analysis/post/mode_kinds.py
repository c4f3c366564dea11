"""The kind of a mode from its shape: the direction in which it moves the flexible links' rfes,
against gravity, not the names of the coordinates it moves (a user's ``psi`` need not bend
anything vertically, and a z-up model bends vertically about y).

Each shape ``φ`` moves every body frame by ``δT = ∂T/∂q φ`` (central differences of the generated
transforms): its origin by ``u`` (m) and its axes by the small rotation ``ω`` (rad). On an rfe,
whose x axis ``e_a`` runs along the link, with ``e_v`` the upward direction made normal to it
and ``e_h = e_a × e_v``, the shares are: vertical ``(u·e_v)² + (ℓ ω·e_h)²``, horizontal
``(u·e_h)² + (ℓ ω·e_v)²``, torsion ``(ℓ ω·e_a)²``, other (stretch) ``(u·e_a)²``, ``ℓ`` the rfe's
length (m); summed over the rfes, the largest names the mode. A mode that moves no rfe (a rigid
model, or a sprung joint beyond the links) is named by its bodies' and points' translations alone:
vertical along gravity, horizontal across it. Upward is against gravity, ``+z`` without gravity.
"""

from __future__ import annotations

import re

import numpy as np

KINDS = ("vertical", "horizontal", "torsion")
# The bodies :func:`gpmegen.model.rfem.discretize` makes: rfe<label>_<r>.
RFE = re.compile(r"^rfe(?P<label>.+)_(?P<r>\d+)$")
# The shapes are unit-modal-mass vectors (order 1 to 1e2 in rad); this step keeps the frames'
# motion linear to ~1e-12 and far above round-off.
STEP = 1e-6
# A mode moves the rfes when their share is above this fraction of all bodies' translation share.
MOVES = 1e-6


def upward(loaded) -> np.ndarray:
    """The unit vector (3,) against gravity at ``loaded``'s parameter values, from the gravity its
    model was loaded with (:func:`gpmegen.api.load` sets ``loaded.gravity``). Gravity set to zero
    for the analysis (frequencies about the unloaded arm) keeps the direction of the model's
    defaults; +z when there is none (a model without gravity, or a built folder loaded without
    its model)."""
    gravity = getattr(loaded, "gravity", None)
    if gravity is not None:
        for values in (loaded.params, dict(zip(loaded.parameter_names, loaded.module.DEFAULTS))):
            g = np.asarray(gravity(values), dtype=float)
            if np.any(g):
                return -g / np.linalg.norm(g)
    return np.array([0.0, 0.0, 1.0])


def rfe_groups(loaded) -> dict:
    """Link label → indices of its rfe bodies in :attr:`bodies` order (base first)."""
    groups = {}
    for k, name in enumerate(loaded.bodies):
        match = RFE.match(name)
        if match:
            groups.setdefault(match["label"], []).append((int(match["r"]), k))
    return {label: [k for _, k in sorted(items)] for label, items in groups.items()}


def _rotation(dR, R) -> np.ndarray:
    """The small rotation (3,) rad of ``δR`` about the frame ``R``: ``δR Rᵀ`` is skew."""
    W = dR @ R.T
    W = 0.5 * (W - W.T)
    return np.array([W[2, 1], W[0, 2], W[1, 0]])


def shares(loaded, q, shape, up=None) -> dict:
    """The vertical, horizontal, torsion and other shares (m²) of the motion ``shape`` (n,) at
    ``q`` (n,), as the module describes them."""
    up = upward(loaded) if up is None else up
    scale = STEP / max(float(np.max(np.abs(shape))), 1e-300)
    if "T" not in loaded.transforms_built:  # a folder built without its transforms: the named points alone
        moved = _point_motion(loaded, q, shape, scale)
        along = float(np.sum((moved @ up) ** 2))
        return {"vertical": along, "horizontal": float(np.sum(moved**2)) - along, "torsion": 0.0, "other": 0.0}
    T = loaded.transforms(q)
    dT = (loaded.transforms(q + scale * shape) - loaded.transforms(q - scale * shape)) / (2 * scale)
    out = dict.fromkeys(KINDS + ("other",), 0.0)
    for rfes in rfe_groups(loaded).values():
        origins = T[rfes, :3, 3]
        lengths = np.linalg.norm(np.diff(origins, axis=0), axis=1)
        lengths = np.append(lengths, lengths[-1] if len(lengths) else 0.0)
        for b, ell in zip(rfes, lengths):
            axis = T[b, :3, 0]
            normal = up - (up @ axis) * axis
            upright = np.linalg.norm(normal) < 1e-9  # a link along gravity: any bending is horizontal
            vertical = T[b, :3, 1] if upright else normal / np.linalg.norm(normal)
            across = np.cross(axis, vertical)
            u, w = dT[b, :3, 3], _rotation(dT[b, :3, :3], T[b, :3, :3])
            # a turn about ``across`` moves the rfe's far end along ``vertical``, and the reverse
            up_down = (u @ vertical) ** 2 + ell**2 * (w @ across) ** 2
            sideways = (u @ across) ** 2 + ell**2 * (w @ vertical) ** 2
            out["horizontal"] += sideways + (up_down if upright else 0.0)
            out["vertical"] += 0.0 if upright else up_down
            out["torsion"] += ell**2 * (w @ axis) ** 2
            out["other"] += (u @ axis) ** 2
    moved = np.vstack([dT[:, :3, 3], _point_motion(loaded, q, shape, scale)])
    along = moved @ up
    total = float(np.sum(moved**2))
    if sum(out.values()) <= MOVES * total:
        out = dict.fromkeys(KINDS + ("other",), 0.0)
        out["vertical"], out["horizontal"] = float(np.sum(along**2)), total - float(np.sum(along**2))
    return out


def _point_motion(loaded, q, shape, scale) -> np.ndarray:
    if not loaded.points:
        return np.zeros((0, 3))
    return ((loaded.point_positions(q + scale * shape) - loaded.point_positions(q - scale * shape))
            / (2 * scale)).reshape(-1, 3)


def classify(loaded, q, shapes) -> list[str]:
    """Kind of each mode (column of ``shapes``, (n, k)) of ``loaded`` about ``q`` (n,): 'vertical'
    or 'horizontal' bending, 'torsion', or 'other' (a stretch, or a mode that moves nothing)."""
    shapes = np.asarray(shapes, dtype=float)
    if shapes.ndim == 1:
        shapes = shapes[:, None]
    up = upward(loaded)
    kinds = []
    for col in shapes.T:
        share = shares(loaded, np.asarray(q, dtype=float), col, up)
        kinds.append(max(share, key=share.get) if any(v > 0 for v in share.values()) else "other")
    return kinds
