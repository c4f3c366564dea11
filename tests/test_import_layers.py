"""The import contracts of pyproject.toml (checked by import-linter, which counts the imports made
inside functions as well) cover the whole package: every top-level module and package has its
layer, and every subpackage of the analysis its own, so that a module added without a place fails
here instead of escaping the contracts."""

import subprocess
import sys
import tomllib
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = ROOT / "gpmegen"
#: Modules left at the top of gpmegen/analysis: the former places the Python API's page named.
FORMER_PLACES = {"closures", "modes"}


def _contracts() -> dict:
    config = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))["tool"]["importlinter"]
    return {contract["name"]: contract for contract in config["contracts"]}


def _layered(layers) -> set[str]:
    """The module names of import-linter layers ("a | b" and "a : b" name siblings)."""
    return {name.strip() for layer in layers for name in layer.replace(":", "|").split("|")}


def _children(folder: Path) -> set[str]:
    """The modules and packages directly in ``folder`` (without ``__init__``)."""
    return ({p.stem for p in folder.glob("*.py") if p.stem != "__init__"}
            | {p.name for p in folder.iterdir() if (p / "__init__.py").is_file()})


def test_every_top_level_module_has_a_layer():
    listed = _layered(_contracts()["the pipeline's layers"]["layers"])
    missing = {f"gpmegen.{name}" for name in _children(PACKAGE)} - listed
    assert not missing, f"give {sorted(missing)} a layer in pyproject.toml [tool.importlinter]"
    assert listed <= {f"gpmegen.{name}" for name in _children(PACKAGE)}, "a layer names no module"


def test_every_analysis_subpackage_has_a_layer():
    contract = _contracts()["analysis by concern"]
    assert contract["containers"] == ["gpmegen.analysis"]
    folder = PACKAGE / "analysis"
    subpackages = {p.name for p in folder.iterdir() if (p / "__init__.py").is_file()}
    assert _layered(contract["layers"]) == subpackages
    loose = {p.stem for p in folder.glob("*.py") if p.stem != "__init__"}
    assert loose <= FORMER_PLACES, f"place {sorted(loose - FORMER_PLACES)} in a subpackage of gpmegen/analysis"


def test_every_package_is_checked_for_cycles():
    assert _contracts()["no import cycles"]["ancestors"] == ["gpmegen"]


def test_the_contracts_hold():
    lint = Path(sys.executable).with_name("lint-imports")
    done = subprocess.run([str(lint), "--no-cache"], cwd=ROOT, capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stdout[-3000:] + done.stderr[-2000:]
