"""Reference signals (``[[signals]]``) and feedforward (``simulate --feedforward``).

A signal given by an expression is the expression written where its name stands; one read from
a table is the linear interpolation of its samples, called by the generated code as a function
of t that the runtime supplies (NumPy: ``numpy.interp``; C: the solver library's
``gpmegen_signal``), its error at most h²/8·max|ÿ|. The models are sliders of one coordinate
(a cart of mass m on a prismatic joint, no gravity), where a force's effect on the motion is two
integrations: an error of the force of at most ε moves the cart by at most ε·T²/(2m) in T."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

import gpmegen
from gpmegen import cli
from gpmegen.analysis.post import feedforward
from gpmegen.codegen.backends import casadi as casadi_export
from gpmegen.errors import ModelError, SimulationError
from gpmegen.model.expand import expand
from gpmegen.runtime import signals

CART = """schema = 1
name = "{name}"
gravity = [0, 0, 0]
{top}
[parameters]
m = {{ value = 2.0, unit = "kg" }}
A = {{ value = 0.1, unit = "m" }}
w = {{ value = 3.0, unit = "rad/s" }}

[[chain]]
joint = "x"
type = "prismatic"
axis = "x"

[[chain]]
body = "cart"
mass = "m"

[[chain]]
point = "C"
{rest}"""

# the cart follows x = A (1 - cos w t) by its input u on x: u = m ẍ = m A w² cos w t
SERVO = CART.format(name="servo_cart", top='actuators = ["x"]\n', rest="""
[[constraints]]
name = "path"
expression = "x_C - A*(1 - cos(w*t))"
alpha = 20
beta = 20
""")
PLANT = CART.format(name="plant_cart", top="", rest="")
TABLE = CART.format(name="table_cart", top="", rest="""
[[signals]]
name = "push"
table = "ref.npz"
column = "f"

[[drives]]
coordinate = "x"
expression = "push"
""")
NAMED = CART.format(name="named_cart", top="", rest="""
[[signals]]
name = "push"
expression = "m*A*w^2*cos(w*t)"

[[drives]]
coordinate = "x"
expression = "push"

[[constraints]]
name = "slow"
expression = "x_C_dot - 0*push"
order = 1
""").replace("x_C_dot", "vx_C")
INLINE = NAMED.replace('expression = "push"', 'expression = "m*A*w^2*cos(w*t)"').replace(
    "named_cart", "inline_cart").replace("0*push", "0*m*A*w^2*cos(w*t)")
M, A, W = 2.0, 0.1, 3.0
T_END, DT = 0.5, 1e-3


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    folder = tmp_path_factory.mktemp("signals")
    for name, text in (("servo", SERVO), ("plant", PLANT), ("table", TABLE), ("named", NAMED), ("inline", INLINE)):
        (folder / f"{name}.toml").write_text(text)
    t = np.linspace(0.0, 2.0, 41)
    np.savez(folder / "ref.npz", t=t, f=np.sin(W * t))
    return folder


@pytest.fixture(scope="module")
def actuated_run(env, files):
    """The servo cart's actuated realization (u on x) saved at every RK4 step."""
    run = gpmegen.simulate(files / "servo.toml", t_end=T_END, dt=DT, backend="numpy")
    assert run.status == "complete"
    run.save(files / "servo.npz")
    return run


def double_integral_bound(epsilon, t_end, mass):
    """The largest move of a cart of ``mass`` in ``t_end`` from rest by a force of at most ``epsilon``."""
    return epsilon * t_end ** 2 / (2 * mass)


def test_an_expression_signal_is_its_expression_where_its_name_stands(env, files):
    named, inline = (gpmegen.load_model_file(files / f"{k}.toml") for k in ("named", "inline"))
    assert named.drives == inline.drives and named.constraints == inline.constraints
    assert named.signals == ()   # nothing to read at run time
    a, b = (gpmegen.load(model=m, backend="numpy") for m in (named, inline))
    for t in (0.0, 0.37, 1.9):
        assert np.array_equal(a.drive_forces(t, [0.1], [0.2]), b.drive_forces(t, [0.1], [0.2]))


