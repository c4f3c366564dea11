"""Work that cannot finish is refused before it starts, values that make no physical sense are
refused wherever they are bound, odd values end in one clear line, and messages speak of the
user's own model. Each test is named after the defect it provokes."""

from __future__ import annotations

import hashlib
import json
import math
import re
import types

import numpy as np
import pytest

import gpmegen
from gpmegen import limits
from gpmegen.analysis.run import reference_case, study
from gpmegen.analysis.run.model_files import load_model_file
from gpmegen.analysis.run.runspec import RunSpec
from gpmegen.cli import main
from gpmegen.errors import BuildError, EvaluationError, ModelError
from gpmegen.limits import LimitError
from gpmegen.model import Body, Joint, Model, Parameter, Point, shapes
from gpmegen.runtime import ccompile
from gpmegen.runtime.numpy_module import import_numpy_module

# A planar two-link arm (links of length L) whose tip E is held at the height h.
ARM = """
schema = 1
name = "reach_arm"
gravity = [0, "-g", 0]

[parameters]
g = 9.81
m = 1.0
L = 0.5
h = 0.3
c = 1.0

[[chain]]
joint = "theta"
type = "revolute"
axis = "z"

[[chain]]
body = "upper"
shape = { type = "rod", mass = "m", length = "L", radius = 0.01 }

[[chain]]
translation = ["L", 0, 0]

[[chain]]
joint = "phi"
type = "revolute"
axis = "z"

[[chain]]
body = "lower"
shape = { type = "rod", mass = "m", length = "L", radius = 0.01 }

[[chain]]
translation = ["L", 0, 0]

[[chain]]
point = "E"

[[constraints]]
name = "height"
expression = "y_E - h"
alpha = 10
beta = 10

[initial]
q = { theta = 0.5 }
"""


def _file(tmp_path, text, name="arm.toml"):
    path = tmp_path / name
    path.write_text(text)
    return path


def _one_line_error(capsys):
    err = capsys.readouterr().err.strip().splitlines()
    assert err and "Traceback" not in "\n".join(err) and "internal error" not in "\n".join(err), err
    return err[-1]


def _no_files(folder):
    return not folder.exists() or not any(folder.iterdir())


# --- 6. bounds on resources --------------------------------------------------------------------

def test_build_of_500_rfes_ran_until_killed(tmp_path, capsys):
    out = tmp_path / "out"
    assert main(["build", "--nrfe", "500", "--out", str(out)]) == 2
    line = _one_line_error(capsys)
    assert "manipulator_nrfe500 (n_dof = 1500) would take about " in line and " GB of memory" in line
    assert "limit of 3600 s" in line and "--no-limits" in line
    assert _no_files(out / "manipulator_nrfe500")


def test_build_of_500_rfes_ran_until_killed_from_python(tmp_path):
    with pytest.raises(LimitError, match=r"n_dof = 1500"):
        gpmegen.load("manipulator", nrfe=500, directory=tmp_path, backend="numpy")
    assert not (tmp_path / "manipulator_nrfe500").exists()


def test_model_file_of_10000_chain_elements_ran_until_killed(tmp_path, capsys):
    elements = "".join(f'[[chain]]\njoint = "q{k}"\ntype = "revolute"\naxis = "z"\n\n'
                       f'[[chain]]\nbody = "b{k}"\nshape = {{ type = "point_mass", mass = 1 }}\n\n'
                       for k in range(5000))
    # a fault in the last element: a reader that went through the chain would report it instead
    path = _file(tmp_path, 'schema = 1\nname = "long_chain"\n\n' + elements + '[[chain]]\nnosuch = 1\n')
    assert main(["build", str(path), "--out", str(tmp_path / "out")]) == 2
    line = _one_line_error(capsys)
    assert f"{path} (10001 chain elements, n_dof = 5000)" in line and "GB of memory" in line
    assert "available" in line and "--no-limits" in line


