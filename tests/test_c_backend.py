"""The C backend against the NumPy one (the oracle), and the compile cache.

Every model is generated into a temporary folder and compiled into a temporary cache, so the
tests neither depend on nor touch ``generated/`` and ``~/.cache``.
"""

from __future__ import annotations

import dataclasses
import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import sympy as sp
from conftest import stacked_gpme

import gpmegen
from gpmegen.errors import BuildError, SimulationError
from gpmegen.model import reference_model
from gpmegen.model.chain import TIME, Constraint, point_velocity_symbols
from gpmegen.model.reference import PARAMETERS
from gpmegen.runtime import ccompile
from gpmegen.runtime.cmodel import CModel
from gpmegen.status import SolveStatus

pytestmark = pytest.mark.requires_cc
EPS = np.finfo(float).eps


def _variant(name, **changes):
    return dataclasses.replace(reference_model(1), name=name, **changes)


def _unconstrained():
    return _variant("free_nrfe1", constraints=(), dependent=None)


def _mixed_orders():
    """The rigid arm with the height constraint given as a first-order one (ẏ_E prescribed)."""
    ref = reference_model(1)
    P = {p.name: p.symbol for p in PARAMETERS}
    _, vy, _ = point_velocity_symbols("E")
    w = 2 * sp.pi / P["T"]
    rate = Constraint("height_rate", vy + P["A"] * w * sp.sin(w * TIME), 1, P["alpha_height"], P["beta_height"])
    return _variant("mixed_nrfe1", constraints=(ref.constraints[0], rate))


MODELS = {
    "nrfe1": lambda: dict(model="manipulator", nrfe=1),
    "nrfe2": lambda: dict(model="manipulator", nrfe=2),
    "nrfe5": lambda: dict(model="manipulator", nrfe=5),
    "unconstrained": lambda: dict(model=_unconstrained()),
    "first_order": lambda: dict(model=_mixed_orders()),
}


@pytest.fixture(scope="module")
def pairs(env):
    loaded = {}

    def get(key):
        if key not in loaded:
            kwargs = MODELS[key]()
            numpy_model = gpmegen.load(backend="numpy", **kwargs)
            loaded[key] = (gpmegen.load(backend="c", **kwargs), numpy_model)
        return loaded[key]

    return get


def _states(model, n, seed, scale=0.3):
    rng = np.random.default_rng(seed)
    for _ in range(n):
        q = scale * rng.standard_normal(model.n_dof)
        q[model.index("psi2")] += np.pi / 4
        yield float(rng.uniform(0, 10)), q, rng.standard_normal(model.n_dof)


def _rel(a, b):
    a, b = np.asarray(a, float), np.asarray(b, float)
    return np.max(np.abs(a - b)) / max(np.max(np.abs(b)), 1e-300) if b.size else 0.0


@pytest.mark.parametrize("key", list(MODELS))
def test_functions_agree_with_numpy(pairs, key):
    c, n = pairs(key)
    assert isinstance(c, CModel) and c.backend == "c"
    assert c.coordinates == n.coordinates and c.params == n.params
    for t, q, qd in _states(c, 5, seed=1):
        assert _rel(c.mass_matrix(q), n.mass_matrix(q)) <= 1e-12
        assert _rel(c.forces(t, q, qd), n.forces(t, q, qd)) <= 1e-12
        for a, b in zip(c.constraint_terms(t, q, qd), n.constraint_terms(t, q, qd)):
            assert a.shape == b.shape
            assert _rel(a, b) <= 1e-12
        assert _rel(c.static_residual(q), n.static_residual(q)) <= 1e-12
        assert _rel(c.stiffness_jacobian(q), n.stiffness_jacobian(q)) <= 1e-12
        assert _rel(c.energies(q, qd), n.energies(q, qd)) <= 1e-12
        assert _rel(c.drive_forces(t, q, qd), n.drive_forces(t, q, qd)) <= 1e-12
        assert _rel(c.end_effector(q), n.end_effector(q)) <= 1e-12
        for a, b in zip(c.gpme_terms(t, q, qd), n.gpme_terms(t, q, qd)):
            assert a.shape == b.shape and _rel(a, b) <= 1e-12
        assert c.point_positions(q).shape == n.point_positions(q).shape


