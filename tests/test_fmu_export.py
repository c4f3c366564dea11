"""The FMU export (``gpmegen export --format fmu``, :mod:`gpmegen.codegen.backends.fmu` and
:mod:`gpmegen.analysis.export.fmu`), checked by FMPy: the FMU is valid, its Model Exchange (CVode)
and Co-Simulation (RK4, DOP853) runs are gpmegen's own runs, an input and a parameter set through
FMPy change the run as the same force and parameter do in gpmegen, the archive is the same byte for
byte each time, and a model's free text and names cannot break its XML or C.

Two models: the reference arm at n_rfe = 1 and tests/models/two_link_traced.toml (a programmed
constraint, and a torque ``tau`` on theta1 as a drive, the same force as an input on theta1)."""

from __future__ import annotations

import subprocess
import sys
import warnings
import xml.etree.ElementTree as ET
import zipfile
from pathlib import Path

import numpy as np
import pytest
from test_trust_codegen import DANGEROUS

import gpmegen
from gpmegen.analysis.export import fmu as fmu_archive
from gpmegen.cli import main
from gpmegen.codegen.backends import fmu as fmu_export
from gpmegen.model import shapes
from gpmegen.model.chain import Body, Joint, Model, Parameter, Point, symbol

pytestmark = pytest.mark.requires_cc

ROOT = Path(__file__).resolve().parents[1]
TWO_LINK = ROOT / "tests" / "models" / "two_link_traced.toml"
T_END, OUTPUT = 1.0, 0.01
TIGHT = dict(rtol=1e-11, atol=1e-12)
MATCH = 1e-6   # the FMU's run against gpmegen's own, over 1 s (the task's bar)


@pytest.fixture(scope="module")
def fmpy():
    try:
        import fmpy
        import fmpy.validation
    except ImportError:
        pytest.skip("fmpy is not installed (pip install 'gpmegen[fmu]'); the FMU is not checked")
    return fmpy


class Exported(dict):
    """The FMUs of the two models by name (the two-link one with an input on theta1), each
    exported when first asked for."""

    def __init__(self, folder):
        super().__init__()
        self.folder = folder

    def __missing__(self, name):
        with warnings.catch_warnings():   # the two-link model's start is moved onto its constraint
            warnings.simplefilter("ignore", RuntimeWarning)
            if name == "reference":
                self[name] = gpmegen.export_fmu(self.folder / "reference.fmu", nrfe=1)
            else:
                self[name] = gpmegen.export_fmu(self.folder / "two_link.fmu", TWO_LINK, inputs=["theta1"])
        return self[name]


@pytest.fixture(scope="module")
def fmus(env, tmp_path_factory):
    return Exported(tmp_path_factory.mktemp("fmus"))


# The reference arm's checks are the two-link model's on a larger model: they run with the long tests.
MODELS = [pytest.param("reference", marks=pytest.mark.long), "two_link"]


def _gpmegen_run(name, method, params=None):
    model = dict(model=None, nrfe=1) if name == "reference" else dict(model=TWO_LINK)
    options = dict(dt=1e-4) if method == "rk4" else TIGHT
    with warnings.catch_warnings():   # the two-link model's start is moved onto its constraint, as in the FMU
        warnings.simplefilter("ignore", RuntimeWarning)
        return gpmegen.simulate(**model, t_end=T_END, method=method, save_dt=OUTPUT, params=params, **options)


def _states(result, coordinates):
    return (np.column_stack([result[c] for c in coordinates]),
            np.column_stack([result[c + "_dot"] for c in coordinates]))


def _simulate(fmpy, path, fmi_type, coordinates, start_values=None, **options):
    outputs = [*coordinates, *(c + "_dot" for c in coordinates)]
    if fmi_type == "ModelExchange":
        options = dict(solver="CVode", relative_tolerance=TIGHT["rtol"], **options)
    return fmpy.simulate_fmu(str(path), fmi_type=fmi_type, stop_time=T_END, output_interval=OUTPUT,
                             output=outputs + list(options.pop("extra", ())), start_values=start_values or {},
                             **options)