def test_simulation_of_1e14_saved_steps_filled_the_memory(tmp_path, capsys, monkeypatch):
    empty = tmp_path / "generated"
    empty.mkdir()
    monkeypatch.setenv("GPMEGEN_GENERATED", str(empty))  # nothing to load: refused before loading
    out = tmp_path / "run.npz"
    assert main(["simulate", "--t-end", "1e9", "--save-every", "1", "--backend", "numpy", "--out", str(out)]) == 2
    line = _one_line_error(capsys)
    assert "1e+14 RK4 steps of n_dof = 15 in NumPy, saving 1e+14 samples" in line
    assert "years" in line and "GB of memory" in line and "of memory available" in line
    assert _no_files(empty) and not out.exists()


@pytest.mark.parametrize("method", ["radau", "scipy-radau"])
def test_simulation_of_1e15_saved_samples_by_a_method_without_an_estimate_ran_until_killed(tmp_path, capsys,
                                                                                         monkeypatch, method):
    """A method whose steps cannot be known before (no estimator) skipped every limit, even what
    its saved samples need; they are known from the save grid alone."""
    empty = tmp_path / "generated"
    empty.mkdir()
    monkeypatch.setenv("GPMEGEN_GENERATED", str(empty))
    out = tmp_path / "run.npz"
    assert main(["simulate", "--method", method, "--t-end", "1e12", "--save-dt", "1e-3", "--out", str(out)]) == 2
    line = _one_line_error(capsys)
    assert f"a {method} run of n_dof = 15, saving 1e+15 samples" in line
    assert "at least" in line and "GB of memory" in line and "--save-every (or --save-dt)" in line
    assert _no_files(empty) and not out.exists()


def test_simulation_at_a_step_of_1e_300_ran_forever_even_without_limits(tmp_path, capsys):
    out = tmp_path / "run.npz"
    for extra in ([], ["--no-limits"]):
        assert main(["simulate", "--nrfe", "1", "--dt", "1e-300", "--out", str(out), *extra]) == 2
        line = _one_line_error(capsys)
        assert "1e+301 steps, more than any run can count" in line and "--dt" in line
    assert not out.exists()


def test_simulation_from_python_is_refused_too(rigid):
    model, q0 = reference_case.initial_state(rigid)
    with pytest.raises(LimitError, match="saving 1e\\+14 samples"):
        study.simulate(model, q0, RunSpec(t_end=1e9, dt=1e-5, save_every=1))


def test_no_limits_lifts_the_refusal(tmp_path, capsys, monkeypatch):
    monkeypatch.setattr(limits, "MAX_SECONDS", 0.0)  # everything is over the limit now
    argv = ["simulate", "--nrfe", "1", "--backend", "numpy", "--t-end", "0.002", "--dt", "1e-3",
            "--out", str(tmp_path / "run.npz")]
    assert main(argv) == 2
    assert "--no-limits" in _one_line_error(capsys)
    assert main(argv + ["--no-limits"]) == 0
    with pytest.raises(LimitError):
        limits.check_build(3, "tiny")
    with limits.lifted():
        limits.check_build(3, "tiny")


def test_compile_of_a_huge_c_file_is_refused():
    with pytest.raises(LimitError, match=r"compiling model\.c \(5e\+03 MB of C\).*--backend numpy"):
        limits.check_compile(5_000_000_000, "model.c")


def test_estimates_follow_the_measurements_and_grow_beyond_them():
    for points in (limits.BUILD_SECONDS, limits.BUILD_BYTES, limits.COMPILE_SECONDS):
        for x, y in points:
            assert limits.interpolate(points, x) == pytest.approx(y)
        assert limits.interpolate(points, 10 * points[-1][0]) > 5 * points[-1][1]
    for points in (limits.BUILD_SECONDS, limits.BUILD_BYTES):  # against n_dof: M and K have n_dof^2 entries
        assert limits.interpolate(points, 10 * points[-1][0]) > 10 * points[-1][1]


