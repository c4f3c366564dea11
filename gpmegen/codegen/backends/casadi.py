"""The model's functions as CasADi functions (``gpmegen export --format casadi``).

The derivation's functions are printed once more, by :class:`gpmegen.codegen.printers.CasadiPrinter`,
into Python source that builds CasADi SX expressions (``templates/model_casadi.py.j2``): the same
expressions as the NumPy and C backends, after the same common-subexpression elimination. That
source is written beside the functions it makes, each saved by CasADi's ``Function.save`` as
``<name>.casadi`` (loaded again by ``casadi.Function.load``, or :func:`load`):

- ``qdd(t, q, qd, u, p)``: the GPME's accelerations with Baumgarte terms, from the linear system
  ``M qdd - Dᵀλ = f + S u``, ``D qdd = rhs``, so that CasADi can differentiate it;
- ``M(q, p)``; ``f(t, q, qd, u, p)``: the generalized forces with the inputs' ``S u``;
- ``Phi``, ``Phi_rate``, ``D``, ``gamma`` ``(t, q, qd, p)``: the programmed constraints' terms;
- ``points(q, p)``: the named points' positions in {0}; ``energies(q, qd, p)``.

``u`` holds inputs: a generalized force on each coordinate named in ``inputs`` (an actuator
torque or force), added to the model's own drives (laws of ``t``, the parameters and, as
feedback laws, the state).
"""

from __future__ import annotations

import functools
import importlib.util
import json
import tempfile
from pathlib import Path

from ... import extras
from ...errors import GpmegenError, ModelError
from ...symbolic import derive
from ..digest import input_hash
from ..functions import lower, model_functions, prepare_all
from ..printers import CASADI, CasadiPrinter
from ..templating import model_context, template_environment
from .base import Backend

SOURCE = "model_casadi.py"
MANIFEST = "casadi.json"
#: The derivation's functions the CasADi source holds (of :func:`gpmegen.codegen.functions.model_functions`).
PRINTED = ("mass_matrix", "forces", "points", "constraint_terms", "baumgarte_gains", "energies")
#: The exported functions, each saved as ``<name>.casadi``.
EXPORTED = ("qdd", "M", "f", "Phi", "Phi_rate", "D", "gamma", "points", "energies")


class CasadiBackend(Backend):
    """The CasADi export: its source and the functions it saves, printed by :class:`CasadiPrinter`
    from ``templates/model_casadi.py.j2``; made by :func:`export`, opened by :func:`load`."""

    name = "casadi"
    files = (SOURCE, MANIFEST, *(f"{name}.casadi" for name in EXPORTED))
    refuses = ("signals", "controllers")
    made = "a CasADi export"

    def printer(self, parameters, signals=()):
        return CasadiPrinter(parameters)

    def templates(self) -> tuple[str, ...]:
        return (SOURCE + ".j2",)


def require_casadi():
    """The ``casadi`` module; MissingExtraError in one line naming the extra when it is not installed."""
    return extras.require("casadi", "the CasADi export")


def check_inputs(coordinates, inputs) -> tuple:
    """``inputs`` (coordinate names) checked against the model's ``coordinates``: each once."""
    inputs = tuple(inputs)
    for name in inputs:
        if name not in coordinates:
            raise ModelError(f"input {name!r} is not a coordinate of the model; give coordinates among "
                             f"{', '.join(coordinates)}")
    repeated = sorted({name for name in inputs if inputs.count(name) > 1})
    if repeated:
        raise ModelError(f"input {repeated[0]!r} is given twice; name each coordinate once")
    return inputs


