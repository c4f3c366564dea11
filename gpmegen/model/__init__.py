"""Plain-data description of open kinematic chains with rigid and flexible links."""

from .chain import (
    Body,
    Chain,
    Closure,
    Constraint,
    Controller,
    Drive,
    FlexibleLink,
    ForceElement,
    Joint,
    Model,
    Motor,
    Offset,
    Parameter,
    Point,
    SeriesElastic,
    Signal,
)
from .reference import reference_model

__all__ = [
    "Body", "Chain", "Closure", "Constraint", "Controller", "Drive", "FlexibleLink", "ForceElement", "Joint",
    "Model", "Motor", "Offset", "Parameter", "Point", "SeriesElastic", "Signal", "reference_model",
]