@pytest.mark.parametrize("name", MODELS)
def test_fmus_are_valid(fmpy, fmus, name):
    path = fmus[name]
    assert fmpy.validation.validate_fmu(str(path)) == []
    description = fmpy.read_model_description(str(path))
    assert description.modelExchange is not None and description.coSimulation is not None
    with zipfile.ZipFile(path) as archive:
        names = set(archive.namelist())
        root = ET.fromstring(archive.read("modelDescription.xml"))
    identifier = description.coSimulation.modelIdentifier
    assert f"binaries/linux64/{identifier}.so" in names
    for kind in ("ModelExchange", "CoSimulation"):   # every C file of the archive is listed, and only those
        listed = {f"sources/{f.get('name')}" for f in root.find(kind).iter("File")}
        assert listed == {name for name in names if name.startswith("sources/") and name.endswith(".c")}
    assert {"sources/model.c", "sources/gpmegen_fmi2.c", "sources/gpme.c", "sources/rk4.c"} <= names


def test_model_structure_names_what_each_unknown_depends_on(fmus):
    """A point's position and a constraint's value depend on the states alone, λ and q̈ on the
    input too (so that a tool may feed a point back to the input without an algebraic loop), and
    der(q) on q̇ alone."""
    with zipfile.ZipFile(fmus["two_link"]) as archive:
        root = ET.fromstring(archive.read("modelDescription.xml"))
    names = [v.get("name") for v in root.iter("ScalarVariable")]
    index = {name: str(k) for k, name in enumerate(names, start=1)}
    states = [index[n] for n in ("theta1", "theta2", "theta1_dot", "theta2_dot")]

    def depends(tag, name):
        (unknown,) = [u for u in root.find("ModelStructure").find(tag) if u.get("index") == index[name]]
        return unknown.get("dependencies").split()

    for axis in "xyz":
        assert depends("Outputs", f"E.{axis}") == states[:2]
    assert depends("Outputs", "phi_height") == states
    assert depends("Outputs", "lambda_height") == states + [index["u_theta1"]]
    assert depends("Derivatives", "der(theta2)") == [index["theta2_dot"]]
    assert depends("Derivatives", "der(theta2_dot)") == states + [index["u_theta1"]]


@pytest.mark.parametrize("name", MODELS)
def test_model_exchange_is_gpmegens_run(fmpy, fmus, name):
    """CVode on the FMU's derivatives against gpmegen's DOP853, both at tight tolerances; the
    outputs at the FMU's states against gpmegen's functions there."""
    path = fmus[name]
    reference = _gpmegen_run(name, "dop853")
    loaded = gpmegen.load("manipulator", nrfe=1) if name == "reference" else gpmegen.load(
        model=gpmegen.load_model_file(TWO_LINK))
    constraint = loaded.constraint_names[0]
    got = _simulate(fmpy, path, "ModelExchange", reference.coordinates,
                    extra=["E.x", "E.y", "E.z", f"lambda_{constraint}", f"phi_{constraint}"])
    np.testing.assert_allclose(got["time"], reference.t, atol=1e-12)
    q, qd = _states(got, reference.coordinates)
    assert np.abs(q - reference.q).max() < MATCH and np.abs(qd - reference.qd).max() < MATCH, name
    k = len(got) // 2
    t, q_k, qd_k = got["time"][k], q[k], qd[k]
    E = loaded.point_positions(q_k)[loaded.points.index("E")]
    np.testing.assert_allclose([got["E.x"][k], got["E.y"][k], got["E.z"][k]], E, rtol=1e-12, atol=1e-14)
    phi = loaded.constraint_terms(t, q_k, qd_k)[0][0]
    assert got[f"phi_{constraint}"][k] == pytest.approx(phi, abs=1e-14)
    lam = loaded.multipliers(t, q_k, qd_k)[0]
    assert got[f"lambda_{constraint}"][k] == pytest.approx(lam, rel=1e-8)


