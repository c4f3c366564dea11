"""Mutated model files through ``gpmegen build``: the reference manipulator's file, a file
giving flexible links in every way (sections by stiffness, tube and I; freedoms; a prescribed
joint) and the constraints of the manipulator's variant with a second-order constraint, with one
field replaced (wrong types; negative, zero, huge, non-finite numbers; code-injection attempts, very
long and non-ASCII strings), a key deleted, renamed or added, or a stray line inserted. The
build exits 0, 2 (the file is at fault: one located line) or 1 (an honest runtime failure),
never raises or shows a traceback, writes no model folder when it fails, and what it writes when
it succeeds is valid Python and C."""

from __future__ import annotations

import io
import math
import re
import subprocess
import tempfile
import tokenize
import tomllib
from pathlib import Path

import pytest
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st

from gpmegen.cli import main
from gpmegen.errors import BuildError
from gpmegen.runtime import ccompile
from gpmegen.runtime.ccompile import find_compiler

ROOT = Path(__file__).resolve().parents[1]
SOURCE = ROOT / "examples" / "manipulator.toml"
BASE_TEXT = SOURCE.read_text()
BASE = tomllib.loads(BASE_TEXT)
LINKS_TEXT = (ROOT / "tests" / "models" / "flexible_sections.toml").read_text()

try:
    CC = find_compiler()
except BuildError:
    CC = None


# --- a tiny TOML writer ------------------------------------------------------------------------

def _string(s: str) -> str:
    out = []
    for c in s:
        if c == '"':
            out.append('\\"')
        elif c == "\\":
            out.append("\\\\")
        elif ord(c) < 0x20 or ord(c) == 0x7F:
            out.append(f"\\u{ord(c):04X}")
        else:
            out.append(c)
    return '"' + "".join(out) + '"'


def _key(k: str) -> str:
    return k if re.fullmatch(r"[A-Za-z0-9_-]+", k) else _string(k)


def _value(v) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        if math.isnan(v):
            return "nan"
        if math.isinf(v):
            return "inf" if v > 0 else "-inf"
        return repr(v)
    if isinstance(v, str):
        return _string(v)
    if isinstance(v, list):
        return "[" + ", ".join(_value(x) for x in v) + "]"
    if isinstance(v, dict):
        return "{ " + ", ".join(f"{_key(k)} = {_value(x)}" for k, x in v.items()) + " }" if v else "{}"
    raise TypeError(type(v))


def _is_table_array(v) -> bool:
    return isinstance(v, list) and bool(v) and all(isinstance(x, dict) for x in v)


def dumps(data: dict) -> str:
    """TOML text of ``data``: top-level values, then [tables] and [[arrays of tables]] (their
    own nested tables inline)."""
    lines = [f"{_key(k)} = {_value(v)}" for k, v in data.items()
             if not isinstance(v, dict) and not _is_table_array(v)]
    for k, v in data.items():
        if isinstance(v, dict):
            lines += ["", f"[{_key(k)}]"] + [f"{_key(a)} = {_value(b)}" for a, b in v.items()]
        elif _is_table_array(v):
            for item in v:
                lines += ["", f"[[{_key(k)}]]"] + [f"{_key(a)} = {_value(b)}" for a, b in item.items()]
    return "\n".join(lines) + "\n"


def _same(a, b) -> bool:
    if isinstance(a, float) and isinstance(b, float) and math.isnan(a) and math.isnan(b):
        return True
    if type(a) is not type(b):
        return False
    if isinstance(a, dict):  # order within a table is kept; top-level tables move after the values
        return set(a) == set(b) and all(_same(a[k], b[k]) for k in a)
    if isinstance(a, list):
        return len(a) == len(b) and all(_same(x, y) for x, y in zip(a, b))
    return a == b


@pytest.mark.parametrize("text", [BASE_TEXT, LINKS_TEXT])
def test_writer_round_trips_the_example(text):
    base = tomllib.loads(text)
    assert _same(tomllib.loads(dumps(base)), base)


# --- mutations ---------------------------------------------------------------------------------

def _nodes(obj, prefix=()):
    """Paths of every value below ``obj`` (dict keys and list indices)."""
    items = obj.items() if isinstance(obj, dict) else enumerate(obj) if isinstance(obj, list) else ()
    for k, v in items:
        yield prefix + (k,)
        yield from _nodes(v, prefix + (k,))


