"""The CasADi export (gpmegen export --format casadi): its functions against the generated NumPy
model, the derivative CasADi takes of the accelerations against central differences of NumPy's,
the saved files in a fresh process, and user text and names that must not change the code."""

from __future__ import annotations

import dataclasses
import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import sympy as sp
from conftest import stacked_gpme
from hypothesis import HealthCheck, example, given, settings
from precise_solve import EPS
from test_trust_codegen import COLLIDING, NEUTRAL, _named_model, _python_code, _tiny_model, free_text

import gpmegen
from gpmegen.analysis.post.coordinates import elastic_coordinates
from gpmegen.analysis.run.model_files import load_model_file
from gpmegen.cli import main
from gpmegen.codegen import input_hash
from gpmegen.codegen.backends import casadi as casadi_export
from gpmegen.errors import ModelError
from gpmegen.model import reference_model
from gpmegen.model.chain import TIME
from gpmegen.runtime import gpme

casadi = pytest.importorskip("casadi")

ROOT = Path(__file__).resolve().parents[1]
PLANAR = ROOT / "examples" / "planar_two_link.toml"


def _casadi_functions(model, inputs=()):
    return casadi_export.module_of(casadi_export.render_casadi(model, inputs)).functions()


def _planar(nrfe=2):
    return load_model_file(PLANAR, nrfe=nrfe)


@pytest.fixture(scope="module")
def cases(tmp_path_factory):
    """(name, NumPy model, CasADi functions, inputs) of the reference arm (n_rfe 2, constraints of
    orders 0 and 1) and the planar two-link arm (n_rfe 2, two position constraints)."""
    directory = tmp_path_factory.mktemp("generated")
    made = []
    for name, model, inputs in (("reference", reference_model(2), ("theta1", "psi2")),
                                ("planar", _planar(), ("theta1",))):
        loaded = gpmegen.load(model=model, backend="numpy", directory=directory)
        made.append((name, loaded, _casadi_functions(model, inputs), inputs, elastic_coordinates(model, loaded)))
    return made


def _states(model, elastic, rng, k=4):
    """``k`` states ``(t, q, qd, scale of the inputs)``: joints within 0.3 (rad or m) and their rates
    within 1, the links' deformation within 1e-3 rad and its rates within 0.1 rad/s."""
    size = np.where(np.isin(np.arange(model.n_dof), elastic), 1e-3, 0.3)
    for _ in range(k):
        yield (rng.uniform(0, 2), size * rng.uniform(-1, 1, model.n_dof), size / 0.3 * rng.uniform(-1, 1, model.n_dof),
               rng.uniform(-2, 2))


def _numpy_qdd(model, inputs, t, q, qd, u):
    """The GPME's accelerations of the NumPy model with the inputs ``u`` added to its forces on
    the coordinates ``inputs``."""
    M, f, phi, phi_rate, D, gamma = model.gpme_terms(t, q, qd)
    f = f + gpme.selection(model.n_dof, [model.index(name) for name in inputs]) @ u
    part = model.partitioned(t, q)
    return gpme.accelerations(M, f, phi, phi_rate, D, gamma, model.alpha, model.beta, model.constraint_orders,
                              part.dependent, part.independent)


def _value(x):
    """A CasADi value (DM) as a NumPy array of its shape."""
    return x.full() if isinstance(x, casadi.DM) else np.asarray(x, float)


def _close(got, expected, rtol):
    got, expected = _value(got), np.asarray(expected, float)
    if expected.ndim == 1:  # a vector: CasADi's is a column
        assert got.shape == expected.shape + (1,) or got.shape == expected.shape
        got = got.reshape(expected.shape)
    assert got.shape == expected.shape
    scale = np.abs(expected).max() if expected.size else 0.0
    assert np.abs(got - expected).max(initial=0.0) <= rtol * scale, (got, expected)


