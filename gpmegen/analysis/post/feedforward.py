"""Feedforward: a run's inputs applied to a plant. The inputs are the run's actuated realization
``u`` (``gpmegen simulate --actuated``, or a stable inversion, ``gpmegen invert``): the generalized
force on each actuated coordinate that, added to the model's own forces, made it follow its
programmed motion (``M q̈ = f + S u``). Fed forward, each becomes a table signal of the plant
(:class:`gpmegen.model.Signal`, column ``u_<coordinate>``) added to the drive on the coordinate
of the same name (its feedback law, if it has one: feedback plus feedforward). The multipliers λ
of an ideal realization are no such inputs (their forces ``Dᵀλ`` act on every coordinate the
constraints name, elastic ones included) and are refused.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

from ...errors import ModelError
from ...model.chain import NAME_PATTERN, Drive, Signal
from ...model.expand import expand
from ...runtime import signals

#: What a plant fed forward is called (its own folder of generated code): ``<plant>_ff``.
SUFFIX = "_ff"


def inputs(run) -> tuple:
    """The coordinates the run at ``run`` (a results file) has inputs ``u`` on; ModelError in one
    line when it has none."""
    data = signals.read_results(run)
    if "u" not in data or "actuators" not in data:
        kind = "the multipliers lambda of an ideal realization" if "lambda" in data else "no inputs"
        raise ModelError(f"{run}: holds {kind}, not the inputs u of an actuated realization; make the run with "
                         f"'gpmegen simulate --actuated <coordinates>' or 'gpmegen invert', and feed that forward")
    return tuple(str(name) for name in data["actuators"])


def _free_name(base: str, taken: set) -> str:
    name, k = base, 2
    while name in taken:
        name, k = f"{base}_{k}", k + 1
    return name


def model(plant, run):
    """``plant`` (a :class:`gpmegen.model.Model`) with the inputs of the run at ``run`` added to
    its drives, each read as the table signal ``ff_<coordinate>`` (another name where that one
    is taken), and the name ``<plant>_ff``. ModelError naming the run's inputs and the plant's
    coordinates when an input acts on a coordinate the plant lacks."""
    given, run = run, Path(run).resolve()
    acting = inputs(given)
    coordinates = list(expand(plant).coordinates)
    missing = [name for name in acting if name not in coordinates]
    if missing:
        raise ModelError(f"{given}: its inputs act on {', '.join(acting)}, but the plant {plant.name} has no "
                         f"coordinate {', '.join(missing)} (its coordinates: {', '.join(coordinates)}); feed the run "
                         f"into a plant with coordinates of those names")
    taken = {p.name for p in plant.parameters} | set(coordinates) | {s.name for s in plant.signals}
    added = []
    for name in acting:
        signal = Signal(_free_name(f"ff_{name}"[:45], taken), str(run), f"u_{name}")
        taken.add(signal.name)
        added.append(signal)
    drives = {d.coordinate: d for d in plant.drives}
    for signal, name in zip(added, acting):
        law = drives[name].expression + signal.symbol if name in drives else signal.symbol
        drives[name] = Drive(name, law)
    existing = [d.coordinate for d in plant.drives]
    order = existing + [name for name in acting if name not in existing]
    renamed = plant.name[:48 - len(SUFFIX)] + SUFFIX
    if not NAME_PATTERN.fullmatch(renamed):
        raise ModelError(f"{plant.name}{SUFFIX} is no valid model name; give the plant a shorter name")
    return dataclasses.replace(plant, name=renamed, drives=tuple(drives[c] for c in order),
                               signals=plant.signals + tuple(added))
