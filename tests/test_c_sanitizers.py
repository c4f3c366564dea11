"""The sanitizer sweep (``make check-c``): every exported function of the generated C of a spread
of models, run under AddressSanitizer and UndefinedBehaviorSanitizer, and again as the product
compiles it (``-O3 -march=native``, and ``-march=x86-64-v4`` where the processor has AVX-512).

The spread: each example, the reference arm rigid, flexible and at n_rfe = 12 (its largest
reduced system), a model without constraints, one with three
flexible links and constraints of both orders, the spinning beam that once crashed, and the PID
slider (a controller state). Each run
is :mod:`gpmegen.runtime.cprobe` in a child process: a sanitizer report or a signal fails it.
"""

from __future__ import annotations

import dataclasses
import os
import subprocess
import sys
from pathlib import Path

import pytest
import sympy as sp

import gpmegen
from gpmegen.analysis.run.model_files import load_model_file
from gpmegen.model import reference_model
from gpmegen.model.chain import (
    GROUND_NAME,
    TIME,
    Branch,
    CircularSection,
    Constraint,
    Drive,
    FlexibleLink,
    ForceElement,
    Joint,
    Model,
    Parameter,
    Point,
    RectangularSection,
    point_symbols,
    point_velocity_symbols,
    symbol,
    velocity_symbol,
)
from gpmegen.runtime import ccompile, cprobe

pytestmark = [pytest.mark.sanitizers, pytest.mark.requires_cc]

ROOT = Path(__file__).resolve().parents[1]
SANITIZER_FLAGS = ("-O1", "-fsanitize=address,undefined", "-fno-sanitize-recover=all", "-fno-omit-frame-pointer",
                   "-std=c99", "-ffp-contract=off", "-fno-math-errno")
AVX512 = "avx512f" in (Path("/proc/cpuinfo").read_text() if Path("/proc/cpuinfo").exists() else "")
PRODUCT_FLAGS = {"native": ccompile.DEFAULT_FLAGS}
if AVX512:
    PRODUCT_FLAGS["x86-64-v4"] = tuple(f if f != "-march=native" else "-march=x86-64-v4"
                                       for f in ccompile.DEFAULT_FLAGS)


def _three_links():
    """Three flexible links (rectangular, circular, rectangular; n_rfe 2, 3, 2) between a revolute,
    a revolute and a prismatic joint; a position and a first-order constraint on the tip."""
    P = {name: sp.Symbol(name, real=True) for name in ("L", "b", "h", "r", "rho", "Em", "Gm", "w")}
    parameters = tuple(Parameter(name, value) for name, value in
                       zip(P, (0.4, 0.02, 0.01, 0.008, 2700.0, 7e10, 2.6e10, 1.0)))

    def link(label, section, nrfe):
        return FlexibleLink(label, P["L"], section, P["rho"], P["Em"], P["Gm"], nrfe)

    x, y, z = point_symbols("E")
    vx, vy, _ = point_velocity_symbols("E")
    return Model(
        name="three_links", parameters=parameters,
        chain=(Joint("a1", "revolute", "z"), link("1", RectangularSection(P["b"], P["h"]), 2),
               Joint("a2", "revolute", "y"), link("2", CircularSection(P["r"]), 3),
               Joint("s3", "prismatic", "x"), link("3", RectangularSection(P["b"], P["h"]), 2), Point("E"),
               Branch(GROUND_NAME), Point("G", (sp.Rational(1, 10), sp.Rational(3, 10), sp.Rational(1, 20)))),
        gravity=(0, -9.81, 0),
        constraints=(Constraint("height", y - sp.Rational(1, 10) * sp.sin(TIME), 0, 20, 20),
                     Constraint("heading", vx * sp.sin(P["w"] * TIME) - vy * sp.cos(P["w"] * TIME), 1, 20)),
        dependent=("a2", "s3"),
        # a feedback law of a coordinate, its velocity and the point's position and velocity
        drives=(Drive("a1", -20 * symbol("a1") - 2 * velocity_symbol("a1") - 5 * sp.Max(-1, sp.Min(1, x * vy))),),
        # forces between a ground point and E: a spring-damper and an actuator's feedback law
        forces=(ForceElement("strut", ("E", "G"), "spring-damper", 50, sp.Rational(3, 10), sp.Rational(1, 2)),
                ForceElement("push", ("G", "E"), "actuator", force=-3 * vy + sp.sin(TIME))),
    )


def _models():
    models = {f"reference_nrfe{n}": (lambda n=n: reference_model(n)) for n in (1, 2, 12)}
    models["unconstrained_nrfe2"] = lambda: dataclasses.replace(reference_model(2), name="unconstrained_nrfe2",
                                                                 constraints=(), dependent=None)
    models["three_links"] = _three_links
    for path in sorted((ROOT / "examples").glob("*.toml")):
        models[path.stem] = lambda path=path: load_model_file(path)
    models["spinning_beam_nrfe10"] = lambda: load_model_file(ROOT / "tests" / "models" / "spinning_beam.toml")
    # a controller state: the implicit loops' Newton matrices grow by its rows and columns
    models["pid_slider"] = lambda: load_model_file(ROOT / "tests" / "models" / "pid_slider.toml")
    return models


MODELS = _models()


@pytest.fixture(scope="module")
def folders(env):
    built = {}

    def folder(key):
        if key not in built:
            built[key] = Path(gpmegen.load(model=MODELS[key](), backend="numpy").folder)
        return built[key]

    return folder


def _runtime(name: str) -> str:
    compiler = ccompile.find_compiler()
    path = subprocess.run([*compiler, f"-print-file-name={name}"], capture_output=True, text=True).stdout.strip()
    if not os.path.isabs(path):
        pytest.skip(f"the compiler has no {name} (sanitizers not installed)")
    return path


@pytest.mark.parametrize("key", list(MODELS))
def test_every_function_is_clean_under_address_and_undefined_sanitizers(folders, env, key):
    folder = folders(key)
    library = ccompile.build_library(folder / "model.c", SANITIZER_FLAGS, cache=env[1]).path
    argv = [sys.executable, "-m", "gpmegen.runtime.cprobe", str(library), str(folder / "model.c"),
            str(folder / "model_numpy.py")]
    run = subprocess.run(argv, capture_output=True, text=True, timeout=600, env={
        **os.environ, "LD_PRELOAD": _runtime("libasan.so"),
        "ASAN_OPTIONS": "detect_leaks=0:abort_on_error=0", "UBSAN_OPTIONS": "print_stacktrace=1:halt_on_error=1"})
    assert run.returncode == 0, f"{key}: {run.stdout[-300:]}\n{run.stderr[-4000:]}"
    assert "runtime error" not in run.stderr and "AddressSanitizer" not in run.stderr, run.stderr[-4000:]
    assert "calling rk4" in run.stdout


@pytest.mark.parametrize("flags", list(PRODUCT_FLAGS))
@pytest.mark.parametrize("key", list(MODELS))
def test_every_function_runs_as_compiled_for_use(folders, env, key, flags):
    folder = folders(key)
    library = ccompile.build_library(folder / "model.c", PRODUCT_FLAGS[flags], cache=env[1]).path
    assert cprobe.check_in_child(library, folder / "model.c", folder / "model_numpy.py") is None