@pytest.mark.parametrize("key", list(MODELS))
def test_accelerations_agree_with_numpy(pairs, key):
    """q̈ solves the NumPy-assembled GPME to round-off (backward error), and agrees with the
    NumPy q̈ to 1e-12, or to the cond(A)·eps any two stable solvers may differ by."""
    c, n = pairs(key)
    for t, q, qd in _states(c, 5, seed=2):
        qdd_c, qdd_n = c.accelerations(t, q, qd), n.accelerations(t, q, qd)
        M, f = n.module.gpme_terms(t, q, qd, n.p)[:2]
        A, b = stacked_gpme(n, t, q, qd)
        backward = np.linalg.norm(A @ qdd_c - b) / (np.linalg.norm(A) * np.linalg.norm(qdd_c) + np.linalg.norm(b))
        assert backward <= 1e-14
        assert _rel(qdd_c, qdd_n) <= max(1e-12, 4 * np.linalg.cond(A) * EPS)
        # motion solves the dense GPME from M and f, accelerations by the O(n) recursion: two
        # stable solvers, so agreeing as the NumPy solve does
        qdd_m, M_c, f_c = c.motion(t, q, qd)
        assert _rel(qdd_m, qdd_c) <= max(1e-12, 4 * np.linalg.cond(A) * EPS)
        assert _rel(M_c, M) <= 1e-12 and _rel(f_c, f) <= 1e-12
    if key in ("nrfe1", "nrfe2", "unconstrained", "first_order"):  # well-conditioned: 1e-12 outright
        for t, q, qd in _states(c, 5, seed=3):
            assert _rel(c.accelerations(t, q, qd), n.accelerations(t, q, qd)) <= 1e-12


def test_partition_set_after_loading_is_followed(env):
    """The partition may be chosen at run time (model 'dependent' = None): until one is set, each
    evaluation chooses it at its state, on C as on NumPy, though the C solve picks its own
    dependent coordinates (tests/test_c_solve_accuracy.py)."""
    c = gpmegen.load("manipulator", nrfe=2, backend="c")
    n = gpmegen.load("manipulator", nrfe=2, backend="numpy")
    t, q, qd = next(_states(c, 1, seed=5, scale=0.1))
    before = c.accelerations(t, q, qd)
    dep = np.array([c.index("psi2_1"), c.index("x3")])
    for m in (c, n):
        m.dependent, m.independent = dep, np.array([k for k in range(m.n_dof) if k not in dep])
    after = c.accelerations(t, q, qd)
    assert _rel(after, n.accelerations(t, q, qd)) <= 1e-10
    assert _rel(after, before) <= 1e-9  # the same motion, whichever coordinates are dependent
    c.dependent = None
    assert _rel(c.accelerations(t, q, qd), after) <= 1e-9


def _numpy_rk4(model, t0, dt, n_steps, q, qd):
    ts, qs, qds = [t0], [q.copy()], [qd.copy()]
    for k in range(n_steps):
        t = t0 + k * dt

        def rate(tt, x, v):
            return v, model.accelerations(tt, x, v)

        k1 = rate(t, q, qd)
        k2 = rate(t + dt / 2, q + dt / 2 * k1[0], qd + dt / 2 * k1[1])
        k3 = rate(t + dt / 2, q + dt / 2 * k2[0], qd + dt / 2 * k2[1])
        k4 = rate(t + dt, q + dt * k3[0], qd + dt * k3[1])
        q = q + dt / 6 * (k1[0] + 2 * k2[0] + 2 * k3[0] + k4[0])
        qd = qd + dt / 6 * (k1[1] + 2 * k2[1] + 2 * k3[1] + k4[1])
        ts.append(t0 + (k + 1) * dt)
        qs.append(q)
        qds.append(qd)
    return np.array(ts), np.array(qs), np.array(qds)