def render_casadi(model, inputs=(), command=None) -> str:
    """The CasADi source of ``model`` with inputs on the coordinates ``inputs``."""
    CasadiBackend().check(model)
    d = derive(model)
    inputs = check_inputs(d.chain.coordinates, inputs)
    fns = [fn for fn in model_functions(d, transforms=()) if fn.name in PRINTED]
    printer, cache = CasadiBackend().printer(model.parameter_names), {}
    try:
        lowered = [lower(fn, d, printer, p, cache=cache) for fn, p in zip(fns, prepare_all(fns, d))]
    except (KeyError, ValueError, NotImplementedError) as exc:  # a function CasADi has no counterpart for
        what = str(exc).strip("'").splitlines()[0] if str(exc) else type(exc).__name__
        raise ModelError(f"model {model.name}: the CasADi export cannot print {what}; write the model with the "
                         f"functions of a model file (sin, cos, tan, exp, log, sqrt, Abs, Min, Max, atan2, "
                         f"Heaviside, Piecewise)") from None
    return template_environment().get_template(CasadiBackend().templates()[0]).render(
        functions=lowered,
        casadi=CASADI,
        inputs=inputs,
        input_indices=tuple(d.chain.coordinates.index(name) for name in inputs),
        **model_context(model, d, input_hash(model, ("casadi",), ()),
                        command or f"gpmegen export ({model.name}) --format casadi"),
    )


def module_of(source: str, name: str = "gpmegen_casadi_model"):
    """The generated CasADi source ``source`` run as a module (casadi must be installed)."""
    require_casadi()
    module = importlib.util.module_from_spec(importlib.util.spec_from_loader(name, loader=None))
    exec(compile(source, SOURCE, "exec"), module.__dict__)
    return module


def manifest(module) -> dict:
    """What the exported functions' arguments hold: the model's names in order and the defaults."""
    return {
        "model": module.MODEL,
        "gpmegen_version": module.GPMEGEN_VERSION,
        "input_hash": module.INPUT_HASH,
        "coordinates": list(module.COORDINATES),
        "parameters": list(module.PARAMETERS),
        "defaults": list(module.DEFAULTS),
        "inputs": list(module.INPUTS),
        "points": list(module.POINTS),
        "constraints": list(module.CONSTRAINTS),
        "functions": list(EXPORTED),
    }


def export(model, folder, inputs=(), command=None, overwrite=False) -> dict:
    """Write ``model``'s CasADi functions into ``folder``: the source, ``casadi.json`` (the order of
    the arguments' entries) and ``<name>.casadi`` of each of :data:`EXPORTED`. Returns the
    functions by name. ``overwrite``: replace files of an earlier export."""
    from ... import outputs
    from ...fileio import atomic_write_all

    require_casadi()
    folder = Path(folder)
    if folder.exists() and not folder.is_dir():
        raise outputs.OutputError(f"--out {folder} is a file; give a folder to write the CasADi functions into")
    targets = [folder / name for name in CasadiBackend.files]
    outputs.check(targets, (), overwrite)
    source = render_casadi(model, inputs, command)
    module = module_of(source)
    made = module.functions()
    texts = {folder / SOURCE: source.encode(),
             folder / MANIFEST: (json.dumps(manifest(module), indent=2) + "\n").encode()}
    texts.update({folder / f"{name}.casadi": saved(made[name]) for name in EXPORTED})
    atomic_write_all({path: functools.partial(_write, data) for path, data in texts.items()})
    return made


def saved(function) -> bytes:
    """What ``function.save`` writes (the format ``casadi.Function.load`` reads), as bytes."""
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "function.casadi"
        function.save(str(path))
        return path.read_bytes()


def _write(data: bytes, file) -> None:
    file.write(data)


def load(folder) -> dict:
    """The functions a CasADi export wrote into ``folder``, by name (``casadi.Function.load``)."""
    casadi = require_casadi()
    folder = Path(folder)
    missing = [name for name in EXPORTED if not (folder / f"{name}.casadi").is_file()]
    if missing:
        raise GpmegenError(f"{folder} holds no {missing[0]}.casadi; write the functions with "
                           f"'gpmegen export MODEL --format casadi --out {folder}'")
    return {name: casadi.Function.load(str(folder / f"{name}.casadi")) for name in EXPORTED}