def test_functions_equal_the_numpy_model(cases):
    rng = np.random.default_rng(3)
    for name, model, fns, inputs, elastic in cases:
        assert model.constraint_names, name  # both cases hold constraints
        for t, q, qd, scale in _states(model, elastic, rng):
            u = scale * rng.uniform(-1, 1, len(inputs))
            p = model.p
            M, f, phi, phi_rate, D, gamma = model.gpme_terms(t, q, qd)
            S = gpme.selection(model.n_dof, [model.index(k) for k in inputs])
            _close(fns["M"](q, p), M, 1e-12)
            _close(fns["f"](t, q, qd, u, p), f + S @ u, 1e-12)
            _close(fns["Phi"](t, q, qd, p), phi, 1e-12)
            _close(fns["Phi_rate"](t, q, qd, p), phi_rate, 1e-12)
            _close(fns["D"](t, q, qd, p), D, 1e-12)
            _close(fns["gamma"](t, q, qd, p), gamma, 1e-12)
            _close(fns["points"](q, p), model.point_positions(q), 1e-12)
            _close(fns["energies"](q, qd, p), model.energies(q, qd), 1e-12)
            # qdd solves the stacked GPME to round-off (backward error), and agrees with NumPy's to
            # 1e-12, or for an ill-conditioned system (the planar arm's) to the cond(A) eps any two
            # stable solvers may differ by, as the C backend's (tests/test_c_backend.py)
            A, b = stacked_gpme(model.partitioned(t, q), t, q, qd)
            rtol = 1e-12 if name == "reference" else max(1e-12, 4 * np.linalg.cond(A) * EPS)
            qdd = _value(fns["qdd"](t, q, qd, np.zeros(len(inputs)), p)).ravel()
            assert np.linalg.norm(A @ qdd - b) <= 1e-14 * (np.linalg.norm(A) * np.linalg.norm(qdd) + np.linalg.norm(b))
            _close(qdd, model.accelerations(t, q, qd), rtol)
            _close(fns["qdd"](t, q, qd, u, p), _numpy_qdd(model, inputs, t, q, qd, u), rtol)


def test_inputs_move_the_named_coordinates_only():
    # a model without constraints: an input is M^-1 times a unit force on its coordinate
    model = _tiny_model()
    fns = _casadi_functions(model, ("a",))
    q, qd, p = [0.3], [0.5], [2.0]
    M = float(fns["M"](q, p))
    step = float(fns["qdd"](0.0, q, qd, [1.5], p)) - float(fns["qdd"](0.0, q, qd, [0.0], p))
    assert step == pytest.approx(1.5 / M, rel=1e-14)


def test_jacobian_of_the_accelerations_against_central_differences(cases):
    rng = np.random.default_rng(11)
    for name, model, fns, inputs, elastic in cases:
        t, q, qd, scale = next(_states(model, elastic, rng))
        u = scale * rng.uniform(-1, 1, len(inputs))
        T, Q, QD, U = (casadi.SX.sym(k, n) for k, n in (("t", 1), ("q", model.n_dof), ("qd", model.n_dof),
                                                       ("u", len(inputs))))
        qdd = fns["qdd"](T, Q, QD, U, model.p)
        jac = casadi.Function("dqdd", [T, Q, QD, U], [casadi.jacobian(qdd, casadi.vertcat(Q, QD, U))])
        exact = np.asarray(jac(t, q, qd, u))
        x = np.concatenate([q, qd, u])
        n = model.n_dof

        def numpy_qdd(x):
            return _numpy_qdd(model, inputs, t, x[:n], x[n:2 * n], x[2 * n:])

        # central differences: truncation h² |qdd'''| and round-off eps |qdd| / h, both near 1e-10
        # of the Jacobian's size at h = 1e-5
        h = 1e-5
        differences = np.column_stack([(numpy_qdd(x + h * e) - numpy_qdd(x - h * e)) / (2 * h)
                                       for e in np.eye(len(x))])
        _close(exact, differences, 1e-7)
        assert np.abs(exact).max() > 1.0, name  # a Jacobian that is there to compare


