"""Trust in what reaches generated code, and in the generated files that are used.

1. Free text of a model (description, parameter units and docs, the rebuild command with the
   model file's path) never leaves its comment (C) or docstring (Python), whatever it holds.
2. A model's names never meet the generator's own symbols and locals: a model gives the same
   results whatever its parameters, coordinates, bodies and points are called.
3. Generated files are used only as their manifest records them (sha256): a file edited or
   truncated by hand is built again when building is allowed, else refused with the fix.
"""

from __future__ import annotations

import ast
import dataclasses
import functools
import subprocess
import tempfile
from pathlib import Path

import numpy as np
import pytest
import sympy as sp
from conftest import skip_without_cc
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st

import gpmegen
from gpmegen.analysis.run.model_files import load_model_file
from gpmegen.cli import main
from gpmegen.codegen import backends, input_hash, render
from gpmegen.codegen.comments import PAIRED, comment_text
from gpmegen.codegen.render import read_manifest, stale_reason
from gpmegen.errors import ModelError, StaleModelError
from gpmegen.model import reference_model, shapes
from gpmegen.model.chain import (
    TIME,
    Body,
    Constraint,
    Drive,
    FlexibleLink,
    Joint,
    Model,
    Parameter,
    Point,
    RectangularSection,
    point_symbols,
    symbol,
)
from gpmegen.model.expand import expand
from gpmegen.runtime import ccompile, statics
from gpmegen.runtime.cmodel import CModel
from gpmegen.runtime.numpy_module import import_numpy_module

ROOT = Path(__file__).resolve().parents[1]
BACKENDS = ("numpy", "c")
C_FILES = backends.get("c").files


# --- 1. free text in comments and docstrings ---------------------------------------------------

# Pieces that end or bend a C comment or a Python string, or that some reader takes for a line
# break, mixed with arbitrary text.
DANGEROUS = ("*/", "/*", "*", "/", "?", "??/", "??=", "??(", "??'", "\\", "\\\n", "*\\\n/", '"', '"""',
             "'''", "'", "#", "\n", "\r", "\r\n", "\v", "\f", "\x00", "\x1b", "\x7f", "\x85", "\u2028",
             "\u2029", "\ud800", "é", "\U0001F600")
free_text = st.lists(st.one_of(st.sampled_from(DANGEROUS), st.text(max_size=4)), max_size=12).map("".join)


def _tiny_model(description="", unit="", doc="") -> Model:
    return Model(
        "tiny", (Parameter("m", 1.0, unit, doc),),
        (Joint("a", "revolute", "z"), Body("b", shapes.point_mass(symbol("m"), (1, 0, 0))), Point("E")),
        description=description,
    )


@given(text=free_text, multiline=st.booleans())
@settings(max_examples=500, deadline=None, suppress_health_check=[HealthCheck.too_slow])
def test_defect1_comment_text_keeps_to_the_safe_alphabet(text, multiline):
    out = comment_text(text, multiline)
    allowed = {chr(c) for c in range(0x20, 0x7F)} - {"\\", '"'} | ({"\n"} if multiline else set())
    assert set(out) <= allowed
    for k, char in enumerate(out):
        if char in PAIRED:  # never first, last or next to another of * / ?
            assert 0 < k < len(out) - 1 and out[k - 1] not in PAIRED and out[k + 1] not in PAIRED, out
    if set(text) <= allowed and not any(c in PAIRED for c in text):
        assert out == text  # ordinary text is left as it is


def test_defect1_comment_text_is_readable():
    assert comment_text("N m s/rad") == "N m s/rad"
    assert comment_text("kg*m^2, 1/s") == "kg*m^2, 1/s"
    assert comment_text("a */ b") == "a <U+002A><U+002F> b"
    assert comment_text("x ??/") == "x <U+003F><U+003F><U+002F>"
    assert comment_text("two\nlines\u2028", multiline=True) == "two\nlines<U+2028>"
    assert comment_text("two\nlines") == "two<U+000A>lines"


def _without_hash(files, model):
    digest = input_hash(model, BACKENDS)
    return {name: text.replace(digest, "INPUT_HASH") for name, text in files.items()}


def _c_tokens(files: dict) -> list[str]:
    """The C file, with the headers it includes (its own and the solver library's), after
    translation phases 1-4 (trigraphs, line splicing, comments, macros), as whitespace-separated
    tokens: what the compiler sees."""
    preprocess = [ccompile.find_compiler()[0], "-E", "-std=c99", "-trigraphs", "-P", f"-I{ccompile.solver_include()}",
                  "-x", "c", "-"]
    with tempfile.TemporaryDirectory() as include:
        Path(include, "model.h").write_text(files["model.h"])
        run = subprocess.run(preprocess, input=files["model.c"], cwd=include,
                             capture_output=True, text=True, check=True)
    return run.stdout.split()