@pytest.mark.parametrize("backend", ["numpy", pytest.param("c", marks=pytest.mark.requires_cc)])
def test_a_table_signal_is_within_its_bound_and_converges_at_second_order(env, files, backend):
    model = gpmegen.load(model=gpmegen.load_model_file(files / "table.toml"), backend=backend)
    t_fine = np.linspace(0.0, 2.0, 4001)
    exact = np.sin(W * t_fine)
    second = W ** 2   # max |d²/dt² sin(w t)|
    errors, bounds = [], []
    for n in (21, 41, 81):
        t = np.linspace(0.0, 2.0, n)
        bound = signals.error_bound(t[1] - t[0], second)
        bound_model = model.with_signals([signals.table("push", t, np.sin(W * t))])
        force = np.array([bound_model.drive_forces(s, [0.0], [0.0])[0] for s in t_fine])
        at_samples = [bound_model.drive_forces(s, [0.0], [0.0])[0] for s in t]
        assert np.array_equal(at_samples, np.sin(W * t))   # the samples themselves
        errors.append(np.abs(force - exact).max())
        bounds.append(bound)
        assert bounds[-1] / 2 < errors[-1] <= bounds[-1]   # held, and not by far
    orders = np.log2(np.array(errors[:-1]) / np.array(errors[1:]))
    assert np.all(np.abs(orders - 2) < 0.05), orders


@pytest.mark.requires_cc
def test_c_and_numpy_interpolate_alike(env, files, rng):
    model = gpmegen.load_model_file(files / "table.toml")
    c, numpy = (gpmegen.load(model=model, backend=b) for b in ("c", "numpy"))
    for s in rng.uniform(-0.5, 2.5, 50):   # outside the samples: held at the ends
        assert c.drive_forces(s, [0.0], [0.0])[0] == numpy.drive_forces(s, [0.0], [0.0])[0]


@pytest.mark.requires_cc
@pytest.mark.parametrize("method, step", [("rk4", DT), ("dop853", DT), ("radau", DT), ("scipy-radau", DT),
                                          # second order: its own error, (ω h)²-sized, below 1e-8 at h/4
                                          ("genalpha", DT / 4)])
def test_feeding_the_actuated_inputs_forward_reproduces_the_motion(env, files, actuated_run, method, step):
    u_second = M * A * W ** 4   # max |ü| of u = m A w² cos w t
    epsilon = signals.error_bound(DT, u_second)   # the table's samples are the run's, DT apart
    fed = gpmegen.simulate(files / "plant.toml", t_end=T_END, dt=step, save_dt=DT, backend="c", method=method,
                           feedforward=files / "servo.npz")
    assert fed.status == "complete"
    assert np.array_equal(fed["t"], actuated_run["t"])
    deviation = np.abs(fed.coordinate("x") - actuated_run.coordinate("x")).max()
    assert deviation <= 1e-8 + double_integral_bound(epsilon, T_END, M), deviation
    # the inputs at the samples themselves, where the interpolation is exact
    assert np.array_equal(fed["drive_forces"][:, 0], actuated_run["u"][:, 0])
    assert fed.meta["feedforward"] == str((files / "servo.npz").resolve())


def test_feedforward_adds_to_a_feedback_law(env, files, actuated_run, tmp_path):
    path = tmp_path / "held.toml"
    text = PLANT.replace("[[chain]]", "kp = 40.0\n\n[[chain]]", 1).replace('name = "plant_cart"', 'name = "held"')
    path.write_text(text + '\n[[drives]]\ncoordinate = "x"\nexpression = "kp*(A*(1 - cos(w*t)) - x)"\n')
    fed = feedforward.model(gpmegen.load_model_file(path), files / "servo.npz")
    assert fed.name == "held_ff" and [s.name for s in fed.signals] == ["ff_x"]
    loaded = gpmegen.load(model=fed, backend="numpy")
    for t, x in ((0.2505, 0.01), (0.7, -0.2)):
        ff = np.interp(t, actuated_run["t"], actuated_run["u"][:, 0])
        law = 40.0 * (A * (1 - np.cos(W * t)) - x)
        assert loaded.drive_forces(t, [x], [0.0])[0] == pytest.approx(law + ff, rel=1e-14)