@pytest.mark.parametrize("name", MODELS)
@pytest.mark.parametrize("method", ["rk4", "dop853"])
def test_co_simulation_is_gpmegens_run(fmpy, fmus, method, name):
    """fmi2DoStep by the solver library's RK4 (gpmegen's step of 0.1 ms) or DOP853 (tolerances set
    as parameters), against gpmegen's run by the same method."""
    path = fmus[name]
    reference = _gpmegen_run(name, method)
    settings = {"integrator_method": 0} if method == "rk4" else {
        "integrator_method": 1, "integrator_rtol": TIGHT["rtol"], "integrator_atol": TIGHT["atol"]}
    got = _simulate(fmpy, path, "CoSimulation", reference.coordinates, settings)
    q, qd = _states(got, reference.coordinates)
    assert np.abs(q - reference.q).max() < MATCH and np.abs(qd - reference.qd).max() < MATCH, (name, method)


def test_input_and_parameter_change_the_run_as_in_gpmegen(fmpy, fmus):
    """The torque 0.8 N m on theta1 as the FMU's input u_theta1, and as its parameter tau (the
    model's drive), both give gpmegen's run with tau = 0.8; without it the run is another."""
    coordinates = ("theta1", "theta2")
    path = fmus["two_link"]
    reference = _gpmegen_run("two_link", "rk4", params={"tau": 0.8})
    unforced = _gpmegen_run("two_link", "rk4")
    assert np.abs(reference.q - unforced.q).max() > 1e-2   # the torque moves the arm
    for start_values in ({"u_theta1": 0.8}, {"tau": 0.8}):
        for fmi_type in ("CoSimulation", "ModelExchange"):
            got = _simulate(fmpy, path, fmi_type, coordinates, start_values)
            q, qd = _states(got, coordinates)
            assert np.abs(q - reference.q).max() < MATCH and np.abs(qd - reference.qd).max() < MATCH, \
                (start_values, fmi_type)


def test_same_model_same_bytes(fmus, tmp_path):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        again = gpmegen.export_fmu(tmp_path / "again.fmu", TWO_LINK, inputs=["theta1"])
    assert again.read_bytes() == fmus["two_link"].read_bytes()
    with zipfile.ZipFile(again) as archive:
        infos = archive.infolist()
    assert [i.filename for i in infos] == sorted(i.filename for i in infos)
    assert {i.date_time for i in infos} == {fmu_archive.ZIP_TIME}


def test_export_refuses_in_one_line(env, tmp_path, capsys):
    def refused(*args, code=2):
        assert main(["export", "--nrfe", "1", "--format", "fmu", *args]) == code
        err = capsys.readouterr().err.strip()   # the progress lines of a build, then the error in one line
        assert "Traceback" not in err and "error: " in err.splitlines()[-1]
        return err.splitlines()[-1]

    assert "does not end in .fmu" in refused("--out", str(tmp_path / "arm.zip"))
    assert "is a folder" in refused("--out", str(tmp_path))
    err = refused("--inputs", "nothing", "--out", str(tmp_path / "arm.fmu"))
    assert "input 'nothing' is not a coordinate of the model" in err
    assert not (tmp_path / "arm.fmu").exists()
    (tmp_path / "arm.fmu").write_bytes(b"earlier")
    assert "--overwrite" in refused("--out", str(tmp_path / "arm.fmu"))
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("CC", "no-such-compiler-here")
        assert "no-such-compiler-here" in refused("--out", str(tmp_path / "arm2.fmu"), "--overwrite", code=1)


@pytest.mark.long
def test_missing_fmpy_is_no_part_of_the_export(env, tmp_path):
    """The export needs a C compiler only: it runs with fmpy made unimportable."""
    script = ("import sys\nsys.modules['fmpy'] = None\nfrom gpmegen.cli import main\n"
              f"sys.exit(main(['export', '--nrfe', '1', '--format', 'fmu', '--out', {str(tmp_path / 'a.fmu')!r}]))")
    done = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    assert zipfile.ZipFile(tmp_path / "a.fmu").testzip() is None


def test_xml_text_escapes_markup_and_what_xml_cannot_hold():
    assert fmu_export.xml_text('a<b>&"c\'') == "a&lt;b&gt;&amp;&quot;c&apos;"
    assert fmu_export.xml_text("two\nlines\t") == "two&#10;lines&#9;"
    assert fmu_export.xml_text("\x00\x1b\ud800é\U0001F600") == "U+0000U+001BU+D800é\U0001F600"


