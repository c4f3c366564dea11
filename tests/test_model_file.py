"""Model description files: the reference manipulator as a file, the examples, and one test per
kind of bad file (message names the file, line and field; nothing is written)."""

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

import gpmegen
from gpmegen.analysis.run.model_files import load_model_file, locate, read_initial, read_model_file
from gpmegen.codegen import render
from gpmegen.errors import DerivationError, ModelError
from gpmegen.model import Body, reference_model
from gpmegen.model.expand import expand
from gpmegen.symbolic import derive

ROOT = Path(__file__).resolve().parents[1]
EXAMPLES = ROOT / "examples"
OTHER_EXAMPLES = ["planar_two_link.toml", "spatial_six_joint.toml", "nonholonomic.toml"]


@pytest.mark.parametrize("nrfe", [1, pytest.param(5, marks=pytest.mark.long)])
def test_manipulator_file_is_the_reference_model(nrfe):
    model = load_model_file(EXAMPLES / "manipulator.toml", nrfe)
    reference = reference_model(nrfe)
    assert model == reference
    assert repr(model) == repr(reference)
    assert render(model, ("numpy", "c")) == render(reference, ("numpy", "c"))


def test_manipulator_file_defaults_to_its_own_nrfe():
    assert load_model_file(EXAMPLES / "manipulator.toml") == reference_model(5)
    assert read_initial(EXAMPLES / "manipulator.toml") == {"theta1": 0.0, "psi2": np.pi / 4, "x3": 0.0}


@pytest.mark.parametrize("name", OTHER_EXAMPLES)
def test_example_parses_validates_and_derives(name):
    file = read_model_file(EXAMPLES / name)
    derivation = derive(file.model)
    links = [e for e in file.model.chain if type(e).__name__ == "FlexibleLink"]
    assert len(links) >= 1 and file.model.name.endswith(f"_nrfe{links[0].n_rfe}")
    assert set(file.initial) <= set(derivation.chain.coordinates)
    assert len(file.model.constraints) >= 1
    assert file.model.dependent is None or len(file.model.dependent) == len(file.model.constraints)
    rigid = load_model_file(EXAMPLES / name, nrfe=1)
    assert rigid.name.endswith("_nrfe1") and rigid.name != file.model.name


@pytest.mark.parametrize("name", OTHER_EXAMPLES)
def test_example_starts_on_its_constraints(name, tmp_path):
    file = read_model_file(EXAMPLES / name)
    model = gpmegen.load(model=file.model, directory=tmp_path, backend="numpy")
    q = np.zeros(model.n_dof)
    for coordinate, value in file.initial_values().items():
        q[model.index(coordinate)] = value
    phi, _, D, _ = model.constraint_terms(0.0, q, np.zeros(model.n_dof))
    assert np.max(np.abs(phi)) < 1e-9
    assert np.linalg.cond(D[:, model.dependent]) < 1e3
    assert np.all(np.linalg.eigvalsh(model.mass_matrix(q)) > 0)


def test_initial_values_follow_parameter_overrides(tmp_path):
    path = tmp_path / "m.toml"
    path.write_text(BASE.replace('q = { theta1 = 0.5 }', 'q = { theta1 = "2*L" }'))
    assert read_initial(path) == {"theta1": 1.0}
    assert read_initial(path, params={"L": 0.25}) == {"theta1": 0.5}


def test_nrfe_argument_replaces_the_default_but_not_a_links_own(tmp_path):
    path = tmp_path / "m.toml"
    path.write_text(BASE.replace('name = "arm"', 'name = "arm_nrfe{nrfe}"'))
    assert load_model_file(path).name == "arm_nrfe2"
    model = load_model_file(path, nrfe=4)
    assert model.name == "arm_nrfe4" and model.chain[2].n_rfe == 4
    path.write_text(BASE.replace("shear_modulus = 2.6e10", "shear_modulus = 2.6e10\nnrfe = 3"))
    assert load_model_file(path, nrfe=4).chain[2].n_rfe == 3
    with pytest.raises(ModelError, match="nrfe must be a whole number"):
        load_model_file(path, nrfe=0)