def _python_code(source: str) -> str:
    """The module's syntax tree without its docstring."""
    tree = ast.parse(source)
    assert ast.get_docstring(tree) is not None
    return ast.dump(ast.Module(body=tree.body[1:], type_ignores=[]))


@pytest.mark.requires_cc
@given(description=free_text, command=free_text, unit=free_text, doc=free_text)
@example(description="a *??/\n/ int injected; /*", command="gpmegen build x *??/\n/int y;/*.toml", unit="", doc="")
@example(description='"""\nimport os\n"""', command="\\", unit='\\"""', doc="*/")
@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
def test_defect1_free_text_stays_in_its_comment_and_docstring(description, command, unit, doc):
    model = _tiny_model(description, unit, doc)
    files = _without_hash(render(model, BACKENDS, command=command), model)
    c_tokens, python_code = _neutral_code()
    assert _c_tokens(files) == c_tokens
    assert _python_code(files["model_numpy.py"]) == python_code
    assert all(text.isascii() for text in files.values())


@functools.cache
def _neutral_code() -> tuple:
    """What the compiler and Python see of the tiny model without free text: the same for every
    example, so made once."""
    neutral = _tiny_model()
    reference = _without_hash(render(neutral, BACKENDS, command=""), neutral)
    return _c_tokens(reference), _python_code(reference["model_numpy.py"])


EXPLOIT_MODEL = """\
schema = 1
name = "exploit"
description = '''a harmless line *??/
/ __attribute__((constructor)) static void payload(void) {{
extern int mkdir(const char *, unsigned); static const char d[] = {{{marker}, 0}}; mkdir(d, 0700); }} /*'''

[parameters]
m = 1.0

[[chain]]
joint = "a"
type = "revolute"
axis = "z"

[[chain]]
body = "b"
shape = {{ type = "point_mass", mass = "m", position = [1, 0, 0] }}

[[chain]]
point = "E"
"""


@pytest.mark.requires_cc
def test_defect1_trigraph_in_a_model_file_does_not_run_code_when_the_library_loads(tmp_path):
    # "??/" is a backslash under -std=c99, so "*??/<newline>/" closed the header comment and
    # the rest of the line was compiled: a constructor that ran when the library was loaded.
    marker = tmp_path / "payload_ran"
    path = tmp_path / "exploit.toml"
    path.write_text(EXPLOIT_MODEL.format(marker=", ".join(f"'{c}'" for c in str(marker))))
    model = gpmegen.load(model=load_model_file(path), backend="c", directory=tmp_path / "generated")
    assert model.n_dof == 1 and model.backend == "c"
    assert not marker.exists()
    source = (tmp_path / "generated" / "exploit" / "model.c").read_text()
    assert "*??/" not in source and "<U+003F><U+003F><U+002F>" in source


# --- 2. names of the model against the generator's own -----------------------------------------

# Each the name of something the generator made: intermediates x<k>, coordinates q_<name> and
# velocities qd_<name>, parameters printed p_<name>, C outputs out_<name>.
COLLIDING = dict(g="g", shear="out_M", young="p_g", thickness="q_theta1", mass="q_x3", density="qd_theta1",
                 offset="qd_x3", length="x0", stiffness="x12", width="x5", base="theta1", slider="x3",
                 hub="out_f", tip="x7", point="x9", constraint="x2")
# SymPy orders terms by the names of their symbols, so these names keep the order of the ones
# above (among themselves, against time t, the flexible link's psi1_1, theta1_1, phi1_1 and the
# generator's names): the two models are then the same code but for names, and their results
# agree bit for bit.
NEUTRAL = dict(g="g", shear="g_shear", young="h_young", thickness="i_thick", mass="j_mass", density="k_rho",
               offset="l_offset", length="u_length", stiffness="v_spring", width="w_width", base="rot",
               slider="w3", hub="hub", tip="tip", point="P", constraint="c")
DEFAULTS = dict(g=9.81, length=0.8, width=0.03, thickness=0.01, density=2700.0, young=7e10, shear=2.6e10,
                stiffness=50.0, mass=0.5, offset=0.2)