def test_rk4_matches_numpy_rk4(pairs):
    c, n = pairs("nrfe5")
    rng = np.random.default_rng(4)
    q0 = 1e-3 * rng.standard_normal(c.n_dof)
    q0[c.index("psi2")] = np.pi / 4
    qd0 = 1e-2 * rng.standard_normal(c.n_dof)
    t0, dt, n_steps, every = 0.3, 1e-5, 400, 50
    t, q, qd, _, status = c.rk4(q0, qd0, t0 + n_steps * dt, dt, save_every=every, t0=t0)
    assert status == 0
    tn, qn, qdn = _numpy_rk4(n, t0, dt, n_steps, q0, qd0)
    assert t.shape == (n_steps // every + 1,) and q.shape == qd.shape == (len(t), c.n_dof)
    np.testing.assert_allclose(t, tn[::every], rtol=0, atol=1e-15)
    np.testing.assert_allclose(q, qn[::every], rtol=1e-9, atol=1e-9 * np.max(np.abs(qn)))
    np.testing.assert_allclose(qd, qdn[::every], rtol=1e-9, atol=1e-9 * np.max(np.abs(qdn)))
    np.testing.assert_array_equal(q[0], q0)


def test_rk4_stops_at_a_non_finite_state(pairs):
    c, _ = pairs("nrfe2")
    q0 = np.zeros(c.n_dof)
    q0[c.index("psi2")] = np.pi / 4
    broken = c.with_params()
    broken.p = np.where(np.array(c.parameter_names) == "g", np.inf, c.p)  # f is not finite, so is the first step
    t, q, qd, _, status = broken.rk4(q0, np.zeros(c.n_dof), 1e-3, 1e-5)
    assert status == 2 and len(t) == 1 and np.array_equal(q[0], q0)
    t, q, qd, _, status = c.rk4(q0 + np.nan, np.zeros(c.n_dof), 1e-3, 1e-5)
    assert status == 2 and len(t) == 0


def test_rk4_stops_when_it_diverges(pairs):
    c, _ = pairs("nrfe2")
    q0 = np.zeros(c.n_dof)
    q0[c.index("psi2")] = np.pi / 4
    q0[c.index("psi2_1")] = 0.1
    t, q, qd, _, status = c.rk4(q0, np.zeros(c.n_dof), 10.0, 0.01)  # far beyond the stable step
    assert status in (1, 2)  # numerically singular or non-finite, whichever comes first
    assert 1 <= len(t) < 1001
    assert np.all(np.isfinite(q)) and np.all(np.isfinite(qd))
    np.testing.assert_allclose(t, 0.01 * np.arange(len(t)))


def test_singular_constraint_block(pairs):
    """Arm vertical: E on the column's axis, the circle constraint's row of D vanishes."""
    c, _ = pairs("nrfe1")
    q = np.array([0.0, np.pi / 2, 0.0])
    with pytest.raises(SimulationError, match="singular"):
        c.accelerations(0.0, q, np.zeros(3))
    t, qs, _, _, status = c.rk4(q, np.zeros(3), 1e-4, 1e-5)
    assert status == 1 and len(t) == 1 and np.array_equal(qs[0], q)


def test_shapes_are_checked(pairs):
    c, _ = pairs("nrfe1")
    with pytest.raises(ValueError, match="shape"):
        c.mass_matrix(np.zeros(2))
    with pytest.raises(ValueError):
        c.rk4(np.zeros(3), np.zeros(3), 1e-4, 1e-5, save_every=0)


def test_with_params_reuses_the_library(pairs):
    c, n = pairs("nrfe1")
    heavier = c.with_params(m3=3.0)
    assert isinstance(heavier, CModel) and not heavier.compiled and heavier.lib is c.lib
    q = np.array([0.2, 0.7, 0.1])
    assert _rel(heavier.mass_matrix(q), n.with_params(m3=3.0).mass_matrix(q)) <= 1e-12
    assert _rel(heavier.mass_matrix(q), c.mass_matrix(q)) > 1e-3


# --- compilation and the cache -------------------------------------------------------------------

@pytest.fixture
def source(pairs, tmp_path):
    c, _ = pairs("nrfe1")
    path = tmp_path / "model.c"
    for name in ("model.h", "model.c"):
        (tmp_path / name).write_text((Path(c.folder) / name).read_text())
    return path


@pytest.mark.parametrize("key", ["nrfe1", "nrfe2", "unconstrained", "first_order"])
def test_compiles_without_warnings(pairs, key, tmp_path):
    c, _ = pairs(key)
    cc = ccompile.find_compiler()
    run = subprocess.run([*cc, "-O2", "-std=c99", "-Wall", "-Wextra", "-Werror", "-fPIC",
                          f"-I{ccompile.solver_include()}", "-c", str(Path(c.folder) / "model.c"), "-o",
                          str(tmp_path / "model.o")],
                         capture_output=True, text=True)
    assert run.returncode == 0, run.stderr
    assert run.stderr == ""


def test_cache_hit_and_compile_time(source, fresh_cache):
    cache = fresh_cache
    first = ccompile.build_library(source, cache=cache)
    assert first.compiled and first.compile_seconds > 0 and first.path.exists()
    second = ccompile.build_library(source, cache=cache)
    assert not second.compiled and second.path == first.path
    assert second.compile_seconds == pytest.approx(first.compile_seconds)
    recorded = json.loads((cache / f"{first.key}.json").read_text())["compile_seconds"]
    assert recorded == pytest.approx(first.compile_seconds)
    solver = first.solver.path  # the solver library's object, compiled once for the cache and flags
    assert sorted(p.name for p in cache.iterdir()) == sorted([first.path.name, f"{first.key}.json", solver.name,
                                                              solver.with_suffix(".json").name])


def test_second_load_does_not_recompile(pairs):
    c, _ = pairs("nrfe1")
    again = gpmegen.load("manipulator", nrfe=1, backend="c")
    assert c.library.path == again.library.path and not again.compiled and again.compile_seconds > 0


# make check-c: a model compiled twice (a stale build refused or rebuilt: test_reliability.py)
@pytest.mark.long
def test_stale_source_builds_a_new_library(source, fresh_cache):
    cache = fresh_cache
    first = ccompile.build_library(source, cache=cache)
    source.write_text(source.read_text() + "\n/* changed */\n")
    second = ccompile.build_library(source, cache=cache)
    assert second.compiled and second.key != first.key and second.path != first.path
    assert ccompile.build_library(source, cache=cache, flags=(*ccompile.DEFAULT_FLAGS, "-O3")).compiled


def test_truncated_library_is_rebuilt(source, fresh_cache):
    cache = fresh_cache
    first = ccompile.build_library(source, cache=cache)
    data = first.path.read_bytes()
    first.path.write_bytes(data[: len(data) // 2])
    again = ccompile.build_library(source, cache=cache)
    assert again.compiled and "sha256" in again.rebuilt_reason and again.path == first.path
    ffi, lib, _ = ccompile.load_library(source, cache=cache)
    assert lib.n_dof() == 3


def test_unloadable_library_is_rebuilt(source, fresh_cache):
    """A library whose recorded digest matches but which is no shared object at all."""
    cache = fresh_cache
    first = ccompile.build_library(source, cache=cache)
    first.path.write_bytes(b"not an ELF file")
    meta_path = cache / f"{first.key}.json"
    meta = json.loads(meta_path.read_text())
    meta["sha256"] = ccompile._sha256_file(first.path)
    meta_path.write_text(json.dumps(meta))
    ffi, lib, info = ccompile.load_library(source, cache=cache)
    assert info.compiled and "failed to load" in info.rebuilt_reason
    assert lib.n_dof() == 3


# make check-c: two processes building and compiling at once (concurrent builds: test_reliability.py)
@pytest.mark.long
def test_concurrent_builds_are_safe(source, tmp_path):
    cache = tmp_path / "cache"
    code = ("import sys; from gpmegen.runtime import ccompile; "
            "print(ccompile.build_library(sys.argv[1], cache=sys.argv[2]).compiled)")
    procs = [subprocess.Popen([sys.executable, "-c", code, str(source), str(cache)],
                              stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True) for _ in range(2)]
    outs = [p.communicate(timeout=120) for p in procs]
    assert all(p.returncode == 0 for p in procs), outs
    libs = [p for p in cache.iterdir() if p.suffix == ".so"]
    assert len(libs) == 1 and not [p for p in cache.iterdir() if p.name.startswith(".")]
    info = ccompile.build_library(source, cache=cache)
    assert not info.compiled
    _, lib, _ = ccompile.load_library(source, cache=cache)
    assert lib.n_dof() == 3


def test_missing_compiler_named_by_cc(source, tmp_path, monkeypatch):
    monkeypatch.setenv("CC", str(tmp_path / "no-such-cc"))
    with pytest.raises(BuildError, match=r"\$CC .*not found.*backend='numpy'"):
        ccompile.build_library(source, cache=tmp_path / "cache")


def test_no_compiler_on_path(pairs, tmp_path, monkeypatch):
    pairs("nrfe1")
    monkeypatch.delenv("CC", raising=False)
    monkeypatch.setenv("PATH", str(tmp_path))
    monkeypatch.setenv("GPMEGEN_CACHE", str(tmp_path / "cache"))
    with pytest.raises(BuildError, match="no C compiler found.*install gcc or clang"):
        gpmegen.load("manipulator", nrfe=1, backend="c")


def test_compile_error_is_a_build_error(tmp_path, fresh_cache):
    bad = tmp_path / "model.c"
    (tmp_path / "model.h").write_text("int m_f(void);\n")
    bad.write_text("#include \"model.h\"\nint m_f(void) { return }\n")
    with pytest.raises(BuildError, match="compiling .*model.c failed"):
        ccompile.build_library(bad, cache=fresh_cache)
    assert not [p for p in fresh_cache.iterdir() if not p.name.startswith(ccompile.SOLVER_PREFIX)]


def test_cache_directory_default_and_override(monkeypatch, tmp_path):
    monkeypatch.setenv("GPMEGEN_CACHE", str(tmp_path))
    assert ccompile.cache_directory() == tmp_path
    monkeypatch.delenv("GPMEGEN_CACHE")
    monkeypatch.delenv("XDG_CACHE_HOME", raising=False)
    assert ccompile.cache_directory() == Path.home() / ".cache" / "gpmegen" / "c"
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    assert ccompile.cache_directory() == tmp_path / "xdg" / "gpmegen" / "c"
    assert os.environ.get("GPMEGEN_CACHE") is None


def test_rk4_work_integrals_match_the_numpy_integrator(pairs):
    """The C loop integrates the work of drive and constraints like integrators.rk4.rk4 does."""
    from gpmegen.analysis.run import reference_case
    from gpmegen.runtime import integrators

    c, n = pairs("nrfe1")
    model_n, q0 = reference_case.initial_state(n)
    model_c = c.with_params(r_Ea=model_n.params["r_Ea"], y_c=model_n.params["y_c"], tdr0=50.0)
    model_n = model_n.with_params(tdr0=50.0)
    t, q, qd, w, status = model_c.rk4(q0, np.zeros(3), 4.3, 1e-3, save_every=100, t0=4.0)
    tn, yn, status_n = integrators.rk4.rk4(model_n, q0, np.zeros(3), 4.3, 1e-3, save_every=100, t0=4.0)
    assert status == SolveStatus.OK and status_n.complete
    np.testing.assert_allclose(t, tn, atol=1e-12)
    np.testing.assert_allclose(w, yn[:, 6:8], rtol=1e-9, atol=1e-12)
    assert np.abs(w[-1]).min() > 1e-3  # both works are real here


@pytest.mark.parametrize("identity, gcc", [
    ("/usr/bin/cc\ncc (Debian 12.2.0-14) 12.2.0\nCopyright (C) 2022 Free Software Foundation, Inc.\n\nAMD", True),
    ("/usr/bin/gcc\ngcc (GCC) 13.2.1\nCopyright (C) 2023 Free Software Foundation, Inc.\n\nIntel", True),
    ("/usr/bin/cc\nDebian clang version 14.0.6\nTarget: x86_64-pc-linux-gnu\n\nAMD", False),
    ("/usr/bin/cc\nApple clang version 15.0.0 (clang-1500.1.0.2.5)\nTarget: arm64-apple-darwin\n\nM2", False),
    ("/opt/Free Software Foundation/cc\n\n\nAMD", False),  # the words only in the path
    ("/usr/bin/cc", False),
])
def test_gcc_is_told_from_other_compilers(identity, gcc):
    """GCC-only flags (priority register allocation) go to GCC alone, whatever its name."""
    assert ccompile.is_gcc(identity) is gcc


@pytest.mark.requires_cc
def test_missing_velocities_are_refused_not_taken_from_an_earlier_call(pairs):
    """Single calls keep q and q̇ in per-thread C buffers: a call without q̇ must not use the q̇
    an earlier call left there (it did), but say what is missing, as the NumPy backend does."""
    c, numpy_model = pairs("nrfe1")
    t, q, qd = next(_states(c, 1, seed=8))
    for name in ("forces", "constraint_terms", "accelerations"):
        getattr(c, name)(t, q, qd)  # leaves qd in the buffers
        with pytest.raises(ValueError) as expected:
            getattr(numpy_model, name)(t, q, None)
        with pytest.raises(ValueError) as got:
            getattr(c, name)(t, q, None)
        assert str(got.value) == str(expected.value), name