def test_a_built_folder_reads_its_tables_as_its_manifest_names_them(env, files, tmp_path):
    model = gpmegen.load_model_file(files / "table.toml")
    gpmegen.load(model=model, backend="numpy", directory=tmp_path)
    run = gpmegen.simulate(tmp_path / "table_cart", t_end=0.5, dt=1e-2, backend="numpy")
    assert run["drive_forces"][:, 0] == pytest.approx(np.interp(run.t, np.linspace(0.0, 2.0, 41),
                                                                np.sin(W * np.linspace(0.0, 2.0, 41))), abs=1e-15)


def test_the_command_line_feeds_a_run_forward(env, files, actuated_run, capsys):
    out = files / "fed.npz"
    assert cli.main(["simulate", str(files / "plant.toml"), "--feedforward", str(files / "servo.npz"), "--t-end",
                     "0.1", "--dt", "1e-3", "--backend", "numpy", "--out", str(out)]) == 0
    assert "plant_ff" in capsys.readouterr().out
    fed = gpmegen.Results.load(out)
    assert fed.meta["feedforward"] == str((files / "servo.npz").resolve())
    assert np.array_equal(fed["drive_forces"][:, 0], actuated_run["u"][:101, 0])


# ---- refusals ------------------------------------------------------------------------------

def _refused(folder, text, capsys, *args) -> str:
    path = folder / "bad.toml"
    path.write_text(text)
    assert cli.main(["simulate", str(path), "--t-end", "0.5", "--dt", "1e-3", "--backend", "numpy",
                     "--out", str(folder / "bad_run.npz"), "--overwrite", *args]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) >= 1 and "Traceback" not in "\n".join(err)
    return err[-1]


@pytest.mark.parametrize("change, message", [
    (('expression = "push"', 'expression = "pushh"'), "unknown name 'pushh'; did you mean 'push'?"),
    (('name = "push"', 'name = "m"'), "signal 'm' has the name of a parameter in expressions"),
    (('name = "push"', 'name = "x"'), "signal 'x' has the name of a coordinate in expressions"),
    (('name = "push"', 'name = "x_dot"'), "the velocity of coordinate 'x'"),
    (('name = "push"', 'name = "vx_C"'), "a velocity coordinate of point 'C'"),
    (('name = "push"', 'name = "t"'), "signal 't' is reserved in generated code"),
    (('name = "push"', 'name = "sin"'), "signal 'sin' is reserved in generated code"),
    (('name = "push"', 'name = "Max"'), "signal 'Max' is reserved in generated code"),
    (('column = "f"', 'column = "f"\nexpression = "t"'), "either expression"),
    (('column = "f"\n', ''), "missing required key 'column'"),
])
def test_a_bad_signal_is_refused_in_one_line(env, files, capsys, change, message):
    assert message in _refused(files, TABLE.replace(*change), capsys)


def test_a_table_signal_in_a_constraint_is_refused(env, files, capsys):
    text = TABLE + '\n[[constraints]]\nname = "c"\nexpression = "x_C - push"\n'
    assert "is read from a table, so it may appear only in drives" in _refused(files, text, capsys)


def test_a_second_signal_of_one_name_is_refused(env, files, capsys):
    text = TABLE.replace("[[drives]]", '[[signals]]\nname = "push"\nexpression = "t"\n\n[[drives]]')
    assert "a second signal 'push'" in _refused(files, text, capsys)


