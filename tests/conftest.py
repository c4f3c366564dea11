"""Shared fixtures: reference models are loaded once per session from the repository's
``generated/`` (built there when missing)."""

import numpy as np
import pytest

import gpmegen
from gpmegen.errors import BuildError
from gpmegen.runtime import ccompile


def skip_without_cc():
    """Skip the running test, saying why, on a machine without a C compiler (everything else
    runs on the NumPy backend there, as the README promises)."""
    try:
        ccompile.find_compiler()
    except BuildError as exc:
        pytest.skip(str(exc))


def pytest_runtest_setup(item):
    """Tests marked ``requires_cc`` need a C compiler."""
    if item.get_closest_marker("requires_cc"):
        skip_without_cc()


@pytest.fixture(scope="session")
def rigid(generated_elsewhere):
    return gpmegen.load(nrfe=1, backend="numpy")


@pytest.fixture(scope="session")
def flexible(generated_elsewhere):
    return gpmegen.load(nrfe=5, backend="numpy")


@pytest.fixture(scope="session")
def shared_cache(tmp_path_factory):
    """One C cache for the modules of a test process: a model compiled by one is reused by the
    next (the cache is keyed by the hash of the source, compiler and flags, so what one module
    compiles is what another would)."""
    return tmp_path_factory.mktemp("c-cache")


@pytest.fixture(scope="module")
def env(tmp_path_factory, shared_cache):
    """A private generated folder for the whole module and the process's C cache:
    ``(generated, cache)``. A test that must see a compile happen sets its own cache."""
    generated = tmp_path_factory.mktemp("generated")
    cache = shared_cache
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("GPMEGEN_GENERATED", str(generated))
        mp.setenv("GPMEGEN_CACHE", str(cache))
        mp.delenv("CC", raising=False)
        yield generated, cache


@pytest.fixture
def rng():
    return np.random.default_rng(20261122)


@pytest.fixture(scope="session", autouse=True)
def generated_elsewhere(tmp_path_factory):
    """Tests build models into a temporary folder, never into the repository's ``generated/``
    (which holds only the committed snapshots); the snapshots are copied there to start from."""
    import os
    import shutil
    from pathlib import Path

    folder = tmp_path_factory.mktemp("generated")
    repo = Path(__file__).resolve().parents[1] / "generated"
    for snapshot in sorted(repo.glob("manipulator_nrfe*")):
        shutil.copytree(snapshot, folder / snapshot.name)
    previous = os.environ.get("GPMEGEN_GENERATED")
    os.environ["GPMEGEN_GENERATED"] = str(folder)
    yield folder
    if previous is None:
        os.environ.pop("GPMEGEN_GENERATED", None)
    else:
        os.environ["GPMEGEN_GENERATED"] = previous


def stacked_gpme(model, t, q, qd):
    """The GPME of ``model`` (NumPy backend) at a state as one square system ``A q̈ = b``: the
    rows ``Bᵀ M q̈ = Bᵀ f`` and the constraint rows (eq. 16); ``M q̈ = f`` without constraints."""
    from gpmegen.runtime import gpme

    M, f, phi, phid, D, gamma = model.module.gpme_terms(t, q, qd, model.p)
    if not D.shape[0]:
        return M, f
    B = gpme.tangent_basis(D, model.dependent, model.independent)
    rhs = gpme.constraint_rhs(phi, phid, gamma, model.alpha, model.beta, model.constraint_orders)
    return np.vstack([B.T @ M, D]), np.concatenate([B.T @ f, rhs])