# --- bad files -----------------------------------------------------------------------------

BASE = '''\
schema = 1
name = "arm"
description = "one joint and a flexible link"
nrfe = 2
gravity = [0, "-g", 0]
dependent = ["theta1"]

[parameters]
g = 9.81
m = { value = 1.0, unit = "kg", doc = "hub mass" }
L = { value = 0.5, unit = "m" }

[[chain]]
joint = "theta1"
type = "revolute"
axis = "z"

[[chain]]
body = "hub"
shape = { type = "rod", mass = "m", length = "L", radius = 0.01 }

[[chain]]
flexible = "1"
length = "L"
section = { type = "circular", radius = 0.01 }
density = 2700
young_modulus = 7e10
shear_modulus = 2.6e10

[[chain]]
point = "E"

[[constraints]]
name = "height"
expression = "y_E - 0.1"
alpha = 10
beta = 10

[initial]
q = { theta1 = 0.5 }
'''


def test_base_file_is_valid(tmp_path):
    path = tmp_path / "base.toml"
    path.write_text(BASE)
    file = read_model_file(path)
    assert file.model.name == "arm" and file.initial == {"theta1": 0.5}
    derive(file.model)


# (id, [(old, new) replacements of BASE], text on the expected line, field, part of the message)
BAD = [
    ("toml-syntax", [('name = "arm"', 'name = "arm')], 'name = "arm', None, "TOML syntax error"),
    ("schema-missing", [("schema = 1\n", "")], None, "schema", "missing schema version"),
    ("schema-unsupported", [("schema = 1", "schema = 2")], "schema = 2", "schema", "unsupported schema 2"),
    ("name-missing", [('name = "arm"\n', "")], None, "name", "missing model name"),
    ("required-key", [('axis = "z"\n', "")], "[[chain]]", "chain[0]", "missing required key 'axis'"),
    ("unknown-key", [('axis = "z"', 'axis = "z"\nstifness = 100')], "stifness", "chain[0].stifness",
     "did you mean 'stiffness'"),
    ("unknown-top-key", [("nrfe = 2", "nrfe = 2\ngravty = 1")], "gravty", "gravty", "did you mean 'gravity'"),
    ("joint-type", [('type = "revolute"', 'type = "rotary"')], "rotary", "chain[0].type",
     "unknown joint type 'rotary'"),
    ("joint-axis", [('axis = "z"', 'axis = "w"')], 'axis = "w"', "chain[0].axis", "unknown axis 'w'"),
    ("negative-mass", [('mass = "m"', "mass = -2")], "mass = -2", "chain[1].shape.mass",
     "negative value -2; masses must be zero or positive"),
    ("negative-mass-default", [("m = { value = 1.0", "m = { value = -1.0")], 'mass = "m"', "chain[1].shape.mass",
     "-1 with the parameter defaults"),
    ("zero-length", [('length = "L"\nsection', "length = 0\nsection")], "length = 0", "chain[2].length",
     "zero value 0; lengths must be positive"),
    ("negative-density", [("density = 2700", "density = -2700")], "density", "chain[2].density",
     "negative value -2700"),
    ("zero-modulus", [("young_modulus = 7e10", "young_modulus = 0")], "young_modulus", "chain[2].young_modulus",
     "zero value 0"),
    ("not-a-number", [("radius = 0.01 }\ndensity", "radius = true }\ndensity")], "circular",
     "chain[2].section.radius", "expected a number or an expression string"),
    ("unknown-point", [('"y_E - 0.1"', '"y_F - 0.1"')], "y_F", "constraints[0].expression",
     "names no declared point 'F'"),
    ("unknown-symbol", [('"y_E - 0.1"', '"y_E - h_max"')], "h_max", "constraints[0].expression",
     "unknown name 'h_max'"),
    ("coordinate-in-chain", [('radius = 0.01 }\ndensity', 'radius = "0.01 + theta1" }\ndensity')], "circular",
     "chain[2].section.radius", "may appear only in drives and constraints"),
    ("no-coordinate", [('"y_E - 0.1"', '"t - 1"')], "t - 1", "constraints[0].expression",
     "does not depend on any coordinate"),
    ("fixed-point", [('[[chain]]\njoint = "theta1"', '[[chain]]\npoint = "B"\n\n[[chain]]\njoint = "theta1"'),
                     ('"y_E - 0.1"', '"y_B - 0.1"')], "y_B", "constraints[0].expression",
     "does not depend on any coordinate"),
    ("does-not-parse", [('"y_E - 0.1"', '"sin(y_E - 0.1"')], "sin(", "constraints[0].expression", "does not parse"),
    ("bad-operator", [('"y_E - 0.1"', '"y_E +* 0.1"')], "+*", "constraints[0].expression", "does not parse"),
    ("unsafe-expression", [('"y_E - 0.1"', '"y_E.__class__"')], "__class__", "constraints[0].expression",
     "is not allowed"),
    ("unsafe-call", [('"y_E - 0.1"', '"__import__(1)"')], "__import__", "constraints[0].expression",
     "double underscore"),
    ("reserved-name", [('joint = "theta1"', 'joint = "import"'), ('["theta1"]', '["import"]'),
                       ("theta1 = 0.5", "import = 0.5")], 'joint = "import"', "chain[0].joint", "reserved"),
    ("invalid-name", [('body = "hub"', 'body = "hub-1"')], "hub-1", "chain[1].body", "not a valid name"),
    ("duplicate-name", [('body = "hub"', 'body = "theta1"')], 'body = "theta1"', "chain[1].body",
     "duplicates the coordinate"),
    ("duplicate-parameter", [("g = 9.81", "g = 9.81\ntheta1 = 1.0")], 'joint = "theta1"', "chain[0].joint",
     "duplicates the parameter"),
    ("duplicate-label", [('[[chain]]\npoint = "E"', '[[chain]]\nflexible = "1"\nlength = "L"\nsection = '
                          '{ type = "circular", radius = 0.01 }\ndensity = 2700\nyoung_modulus = 7e10\n'
                          'shear_modulus = 2.6e10\n\n[[chain]]\npoint = "E"')],
     'flexible = "1"\nlength = "L"\nsection = { type = "circular", radius = 0.01 }\ndensity = 2700\n'
     'young_modulus = 7e10\nshear_modulus = 2.6e10\n\n[[chain]]\npoint', "chain[3].flexible", "label '1' is already used"),  # noqa: E501
    ("point-name-clash", [("g = 9.81", "g = 9.81\nx_E = 1.0")], 'point = "E"', "chain[3].point",
     "makes the name x_E"),
    ("velocity-name-clash", [("g = 9.81", "g = 9.81\ntheta1_dot = 1.0")], 'joint = "theta1"', "chain[0].joint",
     "coordinate 'theta1' makes the name theta1_dot, and parameter 'theta1_dot' has the name of the velocity of "
     "coordinate 'theta1' in constraint expressions; rename one (the other is parameters.theta1_dot, line 10)"),
    ("derived-name-made-twice", [('joint = "theta1"', 'joint = "y_F"'), ('["theta1"]', '["y_F"]'),
                                 ("theta1 = 0.5", "y_F = 0.5"),
                                 ('[[chain]]\npoint = "E"', '[[chain]]\npoint = "E"\n\n[[chain]]\npoint = "F_dot"')],
     'point = "F_dot"', "chain[4].point", "point 'F_dot' makes the name y_F_dot, the coordinate y of point 'F_dot' in "
     "constraint expressions, which is also the velocity of coordinate 'y_F'; rename one (the other is "
     "chain[0].joint, line 14)"),
    ("duplicate-body", [('[[chain]]\npoint = "E"', '[[chain]]\nbody = "hub"\nmass = 1\n\n[[chain]]\npoint = "E"')],
     'body = "hub"\nmass', "chain[3].body", "duplicates the body of the same name; rename one (the other is "
     "chain[1].body, line 19)"),
    ("constraint-order", [("beta = 10\n", "beta = 10\norder = 3\n")], "order = 3", "constraints[0].order",
     "order must be 0 (position), 1 (first order, linear in velocities), 2 (second order, linear in accelerations)"),
    ("constraint-order-boolean", [("beta = 10\n", "order = true\n")], "order = true", "constraints[0].order",
     "got True"),
    ("first-order-nonlinear", [('"y_E - 0.1"', '"vy_E^2 - 0.1"\norder = 1'), ("beta = 10\n", "")],
     '"vy_E^2', "constraints[0].expression", "linear in the velocities"),
    ("first-order-beta", [('"y_E - 0.1"', '"vy_E"\norder = 1')], "beta = 10", "constraints[0].beta",
     "beta applies to position constraints only"),
    ("velocity-in-position", [('"y_E - 0.1"', '"vy_E - 0.1"')], "vy_E", "constraints[0].expression",
     "only in first- and second-order constraints; set order = 1 or 2"),
    ("dependent-count", [('["theta1"]', '["theta1", "psi1_1"]')], "dependent", "dependent",
     "1 constraint(s) need as many"),
    ("dependent-unknown", [('["theta1"]', '["theta9"]')], "dependent", "dependent[0]", "'theta9' is not a coordinate"),
    ("dependent-twice", [('["theta1"]', '["theta1", "theta1"]')], "dependent", "dependent[1]",
     "'theta1' is listed twice"),
    ("initial-unknown", [("q = { theta1 = 0.5 }", "q = { theta9 = 0.5 }")], "theta9", "initial.q.theta9",
     "not a coordinate"),
    ("parameters-not-a-table", [("[parameters]\ng = 9.81\nm = { value = 1.0, unit = \"kg\", doc = \"hub mass\" }\n"
                                 "L = { value = 0.5, unit = \"m\" }\n", "parameters = 0\n")], "parameters = 0",
     "parameters", "expected a parameters table"),
    ("initial-q-not-a-table", [("q = { theta1 = 0.5 }", "q = 0")], "q = 0", "initial.q",
     "expected a table of coordinates"),
    ("drive-unknown", [("[initial]", '[[drives]]\ncoordinate = "theta9"\nexpression = "1"\n\n[initial]')],
     "theta9", "drives[0].coordinate", "unknown coordinate 'theta9'"),
    ("drive-twice", [("[initial]", '[[drives]]\ncoordinate = "theta1"\nexpression = "1"\n\n[[drives]]\n'
                                   'coordinate = "theta1"\nexpression = "2"\n\n[initial]')],
     'coordinate = "theta1"\nexpression = "2"', "drives[1].coordinate",
     "a second drive on 'theta1'; add the two expressions in one drive (the other is drives[0].coordinate, line 40)"),
    ("drive-acceleration", [("[initial]", '[[drives]]\ncoordinate = "theta1"\nexpression = "-theta1_ddot"\n\n'
                                         '[initial]')],
     '"-theta1_ddot"', "drives[0].expression", "a drive's law may use positions and velocities, not the "
     "acceleration theta1_ddot"),
    ("drive-point-acceleration", [("[initial]", '[[drives]]\ncoordinate = "theta1"\nexpression = "-ax_E"\n\n'
                                               '[initial]')],
     '"-ax_E"', "drives[0].expression", "not the point acceleration ax_E"),
    ("drive-unknown-name", [("[initial]", '[[drives]]\ncoordinate = "theta1"\nexpression = "-kp*theta1"\n\n'
                                         '[initial]')],
     '"-kp*theta1"', "drives[0].expression", "unknown name 'kp'"),
    ("drive-unsafe", [("[initial]", '[[drives]]\ncoordinate = "theta1"\nexpression = "theta1.__class__"\n\n'
                                   '[initial]')],
     "__class__", "drives[0].expression", "is not allowed"),
    ("text-injection", [('description = "one joint and a flexible link"', "description = 'x \"\"\" y'")],
     "description", "description", "cannot carry in a comment"),
    ("huge-power", [('"y_E - 0.1"', '"y_E - 9^9^9^9"')], "9^9^9^9", "constraints[0].expression", "too large"),
    ("nrfe-zero", [("nrfe = 2", "nrfe = 0")], "nrfe = 0", "nrfe",
     "nrfe must be a whole number ≥ 1 (1: a rigid link), got 0; write e.g. nrfe = 3"),
    ("link-nrfe-fraction", [("shear_modulus = 2.6e10", "shear_modulus = 2.6e10\nnrfe = 2.5")], "nrfe = 2.5",
     "chain[2].nrfe", "nrfe must be a whole number ≥ 1 (1: a rigid link), got 2.5"),
    ("nrfe-missing", [("nrfe = 2\n", "")], '[[chain]]\nflexible', "chain[2]", "no n_rfe for this flexible link"),
    # comparisons only as Piecewise conditions, one each; (value, True) last
    ("comparison-outside-piecewise", [('"y_E - 0.1"', '"y_E - (t < 1)"')], "t < 1", "constraints[0].expression",
     "the comparison '<' may only be the condition of a Piecewise pair"),
    ("comparison-in-a-function", [('"y_E - 0.1"', '"y_E - sin(t >= 1)"')], "t >= 1", "constraints[0].expression",
     "the comparison '>=' may only be the condition of a Piecewise pair"),
    ("chained-comparison", [('"y_E - 0.1"', '"y_E - Piecewise((t, 0 < t < 1), (1, True))"')], "0 < t < 1",
     "constraints[0].expression", "one per pair"),
    ("equality-condition", [('"y_E - 0.1"', '"y_E - Piecewise((t, t == 1), (1, True))"')], "t == 1",
     "constraints[0].expression", "character '=' is not allowed"),
    ("piecewise-without-default", [('"y_E - 0.1"', '"y_E - Piecewise((t, t < 1))"')], "Piecewise((t, t < 1))",
     "constraints[0].expression", "Piecewise must end with the pair (value, True)"),
    ("piecewise-default-first", [('"y_E - 0.1"', '"y_E - Piecewise((t, True), (1, t < 2))"')], "(t, True)",
     "constraints[0].expression", "a pair after (value, True) is never used"),
    ("piecewise-not-a-pair", [('"y_E - 0.1"', '"y_E - Piecewise(t, (1, True))"')], "Piecewise(t,",
     "constraints[0].expression", "each argument of Piecewise is a pair (value, condition)"),
    ("piecewise-no-condition", [("[initial]", '[[drives]]\ncoordinate = "theta1"\nexpression = '
                                              '"Piecewise((t, t), (0, True))"\n\n[initial]')],
     "Piecewise((t, t)", "drives[0].expression", "a Piecewise pair is (value, condition) with one comparison"),
    ("true-outside-piecewise", [('"y_E - 0.1"', '"y_E - True"')], "y_E - True", "constraints[0].expression",
     "True may only be the whole condition of the last Piecewise pair"),
    ("condition-not-real", [('"y_E - 0.1"', '"y_E - Piecewise((t, t < sqrt(-1)), (1, True))"')], "sqrt(-1)",
     "constraints[0].expression", "a condition compares values that are not real"),
]


