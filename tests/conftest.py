"""Shared fixtures: reference models are loaded once per session from the repository's
``generated/`` (built there when missing)."""

import numpy as np
import pytest

import gpmegen


@pytest.fixture(scope="session")
def rigid(generated_elsewhere):
    return gpmegen.load(nrfe=1, backend="numpy")


@pytest.fixture(scope="session")
def flexible(generated_elsewhere):
    return gpmegen.load(nrfe=5, backend="numpy")


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