@pytest.mark.long
def test_hostile_text_and_names_cannot_break_the_xml_or_the_c(fmpy, env, tmp_path):
    """A model named like the wrapper's own names once were, its description, unit and doc made
    of what ends or bends XML, C comments and strings: the XML holds the text (as
    :func:`fmu_export.xml_text` writes it), FMPy finds no problem, the text is in no C of the
    FMU but the generated model's comments, and the FMU runs."""
    text = "".join(DANGEROUS) + "]]><!-- --><?x?>&amp;</fmiModelDescription>"
    model = Model("fmu", (Parameter("m", 1.0, text, text),),
                  (Joint("a", "revolute", "z"), Body("b", shapes.point_mass(symbol("m"), (1, 0, 0))), Point("E")),
                  description=text, gravity=(0, -9.81, 0))
    path = gpmegen.export_fmu(tmp_path / "hostile.fmu", model)
    with zipfile.ZipFile(path) as archive:
        xml = archive.read("modelDescription.xml")
        wrapper = [archive.read(f"sources/{name}").decode() for name in (*fmu_export.WRAPPER, fmu_export.CONFIG)]
    root = ET.fromstring(xml)
    expected = ET.fromstring(f'<x a="{fmu_export.xml_text(text)}"/>').get("a")
    assert root.get("description") == expected
    m = next(v for v in root.iter("ScalarVariable") if v.get("name") == "m")
    assert m.get("description") == expected and m.find("Real").get("unit") == expected
    assert fmpy.validation.validate_fmu(str(path)) == []
    for source in wrapper:
        assert "fmiModelDescription" not in source and "]]>" not in source
    got = fmpy.simulate_fmu(str(path), fmi_type="CoSimulation", stop_time=0.1, output=["a"],
                            start_values={"a": 0.0})
    assert np.isfinite(got["a"]).all() and got["a"][-1] < 0   # it falls under gravity


@pytest.mark.long
def test_sources_rebuild_the_binary(fmpy, fmus, tmp_path):
    """The archive's sources/, compiled whole by a plain command (as an importer elsewhere would),
    give a binary that runs the same as the one built by gpmegen."""
    from gpmegen.runtime import ccompile

    original = fmus["two_link"]
    with zipfile.ZipFile(original) as archive:
        archive.extractall(tmp_path / "unpacked")
        files = {name: archive.read(name) for name in archive.namelist()}
    identifier = fmpy.read_model_description(str(original)).coSimulation.modelIdentifier
    sources = sorted(str(p) for p in (tmp_path / "unpacked" / "sources").glob("*.c"))
    binary = tmp_path / f"{identifier}.so"
    subprocess.run([*ccompile.find_compiler(), "-shared", "-fPIC", "-O2", "-std=c99", "-ffp-contract=off",
                    "-o", str(binary), *sources, "-lm"], check=True, capture_output=True)
    files[f"binaries/linux64/{identifier}.so"] = binary.read_bytes()
    rebuilt = tmp_path / "rebuilt.fmu"
    rebuilt.write_bytes(fmu_archive.archive(files))
    runs = [_simulate(fmpy, path, "CoSimulation", ("theta1", "theta2"), {"u_theta1": 0.3})
            for path in (original, rebuilt)]
    for name in ("theta1", "theta2", "theta1_dot", "theta2_dot"):
        np.testing.assert_allclose(runs[1][name], runs[0][name], rtol=0, atol=1e-12)


@pytest.mark.long
def test_a_name_the_fmu_has_already_is_refused_in_one_line(env, tmp_path):
    model = Model("clash", (Parameter("integrator_step", 1.0),),
                  (Joint("a", "revolute", "z"), Body("b", shapes.point_mass(1.0, (1, 0, 0)))),
                  gravity=(0, -9.81, 0))
    with pytest.raises(gpmegen.ModelError, match="two variables named 'integrator_step'") as caught:
        gpmegen.export_fmu(tmp_path / "clash.fmu", model)
    assert "\n" not in str(caught.value) and not (tmp_path / "clash.fmu").exists()