@pytest.mark.parametrize("arrays, message", [
    ({"t": [0.0, 1.0, 2.0], "g": [0.0, 1.0, 2.0]}, "no column 'f' for signal 'push'; its columns are g"),
    ({"t": [0.0, 1.0, 2.0], "f": [0.0, np.nan, 2.0]}, "the values at sample 1 is nan"),
    ({"t": [0.0, np.inf, 2.0], "f": [0.0, 1.0, 2.0]}, "t at sample 1 is inf"),
    ({"t": [0.0, 1.0, 1.0], "f": [0.0, 1.0, 2.0]}, "t is not strictly increasing (t[1] = 1.0, t[2] = 1.0)"),
    ({"t": [0.0, 2.0, 1.0], "f": [0.0, 1.0, 2.0]}, "t is not strictly increasing"),
    ({"t": [0.0, 1.0, 2.0], "f": [0.0, 1.0]}, "must be two arrays of one length"),
    ({"t": [0.0, 1.0], "f": [[0.0, 1.0], [1.0, 2.0]]}, "must be two arrays of one length"),
    ({"t": [0.0], "f": [1.0]}, "1 sample(s), an interpolation needs two at least"),
    ({"f": [0.0, 1.0]}, "holds no times t"),
])
def test_a_bad_table_is_refused_in_one_line(env, files, capsys, tmp_path, arrays, message):
    np.savez(tmp_path / "ref.npz", **arrays)
    line = _refused(tmp_path, TABLE, capsys)
    assert message in line and str(tmp_path / "ref.npz") in line


def test_a_table_file_that_is_missing_or_not_npz_is_refused(env, files, capsys, tmp_path):
    assert "no such results file" in _refused(tmp_path, TABLE, capsys)
    (tmp_path / "ref.npz").write_text("t,f\n0,1\n")
    assert "not a results file (.npz) that can be read" in _refused(tmp_path, TABLE, capsys)


def test_a_run_beyond_the_table_is_refused_before_it_steps(env, files, capsys):
    with pytest.raises(SimulationError, match=r"the run's times 0 to 2\.5 s leave those of signal 'push', 0 to 2 s"):
        gpmegen.simulate(files / "table.toml", t_end=2.5, dt=1e-3, backend="numpy")
    assert cli.main(["simulate", str(files / "table.toml"), "--t-end", "2.5", "--backend", "numpy",
                     "--out", str(files / "beyond.npz")]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert "end the run by t = 2 s or give a table that covers it" in err[-1]
    assert not (files / "beyond.npz").exists() and not (files / "beyond.partial.npz").exists()


def test_a_model_of_python_checks_its_signals(env, files):
    plant = gpmegen.load_model_file(files / "plant.toml")
    signal = gpmegen.Signal("m", str(files / "ref.npz"), "f")
    with pytest.raises(ModelError, match="signal 'm' duplicates the parameter of the same name"):
        expand(dataclasses.replace(plant, signals=(signal,)))
    with pytest.raises(ModelError, match="signal 'vx_C' has the name of a time, velocity"):
        expand(dataclasses.replace(plant, signals=(dataclasses.replace(signal, name="vx_C"),)))
    with pytest.raises(ModelError, match="unknown name"):   # a drive naming a signal the model lacks
        expand(dataclasses.replace(plant, drives=(gpmegen.Drive("x", gpmegen.Signal("s", "a", "b").symbol),)))


def test_feedforward_refuses_a_run_without_inputs_and_names_that_do_not_match(env, files, actuated_run, tmp_path):
    other = files / "plant.toml"
    renamed = tmp_path / "renamed.toml"
    renamed.write_text(PLANT.replace('joint = "x"', 'joint = "y"'))
    with pytest.raises(ModelError, match=r"its inputs act on x, but the plant plant_cart has no coordinate x "
                                         r"\(its coordinates: y\)"):
        gpmegen.simulate(renamed, t_end=T_END, dt=DT, backend="numpy", feedforward=files / "servo.npz")
    np.savez(tmp_path / "ideal.npz", t=[0.0, 1.0], **{"lambda": [[0.0], [1.0]]}, constraint_names=["path"])
    with pytest.raises(ModelError, match="holds the multipliers lambda of an ideal realization, not the inputs u"):
        gpmegen.simulate(other, t_end=T_END, dt=DT, backend="numpy", feedforward=tmp_path / "ideal.npz")


def test_the_exports_refuse_a_model_that_reads_tables(env, files, tmp_path):
    model = gpmegen.load_model_file(files / "table.toml")
    with pytest.raises(ModelError, match="its drives read the table signals push, which gpmegen's runtime supplies"):
        casadi_export.render_casadi(model)