def _at(data, path):
    for part in path:
        data = data[part]
    return data


class Base:
    """A file to mutate: its text and the paths of its values, keys, tables and texts."""

    def __init__(self, text: str):
        self.text = text
        data = tomllib.loads(text)
        self.nodes = list(_nodes(data))
        self.keys = [p for p in self.nodes if isinstance(p[-1], str)]
        self.tables = [()] + [p for p in self.nodes if isinstance(_at(data, p), dict)]
        # text reaching the code
        self.texts = [("description",), ("name",)] + [p for p in self.nodes if p[-1] in ("doc", "unit")]


MANIPULATOR, LINKS = Base(BASE_TEXT), Base(LINKS_TEXT)

# Expressions naming accelerations: allowed, nonlinear or out of place in a constraint.
ACCELERATIONS = [
    "ax_E", "theta1_ddot", "x3_ddot - 1", "ax_E^2", "ax_E*az_E", "vx_E*ax_E + vz_E*az_E", "sin(ay_E)",
    "Abs(ax_E)", "ax_E/ay_E", "x_E*az_E - z_E*ax_E", "theta1_ddot*theta1_dot^2", "Piecewise((ax_E, t < 1), (0, True))",
    "Heaviside(ay_E)", "ay_E_ddot", "ax_F", "psi2_1_ddot", "(vx_E^2 + vz_E^2)^(3/2)*ay_E",
]
INJECTIONS = [
    "__import__('os')", "__import__('os').system('touch gpmegen_pwned')", "().__class__.__bases__",
    "eval('1')", "exec('x=1')", "lambda: 0", "open('/etc/passwd').read()", '"""', "'''", "*/", "/*", "\\",
    '"', "'", "\\n", "#", "#include <stdlib.h>", "\n", "\r\n", "\x00", "\x7f", "\t", "a\nimport os", "*/ int x; /*",
    '""" ; import os ; """', "{nrfe}", "{0}", "%s", "${HOME}", "$(id)", "`id`", "; rm -rf /", "../../etc",
    "a" * 300, "x" * 2500, "θ1", "ψ2", "名前", "é", "\u202e", "\u200b", "\U0001F600", "ﬁ", "İ", "", " ",
    "import", "class", "def", "None", "True", "lambda", "pi", "I", "E", "N", "S", "Q", "O", "oo", "zoo", "nan",
    "Symbol", "Integer", "Float", "Rational", "sin", "t", "theta1", "psi2", "x3", "psi2_1", "x_E", "vx_E",
    "theta1_dot", "g", "L2", "_", "1", "1e999", "-1e999", "1e-999", "9^9^9^9", "2**2**2**2**2", "exp(1000)",
    "exp(exp(100))", "sqrt(-1)", "1/0", "0/0", "log(0)", "Min()", "atan2(1)", "sin(1, 2)", "((((((1))))))",
    "(" * 200 + "1" + ")" * 200, "1" + "+1" * 900, "-" * 50 + "1", "1e308*1e308", "L2*1e300", "-L2", "0*L2",
    "revolute", "prismatic", "cylinder", "bar", "rod", "point_mass", "rectangular", "circular", "x", "y", "z",
    "tube", "I", "stiffness", "u", "psi", "theta", "phi", "PSI", "W*t", "theta1 - t",
    "auto", "Abs(-1)", "Max(0, -1)", "t0 - 5", "h1 - 0.6",
    "t" + "**t" * 300, "h1" + "**h1" * 300, "x_E" + "**x_E" * 300,   # deep power towers
    "t < 1", "1 < 2 < 3", "Piecewise((t, t < t0), (1, True))", "Piecewise((x_E, x_E > 0.1), (0.1, True))",   # switches
    "Piecewise((t, t < 1))", "Piecewise((1, True), (t, t < 1))", "Piecewise((t, (t < 1)), (0, True))",
    "Piecewise((t, t <= sqrt(-1)), (0, True))", "Heaviside(t - t0)", "Heaviside(x_E, 1)", "Abs(x_E - 0.1)",
    "Min(t, t0)*x_E", "Max(Abs(Abs(x_E) - 0.1), Min(t, 1))",
    *ACCELERATIONS,
]
NUMBERS = [0, -1, 1, 2, 3, 100, -(2 ** 63), 2 ** 63, 10 ** 30, -(10 ** 400), 0.0, -0.0, -1.0, 0.5, 1e-320, 1e-300,
           1e300, 1.7976931348623157e308, -1e308, float("nan"), float("inf"), float("-inf")]