def test_saved_functions_load_in_a_fresh_process(tmp_path, capsys):
    out = tmp_path / "planar_casadi"
    assert main(["export", str(PLANAR), "--format", "casadi", "--nrfe", "2", "--inputs", "theta1,theta2",
                 "--out", str(out)]) == 0
    assert "CasADi functions qdd, M, f" in capsys.readouterr().out
    assert sorted(p.name for p in out.iterdir()) == sorted(
        [casadi_export.SOURCE, casadi_export.MANIFEST] + [f"{k}.casadi" for k in casadi_export.EXPORTED])
    model = gpmegen.load(model=_planar(), backend="numpy", directory=tmp_path / "generated")
    rng = np.random.default_rng(5)
    t, q, qd, _ = next(_states(model, elastic_coordinates(_planar(), model), rng))
    u = np.array([0.7, -0.4])
    script = (
        "import json, sys, casadi, numpy as np\n"
        "folder = sys.argv[1]\n"
        "meta = json.load(open(folder + '/casadi.json'))\n"
        "qdd = casadi.Function.load(folder + '/qdd.casadi')\n"
        "M = casadi.Function.load(folder + '/M.casadi')\n"
        "t, q, qd, u = json.loads(sys.argv[2])\n"
        "print(json.dumps([np.ravel(qdd(t, q, qd, u, meta['defaults'])).tolist(),\n"
        "                  np.ravel(M(q, meta['defaults'])).tolist(), meta['inputs'], meta['coordinates']]))\n"
    )
    done = subprocess.run([sys.executable, "-c", script, str(out), json.dumps([t, q.tolist(), qd.tolist(),
                                                                                u.tolist()])],
                          capture_output=True, text=True, check=True)
    qdd, M, inputs, coordinates = json.loads(done.stdout)
    assert inputs == ["theta1", "theta2"] and coordinates == list(model.coordinates)
    _close(qdd, _numpy_qdd(model, inputs, t, q, qd, u), 1e-12)
    _close(np.reshape(M, (model.n_dof, model.n_dof)), model.mass_matrix(q), 1e-12)


def test_python_export_returns_what_it_saves(tmp_path):
    made = gpmegen.export_casadi(tmp_path / "arm", ROOT / "examples" / "flexible_arm.toml", nrfe=3,
                                 inputs=["theta1"])
    loaded = casadi_export.load(tmp_path / "arm")
    assert sorted(made) == sorted(loaded) == sorted(casadi_export.EXPORTED)
    q, qd = np.array([0.3, 0.01, -0.02]), np.array([1.0, 0.2, -0.1])
    p = json.loads((tmp_path / "arm" / casadi_export.MANIFEST).read_text())["defaults"]
    for u in ([0.0], [0.5]):
        np.testing.assert_array_equal(_value(loaded["qdd"](0.2, q, qd, u, p)), _value(made["qdd"](0.2, q, qd, u, p)))
    assert not np.array_equal(_value(made["qdd"](0.2, q, qd, [0.5], p)), _value(made["qdd"](0.2, q, qd, [0.0], p)))


def test_export_is_deterministic(tmp_path, monkeypatch):
    for k in (1, 2):  # the same command (it is in the source) in two folders
        (tmp_path / str(k)).mkdir()
        monkeypatch.chdir(tmp_path / str(k))
        assert main(["export", str(PLANAR), "--format", "casadi", "--nrfe", "2", "--out", "arm"]) == 0
    for path in sorted((tmp_path / "1" / "arm").iterdir()):
        assert path.read_bytes() == (tmp_path / "2" / "arm" / path.name).read_bytes(), path.name