def _line_of(text, needle):
    return text[: text.index(needle)].count("\n") + 1


@pytest.mark.parametrize("case", BAD, ids=[case[0] for case in BAD])
def test_bad_file_names_file_line_and_field(case, tmp_path, generated_elsewhere):
    _, replacements, needle, field, problem = case
    text = BASE
    for old, new in replacements:
        assert old in text, old
        text = text.replace(old, new, 1)
    path = tmp_path / "bad.toml"
    path.write_text(text)
    generated_before = sorted(p.name for p in generated_elsewhere.rglob("*"))
    with pytest.raises(ModelError) as info:
        load_model_file(path)
    message = str(info.value)
    line = 1 if needle is None else _line_of(text, needle)
    prefix = f"{path}:{line}: " + (f"{field}: " if field else "")
    assert message.startswith(prefix), message
    assert problem in message, message
    assert "\n" not in message
    assert [p.name for p in tmp_path.iterdir()] == ["bad.toml"]
    assert sorted(p.name for p in generated_elsewhere.rglob("*")) == generated_before


def test_missing_file_is_a_model_error(tmp_path):
    with pytest.raises(ModelError, match="cannot read the model file"):
        load_model_file(tmp_path / "nowhere.toml")


def test_derivation_error_is_located_in_the_file(tmp_path):
    """A point on the joint's axis does not move along x: the derivation finds the constraint
    row empty, and locate() names the constraint's place in the file."""
    text = BASE.replace('"y_E - 0.1"', '"x_C - 0.1"').replace(
        '[[chain]]\nbody = "hub"', '[[chain]]\npoint = "C"\n\n[[chain]]\nbody = "hub"')
    path = tmp_path / "axis.toml"
    path.write_text(text)
    model = load_model_file(path)
    with pytest.raises(DerivationError) as info:
        derive(model)
    located = locate(path, info.value)
    assert isinstance(located, DerivationError)
    assert str(located).startswith(f"{path}:{_line_of(text, 'x_C - 0.1')}: constraints[0].expression: "), str(located)
    assert "does not depend on any coordinate" in str(located)