scalars = st.one_of(
    st.sampled_from(INJECTIONS),
    st.sampled_from(NUMBERS),
    st.booleans(),
    st.integers(),
    st.floats(),
    st.text(max_size=12),
)
values = st.recursive(
    scalars,
    lambda children: st.one_of(st.lists(children, max_size=4),
                               st.dictionaries(st.sampled_from(INJECTIONS[:20]) | st.text(max_size=6), children,
                                               max_size=3)),
    max_leaves=6,
)
keys = st.one_of(st.sampled_from(["joint", "body", "flexible", "point", "translation", "rotations", "shape", "mass",
                                  "center", "inertia", "stiffness", "damping", "nrfe", "order", "alpha", "beta",
                                  "value", "unit", "doc", "q", "schema", "name", "torsion_constant", "position",
                                  "t", "x_E", "theta1_dot", "ax_E", "theta1_ddot", "pi", "import", "freedoms",
                                  "prescribed", "EIz", "GJ", "rhoA", "rhoIy", "EA", "outer_diameter", "inner_diameter",
                                  "height", "web_thickness",
                                  "section", "dependent", "density"]),
                 st.sampled_from(INJECTIONS), st.text(max_size=8))

STRAY_LINES = ['"""', "*/", "[[chain]]", "[parameters]", "[initial]", 'x = __import__("os")', "schema = 1",
               "key = 'unterminated", "[[chain]]\njoint = 1", "g = 1", "[[constraints]]", "= 1", "\x00", "}",
               'name = "again"', "[chain]", "a.b.c = 1"]


@st.composite
def mutations(draw, base=MANIPULATOR):
    """(label, TOML text) of one mutation of the file ``base``."""
    op = draw(st.sampled_from(["replace", "replace", "replace", "text", "delete", "rename", "add", "line"]))
    if op == "line":
        lines = base.text.splitlines()
        k = draw(st.integers(0, len(lines)))
        stray = draw(st.sampled_from(STRAY_LINES) | st.text(max_size=20))
        return f"insert {stray!r} at line {k + 1}", "\n".join(lines[:k] + [stray] + lines[k:]) + "\n"
    data = tomllib.loads(base.text)
    if op in ("replace", "text"):
        path = draw(st.sampled_from(base.nodes if op == "replace" else base.texts))
        value = draw(values if op == "replace" else st.sampled_from(INJECTIONS) | st.text())
        _at(data, path[:-1])[path[-1]] = value
        label = f"{path} = {value!r}"
    elif op == "delete":
        path = draw(st.sampled_from(base.nodes))
        del _at(data, path[:-1])[path[-1]]
        label = f"del {path}"
    elif op == "rename":
        path = draw(st.sampled_from(base.keys))
        new = draw(keys)
        parent = _at(data, path[:-1])
        if new in parent:
            return f"rename {path} to existing {new!r} (no-op)", dumps(data)
        items = [(new if k == path[-1] else k, v) for k, v in parent.items()]
        parent.clear()
        parent.update(items)
        label = f"rename {path} -> {new!r}"
    else:
        path = draw(st.sampled_from(base.tables))
        new, value = draw(keys), draw(values)
        _at(data, path)[new] = value
        label = f"add {path + (new,)} = {value!r}"
    text = dumps(data)
    assert _same(tomllib.loads(text), data), label  # the writer is faithful
    return label, text


