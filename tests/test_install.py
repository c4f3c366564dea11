"""gpmegen as a user gets it from a wheel: the wheel built from this checkout holds every module
and every file the package reads at run time, and, installed into a fresh virtual environment
outside the checkout, builds a model, runs it and loads it from Python. The editable install
that the other tests run on finds everything in the checkout, so only this test sees what the
wheel leaves out.

Nothing is downloaded: the wheel is built with the setuptools of the environment running the
tests (the test extra asks for a recent one), and the fresh environment sees that environment's
packages as its dependencies through a .pth file."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import sysconfig
import zipfile
from importlib.metadata import PackageNotFoundError, version
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
# what the build reads: the build configuration, the readme (the project's long description)
# and the package's two folders
BUILD_INPUTS = ("pyproject.toml", "setup.py", "README.md", "gpmegen", "templates")
NOT_SOURCE = shutil.ignore_patterns("__pycache__", "*.pyc", "*.so", "*.o", ".*")
# The Python example run by the installed package, from a folder outside the checkout.
SNIPPET = """
import sys
from pathlib import Path
import numpy as np
import gpmegen
from importlib import resources

here = Path(sys.prefix).resolve()
for where in (Path(gpmegen.__file__), Path(str(resources.files("gpmegen.templates")))):
    assert here in where.resolve().parents, f"{where} is not in the fresh environment {here}"
model = gpmegen.load("manipulator", nrfe=1, directory="models", build=False)
q = np.array([0.0, np.pi / 4, 0.0])
qdd = model.accelerations(0.0, q, np.zeros(3))
assert qdd.shape == (3,) and np.all(np.isfinite(qdd)), qdd
print("accelerations", model.coordinates, qdd)
"""


def _run(argv, **kwargs) -> subprocess.CompletedProcess:
    proc = subprocess.run([str(a) for a in argv], capture_output=True, text=True, timeout=600, **kwargs)
    assert proc.returncode == 0, (f"{' '.join(map(str, argv))} exited with {proc.returncode}\n"
                                  f"stdout:\n{proc.stdout}\nstderr:\n{proc.stderr}")
    return proc


def _without_build_isolation() -> list[str]:
    """pip's options to build with the running environment's setuptools, when it is recent
    enough for pyproject.toml; otherwise pip fetches one for an isolated build."""
    try:
        major = int(version("setuptools").split(".")[0])
    except (PackageNotFoundError, ValueError):
        major = 0
    return ["--no-build-isolation", "--no-index"] if major >= 77 else []


@pytest.fixture(scope="module")
def built(tmp_path_factory) -> tuple[Path, Path]:
    """The wheel built from a copy of the checkout's build inputs (so that nothing is written
    into the checkout, and no earlier build's leftovers end up in the wheel); (wheel, copy)."""
    source = tmp_path_factory.mktemp("source")
    for name in BUILD_INPUTS:
        path = ROOT / name
        if path.is_dir():
            shutil.copytree(path, source / name, ignore=NOT_SOURCE)
        elif path.exists():
            shutil.copy2(path, source / name)
    dist = tmp_path_factory.mktemp("dist")
    _run([sys.executable, "-m", "pip", "wheel", source, "--no-deps", "-w", dist, *_without_build_isolation()])
    (wheel,) = dist.glob("gpmegen-*.whl")
    return wheel, source


def _fresh_environment(tmp_path: Path, wheel: Path) -> Path:
    """A new virtual environment with the wheel installed and, through a .pth file, the running
    environment's packages as its dependencies; its bin folder."""
    venv = tmp_path / "venv"
    _run([sys.executable, "-m", "venv", "--without-pip", venv])
    bin_dir = venv / "bin"
    python = bin_dir / "python"
    # installed before the .pth exists, so that pip does not see the checkout's editable install
    _run([sys.executable, "-m", "pip", "--python", python, "install", "--no-deps", "--no-index", wheel])
    site = Path(_run([python, "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"]).stdout.strip())
    running = dict.fromkeys(sysconfig.get_paths()[key] for key in ("purelib", "platlib"))
    (site / "dependencies_of_the_tests.pth").write_text("".join(f"{path}\n" for path in running))
    return bin_dir


def test_wheel_holds_every_file_of_the_package(built):
    """Every module and data file of gpmegen/ is in the wheel, and templates/ as gpmegen/templates/."""
    wheel, source = built
    with zipfile.ZipFile(wheel) as archive:
        held = set(archive.namelist())
    wanted = {f"gpmegen/{path.relative_to(source / 'gpmegen').as_posix()}"
              for path in (source / "gpmegen").rglob("*") if path.is_file()}
    wanted |= {f"gpmegen/templates/{path.relative_to(source / 'templates').as_posix()}"
               for path in (source / "templates").rglob("*") if path.is_file()}
    missing = sorted(wanted - held)
    assert not missing, f"missing from the wheel (a package not found, or data not in package-data): {missing}"


@pytest.mark.long   # a fresh environment with the wheel installed; the wheel's contents are checked in make test
def test_installed_wheel_builds_runs_and_loads_outside_the_checkout(built, tmp_path):
    bin_dir = _fresh_environment(tmp_path, built[0])
    work = tmp_path / "work"
    work.mkdir()
    env = {k: v for k, v in os.environ.items()
           if k not in ("PYTHONPATH", "PYTHONHOME", "GPMEGEN_GENERATED", "VIRTUAL_ENV")}
    env.update(GPMEGEN_CACHE=str(tmp_path / "c-cache"), XDG_CACHE_HOME=str(tmp_path / "cache"),
               MPLCONFIGDIR=str(tmp_path / "matplotlib"))
    gpmegen = bin_dir / "gpmegen"

    _run([gpmegen, "build", "--nrfe", "1", "--out", "models"], cwd=work, env=env)
    assert (work / "models" / "manipulator_nrfe1" / "model.c").is_file()
    run = _run([gpmegen, "simulate", "models/manipulator_nrfe1", "--t-end", "0.002", "--out", "run.npz"],
               cwd=work, env=env)
    assert "complete at t = 0.002 s" in run.stdout and (work / "run.npz").is_file()
    loaded = _run([bin_dir / "python", "-c", SNIPPET], cwd=work, env=env)
    assert loaded.stdout.startswith("accelerations ('theta1', 'psi2', 'x3')")
