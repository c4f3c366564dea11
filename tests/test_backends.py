"""The backend registry (gpmegen/codegen/backends): a backend is one class, found by its name, and
one written here (a JSON of M's expressions) builds a model beside the NumPy module and agrees
with its M at a random state."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import sympy as sp
from sympy.printing.str import StrPrinter

from gpmegen.analysis.run.model_files import load_model_file
from gpmegen.codegen import backends, build
from gpmegen.errors import ModelError
from gpmegen.runtime.loader import OPENERS
from gpmegen.runtime.numpy_module import import_numpy_module

MODELS = Path(__file__).parent / "models"


class JsonMassMatrix(backends.Backend):
    """The mass matrix as SymPy's text of each intermediate and entry, in a JSON file: the whole
    of a backend, as the recipe of docs/architecture.md gives it."""

    name = "json-mass"
    files = ("mass_matrix.json",)
    folder = True

    def printer(self, parameters, signals=()):
        return StrPrinter()

    def write(self, env, functions, context):
        fn = next(f for f in functions if f.function.name == "mass_matrix")
        (out, values), = fn.outputs
        text = json.dumps({"coordinates": list(context["coordinates"]), "q": fn.q_used, "body": fn.body,
                           "shape": out.shape, "M": values}, indent=1)
        return {"mass_matrix.json": text + "\n"}


@pytest.fixture
def json_backend():
    backend = backends.register(JsonMassMatrix())
    yield backend
    backends.unregister(backend.name)


def evaluate(record: dict, q, parameters: dict) -> np.ndarray:
    """M of the JSON ``record`` at ``q``: each intermediate read by SymPy's parser and evaluated
    in order, every name bound to a symbol of its own (a parameter named like a SymPy function
    stays a symbol)."""
    values = {name: sp.Float(value) for name, value in parameters.items()}
    values.update({name: sp.Float(q[j]) for j, name in record["q"]})

    def value(code):
        expr = sp.parse_expr(code, local_dict={name: sp.Symbol(name) for name in values})
        return sp.N(expr.xreplace({sp.Symbol(name): v for name, v in values.items()}), 17)

    for name, code in record["body"]:
        values[name] = value(code)
    return np.array([float(value(code)) for code in record["M"]]).reshape(record["shape"])


def test_a_backend_written_as_one_class_builds_the_mass_matrix_of_the_numpy_module(json_backend, tmp_path):
    model = load_model_file(MODELS / "two_link_traced.toml")
    result = build(model, tmp_path, backends=("numpy", json_backend.name))
    assert set(result.files) == {"model_numpy.py", "mass_matrix.json", "manifest.json"}
    record = json.loads((result.folder / "mass_matrix.json").read_text())
    module = import_numpy_module(result.folder)
    rng = np.random.default_rng(7)
    q = rng.uniform(-np.pi, np.pi, len(module.COORDINATES))
    p = np.array(module.DEFAULTS) * rng.uniform(0.5, 2.0, len(module.DEFAULTS))
    expected = module.mass_matrix(q, p)
    assert not np.allclose(module.mass_matrix(q[::-1], p), expected)   # coordinates read in a wrong order would show
    np.testing.assert_allclose(evaluate(record, q, dict(zip(module.PARAMETERS, p))), expected,
                               rtol=1e-12, atol=1e-12)
    # and the folder with the backend's file is one gpmegen may build again
    again = build(model, tmp_path, backends=("numpy", json_backend.name), force=True)
    assert again.files == result.files


def test_an_unknown_backend_is_refused_in_one_line_naming_the_known_ones():
    with pytest.raises(ModelError) as caught:
        backends.get("julia")
    assert str(caught.value) == "unknown backend 'julia'; known backends: numpy, c, casadi, fmu"


def test_an_export_is_not_rendered_into_a_folder(tmp_path):
    model = load_model_file(MODELS / "two_link_traced.toml")
    with pytest.raises(ModelError) as caught:
        build(model, tmp_path, backends=("numpy", "casadi"))
    assert str(caught.value) == ("the casadi backend is an export, not a part of a model's folder; write it with "
                                 "'gpmegen export --format casadi'")
    assert not (tmp_path / model.name).exists()


def test_the_runtime_opens_the_backends_codegen_says_it_opens():
    assert tuple(OPENERS) == tuple(name for name in backends.names() if backends.get(name).opened)
    assert backends.folder_files() == {"model_numpy.py", "model.h", "model.c"}


def test_a_name_is_registered_once(json_backend):
    with pytest.raises(ValueError, match="empty or taken"):
        backends.register(JsonMassMatrix())