def test_symmetry_check_simplified_an_inertia_entry_for_ever(tmp_path):
    text = ARM.replace('c = 1.0\n', 'c = 1.0\na = 1.0\nb = 1.0\nd = 1.0\n').replace(
        'shape = { type = "rod", mass = "m", length = "L", radius = 0.01 }\n\n[[chain]]\ntranslation',
        'mass = "m"\ninertia = [[1, "(a+b+c+d)**100", 0], [0, 1, 0], [0, 0, 1]]\n\n[[chain]]\ntranslation', 1)
    with pytest.raises(ModelError, match=r"chain\[1\]\.inertia\[1\]\[0\]: the inertia tensor is not symmetric"):
        load_model_file(_file(tmp_path, text))
    # the same product written two ways is one quantity; two parameters equal only at their
    # defaults are not
    same = text.replace('[[1, "(a+b+c+d)**100", 0], [0, 1, 0]', '[[1, "m*a/2", 0], ["0.5*a*m", 1, 0]')
    assert load_model_file(_file(tmp_path, same, "same.toml")).name == "reach_arm"
    other = text.replace('[[1, "(a+b+c+d)**100", 0], [0, 1, 0]', '[[1, "a", 0], ["b", 1, 0]')
    with pytest.raises(ModelError, match="not symmetric"):
        load_model_file(_file(tmp_path, other, "other.toml"))


def test_nrfe_of_24_digits_was_an_internal_error(tmp_path, capsys):
    with pytest.raises(SystemExit) as exit_:
        main(["build", "--nrfe", "1" + "0" * 23, "--out", str(tmp_path)])
    assert exit_.value.code == 2
    assert "is more than any count can hold" in capsys.readouterr().err
    with pytest.raises(LimitError, match="n_dof = 300000000000000000000000"):
        gpmegen.load("manipulator", nrfe=10**23, directory=tmp_path, backend="numpy")


# --- 7. values that slip through ---------------------------------------------------------------

@pytest.mark.parametrize("value", ["exp(1000)", "exp(exp(exp(1000)))"])
def test_parameter_value_beyond_a_double_became_inf_or_an_internal_error(tmp_path, value):
    path = _file(tmp_path, ARM.replace("m = 1.0", f'm = "{value}"'))
    with pytest.raises(ModelError, match=r"arm\.toml:8: parameters\.m: .*exp\(1000\) = 1\.97e\+434, beyond a double"):
        load_model_file(path)


def test_an_integer_too_long_to_print_was_an_internal_error(tmp_path):
    """``(10**49)**100`` has 4,901 digits, more than Python turns into text: its refusal failed."""
    path = _file(tmp_path, ARM.replace("m = 1.0", 'm = "(10**49)**100"'))
    with pytest.raises(ModelError, match=r"arm\.toml:8: parameters\.m: .*holds a number of 1\.00e\+4900, beyond a dou"):
        load_model_file(path)


def test_constant_beyond_a_double_in_a_quantity_became_an_overflow_at_run_time(tmp_path):
    far = 'point = "F"\n\n[[chain]]\npoint = "E"\nposition = ["exp(710)*L", 0, 0]'
    path = _file(tmp_path, ARM.replace('point = "E"', far))
    with pytest.raises(ModelError, match=r"chain\[7\]\.position\[0\]: .*exp\(710\) = .*beyond a double"):
        load_model_file(path)


def test_default_whose_quantity_overflows_is_named(tmp_path):
    path = _file(tmp_path, ARM.replace("c = 1.0", "c = 1000.0").replace('mass = "m", length = "L"',
                                                                         'mass = "exp(c)", length = "L"', 1))
    with pytest.raises(ModelError, match=r"chain\[1\]\.shape\.mass: the mass of body 'upper' = exp\(c\) is not a "
                                         r"finite real number with the parameter defaults \(c = 1000\)"):
        load_model_file(path)


def test_model_with_an_infinite_default_wrote_a_module_that_cannot_be_imported(tmp_path):
    model = Model("inf_default", (Parameter("m", math.inf),),
                  (Joint("q", "revolute", "z"), Body("b", shapes.point_mass(1.0, (1, 0, 0))), Point("P")))
    with pytest.raises(ModelError, match="parameter 'm' has the default inf, not a finite number"):
        gpmegen.load(model=model, directory=tmp_path, backend="numpy")
    folder = tmp_path / "old"
    folder.mkdir()
    text = "DEFAULTS = (1.0, inf)\n"  # written by an older gpmegen, and recorded in its manifest
    (folder / "model_numpy.py").write_text(text)
    files = {"model_numpy.py": hashlib.sha256(text.encode()).hexdigest()}
    (folder / "manifest.json").write_text(json.dumps({"files": files}))
    with pytest.raises(BuildError, match="cannot be imported \\(NameError.*gpmegen build --force"):
        import_numpy_module(folder)


