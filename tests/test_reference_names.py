"""The reference case is data, not names: generic code reads the flexible link's length, stiffness
and mass from the link itself, so a copy of the reference's model file with every parameter and
the model renamed gives the same beam-theory values, the same convergence study and its figure;
and no module of gpmegen outside the one that holds the reference model names its parameters, its
joints or its name."""

from __future__ import annotations

import ast
import re
from pathlib import Path

import numpy as np

import gpmegen
from gpmegen.analysis.discretization import convergence
from gpmegen.analysis.figures import modes_output
from gpmegen.model.chain import Joint
from gpmegen.model.reference import PARAMETERS, reference_model

ROOT = Path(__file__).resolve().parents[1]
ORIGINAL = ROOT / "examples" / "manipulator.toml"
# where the reference case's data lives: its model (its scenario, ReferenceCase, reads it from there)
HOLDERS = {Path("gpmegen/model/reference.py")}


def _renamed_copy(folder: Path) -> tuple[Path, dict]:
    """The reference's model file with its model and every parameter but g renamed (``g`` is
    the generic gravity parameter every model may have); the new name of each."""
    text = ORIGINAL.read_text(encoding="utf-8")
    names = {p.name: f"renamed{k}" for k, p in enumerate(PARAMETERS) if p.name != "g"}
    pattern = re.compile(r"(?<![A-Za-z0-9_])(" + "|".join(map(re.escape, names)) + r")(?![A-Za-z0-9_])")
    renamed = []
    for line in text.splitlines(keepends=True):
        code, hash_, comment = line.partition("#")  # comments left as they are
        renamed.append(pattern.sub(lambda m: names[m.group(1)], code) + hash_ + comment)
    text = "".join(renamed).replace('name = "manipulator_nrfe{nrfe}"', 'name = "other_arm_nrfe{nrfe}"')
    path = folder / "other_arm.toml"
    path.write_text(text, encoding="utf-8")
    return path, names


def _defaults(model) -> dict:
    return {p.name: float(p.default) for p in model.parameters}


def test_a_renamed_reference_gives_the_same_beam_values_and_convergence(env, tmp_path):
    path, names = _renamed_copy(tmp_path)
    original, renamed = gpmegen.load_model_file(ORIGINAL), gpmegen.load_model_file(path)
    assert renamed.name != original.name and "L2" not in _defaults(renamed)  # the copy is renamed
    assert _defaults(renamed) == {names.get(k, k): v for k, v in _defaults(original).items()}
    (link,), (other,) = convergence.flexible_links(original), convergence.flexible_links(renamed)
    assert convergence.link_numbers(link, _defaults(original)) == convergence.link_numbers(other, _defaults(renamed))
    # the built-in reference arm's beam values are its file's
    assert convergence.arm_reference(_defaults(original)) == convergence.link_reference(link, _defaults(original))
    tables = [convergence.convergence_table((2, 3), directory=env[0], clamped=convergence.Clamped(model, link.label))
              for model in (original, renamed)]
    # the same model: its generated code differs only in the order of terms (SymPy orders them
    # by the symbols' names), so the numbers agree to round-off
    assert tables[0].values.keys() == tables[1].values.keys()
    for key in tables[0].values:
        np.testing.assert_allclose(tables[0].values[key], tables[1].values[key], rtol=1e-12, err_msg=key)
        assert tables[0].analytic[key] == tables[1].analytic[key], key
        np.testing.assert_allclose(tables[0].errors[key], tables[1].errors[key], rtol=1e-9, err_msg=key)
    figures = [modes_output.plot_convergence(table, tmp_path / f"convergence_{k}.png")
               for k, table in enumerate(tables)]
    assert all(f.stat().st_size > 0 for f in figures)


def _string_constants(path: Path) -> set[str]:
    """Every string literal of the module at ``path`` that is a whole string (a key, a name), not
    a docstring or a message: those equal to a name are what reads a parameter by it."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    return {node.value for node in ast.walk(tree) if isinstance(node, ast.Constant) and isinstance(node.value, str)}


def test_no_generic_module_names_the_references_parameters():
    """Outside the reference case's own modules, no string literal of gpmegen is one of its
    parameters' names (one-letter ones, g, A, T, are too common to tell: left out)."""
    names = {p.name for p in PARAMETERS if len(p.name) > 1}
    found = {}
    for path in sorted((ROOT / "gpmegen").rglob("*.py")):
        relative = path.relative_to(ROOT)
        if relative in HOLDERS:
            continue
        hits = names & _string_constants(path)
        if hits:
            found[str(relative)] = sorted(hits)
    assert found == {}, f"modules that read the reference's parameters by name: {found}"


def test_no_generic_module_names_the_references_joints_or_its_model():
    """Outside the reference model's module, no string literal of gpmegen is one of its joints'
    names (the figures' labels come from its presentation) or its model's name, whole or as the
    start of a pattern (a built folder is recognized by its input hash, not its name)."""
    joints = {element.name for element in reference_model(2).chain if isinstance(element, Joint)}
    assert joints == {"theta1", "psi2", "x3"}
    found = {}
    for path in sorted((ROOT / "gpmegen").rglob("*.py")):
        relative = path.relative_to(ROOT)
        if relative in HOLDERS:
            continue
        strings = _string_constants(path)
        hits = (joints & strings) | {s for s in strings if s.startswith("manipulator_nrfe")}
        if hits:
            found[str(relative)] = sorted(hits)
    assert found == {}, f"modules that name the reference's joints or model: {found}"