def _named_model(names: dict, label: str) -> Model:
    """An arm (spring-held revolute base, flexible link with 2 rfes, slider, tip mass, one
    position constraint and a drive) whose names are ``names``; the same model for any names."""
    P = {role: symbol(names[role]) for role in DEFAULTS}
    x, y, _ = point_symbols(names["point"])
    chain = (
        Joint(names["base"], "revolute", "z", stiffness=P["stiffness"]),
        Body(names["hub"], shapes.point_mass(P["mass"], (0.05, 0, 0))),
        FlexibleLink("1", P["length"], RectangularSection(P["width"], P["thickness"]), P["density"],
                     P["young"], P["shear"], n_rfe=2),
        Joint(names["slider"], "prismatic", "x"),
        Body(names["tip"], shapes.point_mass(P["mass"])),
        Point(names["point"], (0.1, 0, 0)),
    )
    return Model(
        f"names_{label}", tuple(Parameter(names[role], value) for role, value in DEFAULTS.items()), chain,
        gravity=(0, -P["g"], 0),
        drives=(Drive(names["base"], P["stiffness"] * sp.sin(TIME) / 100),),
        constraints=(Constraint(names["constraint"], x - P["offset"] - symbol(names["slider"]) / 2, 0, 10, 10),),
        dependent=(names["slider"],),
    )


def _results(model):
    rng = np.random.default_rng(7)
    q, qd = rng.uniform(-0.3, 0.3, model.n_dof), rng.uniform(-1, 1, model.n_dof)
    return dict(
        M=model.mass_matrix(q), f=model.forces(0.3, q, qd), points=model.point_positions(q),
        constraints=np.concatenate([np.ravel(v) for v in model.constraint_terms(0.3, q, qd)]),
        qdd=model.accelerations(0.3, q, qd), energies=model.energies(q, qd),
        statics=statics.locked(model, np.zeros(model.n_dof)),
    )


@pytest.mark.parametrize("backend", ["numpy", pytest.param("c", marks=pytest.mark.requires_cc)])
def test_defect2_names_of_generator_symbols_give_the_same_model(tmp_path, backend):
    # SymPy merged a parameter named x5 with the intermediate x5; the C build failed on a local
    # defined twice and the run fell back to NumPy with the wrong model.
    neutral = gpmegen.load(model=_named_model(NEUTRAL, "neutral"), backend=backend, directory=tmp_path)
    colliding = gpmegen.load(model=_named_model(COLLIDING, "colliding"), backend=backend, directory=tmp_path)
    assert colliding.backend == backend
    expected, got = _results(neutral), _results(colliding)
    for key in expected:
        np.testing.assert_array_equal(got[key], expected[key], err_msg=key)


