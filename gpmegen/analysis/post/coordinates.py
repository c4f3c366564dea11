"""What a symbolic model's coordinates and points are, by name: its joints (in chain order), its
named points, and the elastic coordinates of a loaded model (the flexible links' sdes), the
outputs that mean the same at every ``n_rfe`` and the deformation."""

from __future__ import annotations

import numpy as np

from ...model.chain import Joint, Point


def joint_names(model) -> list[str]:
    """The coordinates of the joints of a symbolic model, in chain order."""
    return [element.name for element in model.chain if isinstance(element, Joint)]


def elastic_coordinates(model, loaded) -> np.ndarray:
    """Indices of ``loaded``'s elastic coordinates: its flexible links' sde coordinates, every
    coordinate that is no joint of the symbolic ``model`` (a sprung joint is a joint, not the
    deformation)."""
    joints = set(joint_names(model))
    return np.array([k for k, name in enumerate(loaded.coordinates) if name not in joints], dtype=int)


def point_names(model) -> list[str]:
    """The named points of a symbolic model, in chain order."""
    return [element.name for element in model.chain if isinstance(element, Point)]