def _check_generated(folder: Path, label: str):
    """What a successful build wrote is Python and C that parse (text never escapes comments),
    the Python module runs, and its constants are finite doubles."""
    files = {p.name for p in folder.iterdir()}
    assert {"manifest.json", "model.c", "model_numpy.py"} <= files, (label, files)
    source = (folder / "model_numpy.py").read_text()
    code = compile(source, str(folder / "model_numpy.py"), "exec")
    exec(code, {"__name__": "gpmegen_fuzz_generated"})  # defines functions and DEFAULTS only
    for tok in tokenize.generate_tokens(io.StringIO(source).readline):
        if tok.type == tokenize.NUMBER:
            assert math.isfinite(float(tok.string)), (label, f"line {tok.start[0]}: {tok.string[:40]}")
        elif tok.type == tokenize.NAME:
            assert tok.string not in ("inf", "nan", "oo", "zoo"), (label, f"line {tok.start[0]}: {tok.line}")
    if CC:
        done = subprocess.run([*CC, "-fsyntax-only", "-w", f"-I{ccompile.solver_include()}", str(folder / "model.c")],
                              capture_output=True, text=True)
        assert done.returncode == 0, (label, done.stderr[:2000])


def _mutated(path, value, text=BASE_TEXT) -> tuple[str, str]:
    data = tomllib.loads(text)
    _at(data, path[:-1])[path[-1]] = value
    return f"{path} = {value!r}", dumps(data)


SETTINGS = dict(deadline=None, derandomize=True, suppress_health_check=[
    HealthCheck.function_scoped_fixture, HealthCheck.too_slow, HealthCheck.data_too_large])


def _fuzzed(strategy, regressions, count):
    """A test that builds the ``regressions`` (cases this fuzzer found, kept) and then ``count``
    random mutations drawn from ``strategy`` (the same ones on every run: derandomized)."""
    @settings(max_examples=count, **SETTINGS)
    @given(mutation=strategy)
    def test(mutation, tmp_path, capsys, monkeypatch):
        _builds_or_fails_cleanly(mutation, tmp_path, capsys, monkeypatch)

    for mutation in reversed(regressions):
        test = example(mutation=mutation)(test)
    return test


#: Each sweep runs twice: a sample of its random mutations in ``make test`` (every regression
#: case, and as many random ones as the sample size) and all of them in ``make check-c`` (long).
SAMPLE = 0.1

# Explicit cases first (found by this fuzzer; kept as regressions), then the random ones.
BASE_REGRESSIONS = [
    _mutated(("parameters", "beta_circle", "\r\n"), 2),            # key with a line break
    _mutated(("parameters", "m1", "value"), -(10 ** 400)),           # int beyond double range
    _mutated(("chain", 2, "translation", 1), 10 ** 400),
    _mutated(("chain", 7, "position", 0), "L3 + 1e308*1e308"),      # constant overflow
    _mutated(("drives", 0, "expression"), "t" + "**t" * 300),        # deep power tower
    _mutated(("chain", 2, "translation", 1), "h1" + "**h1" * 300),
    _mutated(("constraints", 1, "expression"),                       # a switch: builds, warns
             "y_E - y_c - A*Piecewise((cos(2*pi*t/T), t < T), (1, True))"),
    _mutated(("drives", 0, "expression"), "tdr0*Heaviside(t - t0) + Piecewise((t, t <= t0), (t0, True))"),
]
test_mutated_model_file_builds_or_fails_cleanly = _fuzzed(mutations(), BASE_REGRESSIONS, int(300 * SAMPLE))
test_mutated_model_file_builds_or_fails_cleanly_all = pytest.mark.long(
    _fuzzed(mutations(), BASE_REGRESSIONS, 300))


# The new keys, with values at their edges: a held rotation named twice, none, a law that names
# its own coordinate, a section by stiffness with the material added, a tube without its wall.
LINKS_REGRESSIONS = [
    _mutated(("chain", 1, "freedoms"), ["psi", "psi"], LINKS_TEXT),
    _mutated(("chain", 1, "freedoms"), [], LINKS_TEXT),
    _mutated(("chain", 1, "freedoms", 0), [], LINKS_TEXT),     # an unhashable entry
    _mutated(("chain", 0, "prescribed"), "theta1 + t", LINKS_TEXT),
    _mutated(("chain", 1, "density"), 2700, LINKS_TEXT),
    _mutated(("chain", 3, "section", "inner_diameter"), "D", LINKS_TEXT),
    _mutated(("dependent",), ["theta1"], LINKS_TEXT),
]
test_mutated_flexible_links_build_or_fail_cleanly = _fuzzed(mutations(LINKS), LINKS_REGRESSIONS, int(150 * SAMPLE))
test_mutated_flexible_links_build_or_fail_cleanly_all = pytest.mark.long(
    _fuzzed(mutations(LINKS), LINKS_REGRESSIONS, 150))


