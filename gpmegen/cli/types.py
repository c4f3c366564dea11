"""argparse types of the command line's options: each turns one argument's text into its value,
or refuses it in one line that names the fix."""
from __future__ import annotations

import argparse
import difflib
import sys

import numpy as np

from ..errors import ModelError
from ..runtime import integrators


def _count(hint: str):
    """argparse type: a whole number ≥ 1 that fits a machine integer; ``hint`` follows a refusal."""

    def count(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{text!r} is not a whole number ({hint})") from None
        if value < 1:
            raise argparse.ArgumentTypeError(f"{value} is below 1 ({hint})")
        if value > sys.maxsize:
            raise argparse.ArgumentTypeError(f"{text} is more than any count can hold (at most {sys.maxsize})")
        return value

    return count


positive_int = _count("give a count of 1 or more")
# n_rfe: the hint is about the arm, and only there
rfe_count = _count("use 1 for a rigid link, 2 or more for a flexible one")


def finite_number(accept, problem):
    """argparse type: a finite number for which ``accept(value)`` holds, else ``problem``."""

    def parse(text: str) -> float:
        try:
            value = float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
        if not (accept(value) and value != float("inf")):
            raise argparse.ArgumentTypeError(f"{text} {problem}")
        return value

    return parse


positive_float = finite_number(lambda v: v > 0, "must be a positive finite number")
unit_interval = finite_number(lambda v: 0 <= v <= 1, "must be a number from 0 to 1")
# a GIF frame lasts a whole number of ms and at most 655 s (its delay is 16 bits of 10 ms)
frame_rate = finite_number(lambda v: 0.01 <= v <= 1000,
                            "frames per second is outside 0.01 to 1000; give e.g. --fps 20")
finite_time = finite_number(np.isfinite, "is not a finite time; give it in seconds")
end_time = finite_number(lambda v: v >= 0, "is below zero or not finite; give the end time in seconds")


def path_argument(text: str) -> str:
    """argparse type: a path, refused when empty (an empty path is not "the default")."""
    if not text.strip():
        raise argparse.ArgumentTypeError("an empty path names no file or folder; give one, or leave the argument "
                                         "out for the default")
    return text


def parameter_override(text: str):
    """argparse type: ``NAME=VALUE``, the value a number or an expression of numbers as a model
    file's parameter values are (``tdr0=2*pi``), read by the model file's expression parser."""
    from ..model.file.expressions import parse
    from ..model.requirements import evaluate

    name, sep, value = text.partition("=")
    if not sep:
        raise argparse.ArgumentTypeError(f"{text!r}: write a parameter override as NAME=VALUE")
    name = name.strip()
    unknown = f"the value of {name!r} may use numbers, pi and functions such as sqrt, not names; write e.g. 2*pi"
    try:
        number = evaluate(parse(value, {}, lambda other, scope: f"{other!r}: {unknown}"), {})
    except ModelError as exc:
        raise argparse.ArgumentTypeError(f"{text!r}: {exc}") from None
    if number is None:
        raise argparse.ArgumentTypeError(f"{text!r}: the value of {name!r} is not a finite real number")
    return name, number


def method_name(text: str) -> str:
    """argparse type: an integrator's name in any case (``DOP853`` → ``dop853``)."""
    methods = integrators.names()
    by_lower = {method.lower(): method for method in methods}
    if text.lower() in by_lower:
        return by_lower[text.lower()]
    close = difflib.get_close_matches(text.lower(), by_lower, 1)
    hint = f"; did you mean {by_lower[close[0]]}?" if close else ""
    raise argparse.ArgumentTypeError(f"{text!r} is not an integrator (choose from {', '.join(methods)}){hint}")


def figure_formats(text: str) -> tuple:
    """argparse type: comma-separated figure formats among png, pdf and svg (``png,pdf``)."""
    from ..analysis.figures.plots import FORMATS

    formats = tuple(dict.fromkeys(f.strip().lower() for f in text.split(",")))
    wrong = [f for f in formats if f not in FORMATS]
    if wrong or not formats:
        raise argparse.ArgumentTypeError(f"{text!r}: figure formats are {', '.join(FORMATS)}, separated by commas "
                                         f"(e.g. png,pdf)")
    return formats


def number_list(text: str) -> tuple:
    """argparse type: finite numbers separated by commas (``0,2.5,5``)."""
    try:
        values = tuple(float(v) for v in text.split(","))
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a list of numbers separated by commas (e.g. 0,2.5,5)") \
            from None
    if not all(np.isfinite(values)):
        raise argparse.ArgumentTypeError(f"{text!r}: every number must be finite")
    return values


def camera(text: str):
    """argparse type of animate's --view: auto, 3d, 2d, or the 3D camera's elevation and azimuth in
    degrees, ``elev,azim`` (a tuple)."""
    if text.strip().lower() in ("auto", "3d", "2d"):
        return text.strip().lower()
    try:
        values = number_list(text)
    except argparse.ArgumentTypeError:
        values = ()
    if len(values) != 2:
        raise argparse.ArgumentTypeError(f"{text!r}: give auto, 3d, 2d or the 3D camera's elevation and azimuth in "
                                         f"degrees, e.g. 20,-60")
    return values


def transform_kinds(text: str) -> tuple:
    """argparse type: the body transforms to generate, T,T_i,T_ij separated by commas, or none."""
    from ..symbolic.transforms import check_kinds

    if text.strip() == "none":
        return ()
    try:
        return check_kinds([k.strip() for k in text.split(",")])
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def input_names(text: str) -> tuple:
    """argparse type: coordinate names separated by commas."""
    names = tuple(name.strip() for name in text.split(","))
    if not all(names):
        raise argparse.ArgumentTypeError(f"{text!r} holds an empty name; give coordinates separated by commas, "
                                         f"e.g. theta1,theta2")
    return names


def sweep_param(text: str):
    """argparse type: a swept parameter, NAME=v1,v2,… | NAME=start:stop:count | NAME=low:high."""
    from ..analysis.sweep import SweepError, plan

    try:
        return plan.parse_param(text)
    except SweepError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None