def test_export_refuses_in_one_line(tmp_path, capsys):
    out = tmp_path / "arm"
    assert main(["export", str(PLANAR), "--format", "casadi", "--nrfe", "2", "--inputs", "theta3",
                 "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert "input 'theta3' is not a coordinate of the model" in err and "theta1" in err and "\n" not in err
    assert main(["export", str(PLANAR), "--format", "urdf", "--inputs", "theta1", "--out", str(out)]) == 2
    assert "--inputs is for --format casadi" in capsys.readouterr().err
    assert main(["export", str(PLANAR), "--format", "casadi", "--nrfe", "2", "--out", str(out)]) == 0
    assert main(["export", str(PLANAR), "--format", "casadi", "--nrfe", "2", "--out", str(out)]) == 2
    assert "--overwrite" in capsys.readouterr().err
    assert main(["export", str(PLANAR), "--format", "casadi", "--nrfe", "2", "--out", str(out), "--overwrite"]) == 0
    capsys.readouterr()
    assert main(["export", str(PLANAR), "--format", "casadi", "--out", str(PLANAR), "--overwrite"]) == 2
    err = capsys.readouterr().err.strip()
    assert "an input of this command" in err and "\n" not in err
    (tmp_path / "file").write_text("")
    assert main(["export", str(PLANAR), "--format", "casadi", "--nrfe", "2", "--out", str(tmp_path / "file")]) == 2
    assert "is a file; give a folder" in capsys.readouterr().err


def test_missing_casadi_is_one_line_naming_the_extra(tmp_path):
    script = ("import sys\nsys.modules['casadi'] = None\nfrom gpmegen.cli import main\n"
              f"sys.exit(main(['export', {str(PLANAR)!r}, '--format', 'casadi', '--out', {str(tmp_path / 'x')!r}]))")
    done = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True)
    assert done.returncode == 2
    assert done.stderr.strip().count("\n") == 0 and "pip install 'gpmegen[casadi]'" in done.stderr
    assert not (tmp_path / "x").exists()


# --- user text and names ------------------------------------------------------------------------


@given(description=free_text, command=free_text, unit=free_text, doc=free_text)
@example(description='"""\nimport os\n"""', command="\\", unit='\\"""', doc="*/")
@settings(max_examples=30, deadline=None, suppress_health_check=[HealthCheck.too_slow])
def test_free_text_stays_in_the_docstring(description, command, unit, doc):
    def source(model, command):  # without the input hash, which holds the model's text
        text = casadi_export.render_casadi(model, command=command)
        return text.replace(input_hash(model, ("casadi",), ()), "INPUT_HASH")

    neutral = source(_tiny_model(), "")
    source = source(_tiny_model(description, unit, doc), command)
    assert _python_code(source) == _python_code(neutral) and source.isascii()


def test_names_of_generator_symbols_and_of_casadi_give_the_same_functions():
    # names of the generator's own symbols, and of what the source uses (casadi, its functions)
    colliding = dict(COLLIDING, g="ca", hub="casadi", tip="SX", point="if_else", constraint="functions")
    neutral_fns = _casadi_functions(_named_model(NEUTRAL, "neutral"), (NEUTRAL["base"],))
    colliding_fns = _casadi_functions(_named_model(colliding, "colliding"), (colliding["base"],))
    rng = np.random.default_rng(2)
    n = neutral_fns["qdd"].size1_in(1)
    p = [prm.default for prm in _named_model(NEUTRAL, "neutral").parameters]
    for _ in range(3):
        t, q, qd, u = rng.uniform(0, 1), rng.uniform(-0.3, 0.3, n), rng.uniform(-1, 1, n), rng.uniform(-1, 1, 1)
        for name, fn in neutral_fns.items():
            args = {"qdd": (t, q, qd, u, p), "f": (t, q, qd, u, p), "M": (q, p), "points": (q, p),
                    "energies": (q, qd, p)}.get(name, (t, q, qd, p))
            np.testing.assert_array_equal(_value(colliding_fns[name](*args)), _value(fn(*args)), err_msg=name)


def test_switching_laws_print_as_casadi_conditionals(tmp_path):
    # the spin-up's prescribed hub angle is a Piecewise of t (its constraint's terms switch at
    # t = T = 15 s) and a drive with Min, Max, Abs and Heaviside: both sides of every switch
    model = load_model_file(ROOT / "examples" / "spinup.toml", nrfe=2)
    law = gpmegen.Drive("theta1", sp.Min(TIME, 3) * sp.Abs(TIME - 2) + sp.Max(TIME - 4, 0) + sp.Heaviside(TIME - 1))
    model = dataclasses.replace(model, drives=(law,))
    fns = _casadi_functions(model, ("theta1",))
    loaded = gpmegen.load(model=model, backend="numpy", directory=tmp_path)
    rng = np.random.default_rng(4)
    for t in (0.5, 1.0, 1.5, 2.5, 3.5, 5.0, 14.0, 15.0, 16.0):
        q, qd = rng.uniform(-0.1, 0.1, loaded.n_dof), rng.uniform(-0.5, 0.5, loaded.n_dof)
        p = loaded.p
        _close(fns["f"](t, q, qd, [0.0], p), loaded.forces(t, q, qd), 1e-12)
        for name, value in zip(("Phi", "Phi_rate", "D", "gamma"), loaded.constraint_terms(t, q, qd)):
            _close(fns[name](t, q, qd, p), value, 1e-12)
        _close(fns["qdd"](t, q, qd, [0.0], p), loaded.accelerations(t, q, qd), 1e-12)


def test_a_function_casadi_cannot_print_is_one_line(tmp_path):
    law = gpmegen.Drive("a", sp.erf(TIME) + sp.Mod(TIME, 2))
    model = dataclasses.replace(_tiny_model(), drives=(law,))
    with pytest.raises(ModelError) as exc:
        casadi_export.render_casadi(model, ("a",))
    assert "cannot print erf" in str(exc.value) and "\n" not in str(exc.value)
    # Mod alone prints, floored as SymPy's: -0.5 mod 2 = 1.5
    fns = _casadi_functions(dataclasses.replace(_tiny_model(), drives=(gpmegen.Drive("a", sp.Mod(TIME, 2)),)))
    assert float(fns["f"](-0.5, [0.0], [0.0], [], [1.0])) == 1.5