def test_defect2_name_with_a_final_line_break_is_refused(tmp_path, capsys):
    # '$' matches before a final line break, so the pattern let "theta1\n" through.
    model = _named_model(dict(NEUTRAL, base="theta1\n"), "newline")
    with pytest.raises(ModelError) as exc:
        expand(model)
    assert "'theta1\\n' is not a valid name" in str(exc.value) and "\n" not in str(exc.value)
    path = tmp_path / "arm.toml"
    path.write_text((ROOT / "examples" / "planar_two_link.toml").read_text()
                    .replace('joint = "theta1"', 'joint = "theta1\\n"', 1))
    assert main(["build", str(path), "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert "chain[0].joint: coordinate 'theta1\\n' is not a valid name" in err and err.count("\n") == 1
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize("name", ["gpmegen", "GPMEGEN", "gpmegen_arm", "Gpmegen_model"])
def test_defect2_a_model_named_in_the_solver_librarys_c_namespace_is_refused(name, tmp_path, capsys):
    # A model's name prefixes its C names: a model named gpmegen declared gpmegen_gpme_jacobian
    # again, its C did not compile, and the command fell back to NumPy with the compiler's errors.
    with pytest.raises(ModelError, match=f"model name '{name}' would prefix its C names with '{name}_', the "
                                         r"solver library's own \(gpmegen_rk4, GPMEGEN_OK, ...\): choose another "
                                         f"name, e.g. 'my_{name}'"):
        expand(dataclasses.replace(_tiny_model(), name=name))
    path = tmp_path / "arm.toml"
    path.write_text((ROOT / "examples" / "planar_two_link.toml").read_text()
                    .replace('name = "planar_two_link_nrfe{nrfe}"', f'name = "{name}"', 1))
    assert main(["build", str(path), "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert f"name: model name '{name}' would prefix its C names" in err and err.count("\n") == 1
    assert not (tmp_path / "out").exists()


def test_defect2_names_beside_the_solver_librarys_namespace_are_models_like_any():
    for name in ("gpmegenic", "my_gpmegen", "gpmegen2"):
        assert expand(dataclasses.replace(_tiny_model(), name=name)).coordinates == ("a",)


@pytest.mark.parametrize("coordinate, taken", [("x_P", "coordinate x of point 'P'"),
                                               ("a_dot", "velocity of coordinate 'a'")])
def test_defect2_coordinate_named_like_a_constraint_symbol_is_refused(coordinate, taken):
    # A constraint expression naming x_P meant the coordinate or the point's x, whichever the
    # derivation happened to take last.
    model = _named_model(dict(NEUTRAL, base="a", slider=coordinate), "ambiguous")
    with pytest.raises(ModelError, match=f"coordinate '{coordinate}' has the name of the {taken}"):
        expand(model)


# --- 3. generated files checked against their manifest -----------------------------------------

def _edit(path):
    """A hand edit that leaves the file valid code."""
    path.write_text(path.read_text() + ("\n/* edited */\n" if path.suffix in (".c", ".h") else "\n# edited\n"))


def _truncate(path):
    data = path.read_bytes()
    path.write_bytes(data[: len(data) // 2])


TAMPERING = [pytest.param(name, change, id=f"{change.__name__[1:]}-{name}")
             for name in (*C_FILES, "model_numpy.py") for change in (_edit, _truncate)]


def _built(tmp_path):
    assert main(["build", "--nrfe", "1", "--out", str(tmp_path)]) == 0
    folder = tmp_path / "manipulator_nrfe1"
    return folder, {p.name: p.read_bytes() for p in folder.iterdir()}


@pytest.mark.parametrize("name, change", TAMPERING)
def test_defect3_build_does_not_report_a_tampered_folder_up_to_date(tmp_path, capsys, name, change):
    folder, original = _built(tmp_path)
    change(folder / name)
    capsys.readouterr()
    assert main(["build", "--nrfe", "1", "--out", str(tmp_path)]) == 0
    out, err = capsys.readouterr()
    assert "built in" in out and "up to date" not in out
    assert f"{folder / name} differs from the sha256 recorded in manifest.json" in err
    assert {p.name: p.read_bytes() for p in folder.iterdir()} == original


@pytest.mark.parametrize("name, change", TAMPERING)
def test_defect3_loading_a_tampered_file_builds_it_again(tmp_path, name, change):
    if name in C_FILES:
        skip_without_cc()
    folder, original = _built(tmp_path)
    change(folder / name)
    backend = "c" if name in C_FILES else "numpy"
    model = gpmegen.load("manipulator", nrfe=1, backend=backend, directory=tmp_path)
    assert model.backend == backend
    assert (folder / name).read_bytes() == original[name]


@pytest.mark.parametrize("name, change", TAMPERING)
def test_defect3_loading_a_tampered_file_without_building_is_refused(tmp_path, name, change):
    folder, _ = _built(tmp_path)
    change(folder / name)
    backend = "c" if name in C_FILES else "numpy"
    with pytest.raises(StaleModelError) as exc:
        gpmegen.load("manipulator", nrfe=1, backend=backend, directory=tmp_path, build=False)
    message = str(exc.value)
    assert message == (f"{folder / name} differs from the sha256 recorded in manifest.json (edited or truncated); "
                       f"rebuild it with 'gpmegen build --nrfe 1 --force'")


def test_defect3_c_file_changed_after_loading_the_module_is_not_compiled(tmp_path):
    # The C file is checked right before it is compiled, not only when the folder was found.
    folder, _ = _built(tmp_path)
    module = import_numpy_module(folder)
    _edit(folder / "model.c")
    with pytest.raises(StaleModelError, match="model.c differs from the sha256"):
        CModel(module, folder=folder, cache=tmp_path / "cache")
    assert not (tmp_path / "cache").exists()


@pytest.mark.requires_cc
def test_defect3_the_compiler_gets_the_text_that_was_read_not_the_file(tmp_path, fresh_cache):
    header = "const char *m_input_hash(void);\nint m_f(void);\n"
    source = "#include \"model.h\"\nconst char *m_input_hash(void) { return \"\"; }\nint m_f(void) { return %d; }\n"
    path = tmp_path / "model.c"
    path.write_text(source % 1)  # the file changed after its text was read and checked
    (tmp_path / "model.h").write_text("#error the header's file, not its text\n")
    _, lib, _ = ccompile.load_library(path, cache=fresh_cache, text=source % 2, header=header)
    assert lib.f() == 2


def test_defect3_manifest_that_is_no_json_object_is_stale_not_a_crash(tmp_path):
    folder, original = _built(tmp_path)
    (folder / "manifest.json").write_text("[]\n")
    with pytest.raises(StaleModelError, match="manifest.json is missing or unreadable; rebuild it with "
                                              "'gpmegen build --nrfe 1 --force'"):
        gpmegen.load("manipulator", nrfe=1, directory=tmp_path, build=False, backend="numpy")
    assert gpmegen.load("manipulator", nrfe=1, directory=tmp_path, backend="numpy").n_dof == 3
    assert (folder / "manifest.json").read_bytes() == original["manifest.json"]


@pytest.mark.parametrize("nrfe", [1, 5])
def test_defect3_committed_snapshots_verify(nrfe):
    folder = ROOT / "generated" / f"manipulator_nrfe{nrfe}"
    digest = input_hash(reference_model(nrfe), BACKENDS)
    assert stale_reason(folder, read_manifest(folder), digest, ("model_numpy.py", *C_FILES)) is None