SECOND_ORDER_TEXT = (ROOT / "examples" / "manipulator_tangential.toml").read_text()
SECOND_ORDER_FIELDS = ("expression", "order", "alpha", "beta", "name")


@st.composite
def second_order_mutations(draw):
    """(label, TOML text): one field of a constraint of the example with a second-order
    constraint replaced or added, mostly by expressions that name accelerations."""
    data = tomllib.loads(SECOND_ORDER_TEXT)
    k = draw(st.integers(0, len(data["constraints"]) - 1))
    key = draw(st.sampled_from(SECOND_ORDER_FIELDS))
    value = draw(st.sampled_from(ACCELERATIONS) | st.sampled_from([0, 1, 2, 3, -2, 2.0, "2", True])
                 | st.sampled_from(INJECTIONS) | values)
    data["constraints"][k][key] = value
    return f"constraints[{k}].{key} = {value!r}", dumps(data)


SECOND_ORDER_REGRESSIONS = [
    ("constraints[2].expression = 'ax_E^2'",
     SECOND_ORDER_TEXT.replace('"(z_E*ax_E - x_E*az_E)/r_Ea - a0*sin(2*pi*t/Ta)"', '"ax_E^2"')),
    ("constraints[0].order = 2", SECOND_ORDER_TEXT.replace("order = 0", "order = 2", 1)),
    ("constraints[0].order = []", SECOND_ORDER_TEXT.replace("order = 0", "order = []", 1)),  # unhashable
    ("constraints[2].order = 1", SECOND_ORDER_TEXT.replace("order = 2", "order = 1", 1)),
]
test_mutated_second_order_constraint_builds_or_fails_cleanly = _fuzzed(
    second_order_mutations(), SECOND_ORDER_REGRESSIONS, int(80 * SAMPLE))
test_mutated_second_order_constraint_builds_or_fails_cleanly_all = pytest.mark.long(
    _fuzzed(second_order_mutations(), SECOND_ORDER_REGRESSIONS, 80))


def _builds_or_fails_cleanly(mutation, tmp_path, capsys, monkeypatch):
    """``gpmegen build`` of the mutated file exits 0, 1 or 2 as the module's doc says."""
    label, text = mutation
    monkeypatch.chdir(tmp_path)  # an injected command would leave ./gpmegen_pwned; stray writes show here
    work = Path(tempfile.mkdtemp(dir=tmp_path))
    path = work / "model.toml"
    path.write_text(text, encoding="utf-8")
    out = work / "out"
    capsys.readouterr()
    try:
        code = main(["build", str(path), "--nrfe", "1", "--out", str(out)])
    except (Exception, SystemExit) as exc:  # main must return a code, whatever the file holds
        pytest.fail(f"{label}: main raised {type(exc).__name__}: {exc}")
    stdout, stderr = capsys.readouterr()
    assert "Traceback" not in stdout + stderr, (label, stderr)
    assert "internal error" not in stderr, (label, stderr.strip().split("\n")[-1:])
    assert code in (0, 1, 2), (label, code, stderr)
    assert sorted(p.name for p in work.iterdir()) == sorted(["model.toml"] + (["out"] if out.exists() else []))
    if code == 0:
        folders = [p for p in out.iterdir() if p.is_dir()]
        assert len(folders) == 1, (label, folders)
        _check_generated(folders[0], label)
    assert not (tmp_path / "gpmegen_pwned").exists(), label
    assert all(p.is_dir() and p.name.startswith("tmp") for p in tmp_path.iterdir()), (label, list(tmp_path.iterdir()))
    if code == 0:
        return
    lines = stderr.strip().split("\n")
    # one line per message: a name or text from the file never breaks the error line
    assert all(line.startswith("gpmegen") for line in lines), (label, lines)
    last = lines[-1]
    assert last.startswith("gpmegen build: error: "), (label, last)
    if code == 2:   # the file is at fault: the message says where
        assert last.startswith(f"gpmegen build: error: {path}:"), (label, last)
    # no model folder (nor a temporary one) is left; only the build's lock file may remain
    left = [p.name for p in out.iterdir()] if out.exists() else []
    assert all(name.startswith(".") and name.endswith(".lock") for name in left), (label, code, last, left)