def test_a_file_read_locates_later_errors_without_reading_it_again(tmp_path):
    """ModelFile.locate maps the error's subject to the line from the text read once: the file
    may be gone by the time the derivation fails."""
    text = BASE.replace('"y_E - 0.1"', '"x_C - 0.1"').replace(
        '[[chain]]\nbody = "hub"', '[[chain]]\npoint = "C"\n\n[[chain]]\nbody = "hub"')
    path = tmp_path / "axis.toml"
    path.write_text(text)
    file = read_model_file(path)
    path.unlink()
    with pytest.raises(DerivationError) as info:
        derive(file.model)
    assert info.value.subject == ("constraints", 0, "expression")
    located = file.locate(info.value)
    assert type(located) is DerivationError and located.subject == info.value.subject
    assert str(located) == f"{path}:{_line_of(text, 'x_C - 0.1')}: constraints[0].expression: {info.value}"


def test_model_errors_name_their_field_without_a_file():
    """expand() says which field of a Model built in Python is at fault, as a path."""
    model = reference_model(1)
    clash = Body("theta1", model.chain[1].pseudo_inertia)
    with pytest.raises(ModelError) as info:
        expand(replace(model, chain=model.chain[:1] + (clash,) + model.chain[2:]))
    assert (info.value.subject, info.value.other) == (("chain", 1, "body"), ("chain", 0, "joint"))
    constraint = replace(model.constraints[0], order=True)
    with pytest.raises(ModelError, match="order must be 0") as info:
        expand(replace(model, constraints=(constraint,) + model.constraints[1:]))
    assert info.value.subject == ("constraints", 0, "order")


def test_lines_are_found_through_subtables_multiline_arrays_and_strings(tmp_path):
    text = '''\
schema = 1
name = "alt"   # a comment with [brackets] and "quotes"
description = """
[[chain]] inside a string is not a header
"""

[parameters.L]
value = 0.5

[[chain]]
joint = "q1"
type = "revolute"
axis = "z"

[[chain]]
body = "b"
mass = 1.0
inertia = [
  [0.01, 0, 0],
  [0, 0.02, 0],
  [0, 0, 0.02],
]

[[chain]]
body = "c"
[chain.shape]
type = "bar"
mass = 1
length = "L"
width = 0.02
thickness = -0.01
'''
    path = tmp_path / "alt.toml"
    path.write_text(text)
    with pytest.raises(ModelError) as info:
        load_model_file(path)
    assert str(info.value).startswith(f"{path}:{_line_of(text, 'thickness = -0.01')}: chain[2].shape.thickness: ")
    path.write_text(text.replace("thickness = -0.01", "thickness = 0.01"))
    model = load_model_file(path)
    assert [p.name for p in model.parameters] == ["L"] and model.dependent is None