def test_statics_initial_on_the_reference_case_was_an_internal_error(capsys):
    assert main(["statics", "--nrfe", "1", "--statics", "none"]) == 2
    assert "--statics none is for model files" in _one_line_error(capsys)


def test_zero_arm_length_divided_by_zero_in_generated_code(capsys):
    assert main(["statics", "--nrfe", "1", "--param", "L2=0"]) == 2
    line = _one_line_error(capsys)
    assert "the length of flexible link '2' is 0 with L2 = 0; lengths must be positive: change L2" in line


def test_negative_mass_by_param_skipped_the_checks_of_model_files(tmp_path, capsys):
    assert main(["statics", "--nrfe", "1", "--param", "m3=-3"]) == 2
    assert "the mass of body 'slider' is -3 with m3 = -3; masses must be zero or positive" in _one_line_error(capsys)
    # a file's default and a value bound at run time get the same words
    bad = _file(tmp_path, ARM.replace("m = 1.0", "m = -3.0"), "bad.toml")
    with pytest.raises(ModelError, match=r"bad\.toml:\d+: chain\[1\]\.shape\.mass: the mass of body 'upper' is -3 with "
                                         r"the parameter defaults \(m = -3\); masses must be zero or positive"):
        load_model_file(bad)
    good = load_model_file(_file(tmp_path, ARM))
    with pytest.raises(ModelError, match=r"model reach_arm: the mass of body 'upper' is -3 with m = -3; masses must "
                                         r"be zero or positive: change m"):
        gpmegen.load(model=good, params={"m": -3.0}, backend="numpy")


def test_with_params_bound_unphysical_values(flexible):
    for change, words in [({"E2": -7e10}, "Young's modulus of flexible link '2'"),
                          ({"b2": 0.0}, "width of flexible link '2' is 0"),
                          ({"d2": -0.1}, "damping coefficients must be zero or positive"),
                          ({"alpha_circle": -1.0}, "Baumgarte gains must be zero or positive"),
                          ({"R1": -0.05}, "radius of body 'column'")]:
        with pytest.raises(ModelError, match=words):
            flexible.with_params(**change)
    massless = flexible.with_params(m3=0.0, L3=0.0)  # a massless slider of no length is still a model
    assert massless.params["m3"] == 0.0


def test_division_by_zero_in_generated_code_was_an_internal_error(tmp_path, capsys):
    text = ARM.replace('[[chain]]\npoint = "E"', '[[chain]]\npoint = "E"\nposition = ["1/c", 0, 0]')
    path = _file(tmp_path, text.split("[[constraints]]")[0])
    assert main(["statics", str(path), "--param", "c=0"]) == 1
    line = _one_line_error(capsys)
    assert "model reach_arm: points divides by zero" in line and "--param" in line
    model = gpmegen.load(model=load_model_file(path), directory=tmp_path / "gen", params={"c": 0.0}, backend="numpy")
    with pytest.raises(EvaluationError, match="points divides by zero"):
        model.point_positions(np.zeros(model.n_dof))


def test_overflow_in_generated_code_was_an_internal_error(tmp_path, capsys):
    path = _file(tmp_path, ARM.replace('gravity = [0, "-g", 0]', 'gravity = [0, "-g*exp(c)", 0]'))
    assert main(["statics", str(path), "--statics", "locked", "--param", "c=1000"]) == 1
    line = _one_line_error(capsys)
    assert "model reach_arm: " in line and "overflows a double (math range error)" in line


@pytest.mark.parametrize("damage", ["empty", "truncated", "bad_crc", "no_samples"])
def test_plot_of_a_damaged_results_file_was_an_internal_error(tmp_path, capsys, damage):
    good = tmp_path / "good.npz"
    assert main(["simulate", "--nrfe", "1", "--backend", "numpy", "--t-end", "0.01", "--dt", "1e-3",
                 "--out", str(good)]) == 0
    data = bytearray(good.read_bytes())
    bad = tmp_path / f"{damage}.npz"
    if damage == "empty":
        bad.write_bytes(b"")
    elif damage == "truncated":
        bad.write_bytes(data[: len(data) // 2])
    elif damage == "bad_crc":
        middle = len(data) // 3
        data[middle:middle + 40] = bytes(b ^ 0x55 for b in data[middle:middle + 40])
        bad.write_bytes(data)
    else:
        arrays = dict(np.load(good))
        np.savez(bad, **{**arrays, "t": arrays["t"][:0], "q": arrays["q"][:0]})
    capsys.readouterr()
    assert main(["plot", str(bad), "--out", str(tmp_path / "figures")]) == 2
    line = _one_line_error(capsys)
    assert line.startswith(f"gpmegen plot: error: {bad}: ") and "gpmegen simulate" in line


def test_read_only_cache_failed_on_a_temporary_file_name(tmp_path, capsys, monkeypatch):
    try:
        ccompile.find_compiler()
    except BuildError:
        pytest.skip("no C compiler")
    cache = tmp_path / "cache"
    cache.mkdir()
    monkeypatch.setenv("GPMEGEN_CACHE", str(cache))

    def refused(prefix="", suffix="", dir=None):  # what the OS answers in a read-only folder
        raise PermissionError(13, "Permission denied", f"{dir}/{prefix}x{suffix}")

    monkeypatch.setattr(ccompile, "tempfile", types.SimpleNamespace(mkstemp=refused))
    with pytest.raises(BuildError, match=re.escape(f"C cache folder {cache} (Permission denied); set GPMEGEN_CACHE")):
        gpmegen.load("manipulator", nrfe=1, backend="c")
    out = tmp_path / "run.npz"
    assert main(["simulate", "--nrfe", "1", "--t-end", "0.002", "--dt", "1e-3", "--out", str(out)]) == 0
    err = capsys.readouterr().err
    # the solver library is the first thing a cold cache compiles, so it is the one refused
    assert f"C backend unavailable (cannot write the solver library into the C cache folder {cache}" in err
    assert "using the NumPy backend" in err and out.exists()


# --- 8. messages that name the wrong model -----------------------------------------------------

def test_unreachable_height_was_blamed_on_the_circle_radius(tmp_path, capsys):
    path = _file(tmp_path, ARM)
    assert main(["statics", str(path)]) == 0
    capsys.readouterr()
    assert main(["statics", str(path), "--param", "h=5"]) == 1
    line = _one_line_error(capsys)
    assert "model reach_arm: the programmed constraints cannot be met" in line and "moving theta" in line
    assert "height = -4.0" in line and "reach" in line
    assert "r_Ea" not in line and "y_c" not in line and "circle" not in line


def test_reference_case_keeps_its_own_hint(tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert main(["simulate", "--nrfe", "1", "--backend", "numpy", "--t-end", "0.01", "--dt", "1e-3",
                 "--param", "r_Ea=1e6"]) == 1
    line = _one_line_error(capsys)
    assert "circle = " in line and "r_Ea" in line and "y_c" in line


def test_a_build_with_jacobians_was_estimated_as_one_without(capsys, tmp_path):
    """`build --jacobians` at n_dof 30 was estimated at 2.3 s of CPU and took 68.6 s: the Jacobians
    are derived too (measured 4 to 18 times the CPU of a build without them at n_dof 3 to 30). The
    estimate counts them, and a build that only they make too long is refused before it starts."""
    assert limits.build_seconds(30, jacobians=True) > 15 * limits.build_seconds(30)
    for n in (3, 15, 30, 60):
        assert limits.build_seconds(n, jacobians=True) > limits.build_seconds(n)
    limits.check_build(300, "big")  # about 3 minutes without them
    with pytest.raises(limits.LimitError, match=r"n_dof = 300, with its Jacobians.*without --jacobians"):
        limits.check_build(300, "big", jacobians=True)
    assert main(["build", "--nrfe", "100", "--jacobians", "--out", str(tmp_path / "unused")]) == 2
    assert "with its Jacobians" in capsys.readouterr().err


def test_a_refused_build_left_its_lock_file_and_output_folder_behind(capsys, tmp_path):
    """The estimate refused the build only after the lock had created ``--out`` and a lock file
    in it: a refused command must leave nothing."""
    out = tmp_path / "out"
    assert main(["build", "--nrfe", "100", "--jacobians", "--out", str(out)]) == 2
    assert "with its Jacobians" in capsys.readouterr().err
    assert not out.exists()
