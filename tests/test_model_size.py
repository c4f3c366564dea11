"""A model's size counted before it is expanded (:func:`gpmegen.model.size.coordinate_count`,
what the resource limits judge a build and a run by) is the size its expansion has."""

from pathlib import Path

import pytest

from gpmegen.analysis.run.model_files import load_model_file
from gpmegen.model.expand import expand
from gpmegen.model.reference import reference_model
from gpmegen.model.size import coordinate_count

ROOT = Path(__file__).resolve().parents[1]
FILES = sorted(p for folder in ("examples", "tests/models") for p in (ROOT / folder).glob("*.toml")
               if "urdf" not in p.read_text(encoding="utf-8"))


@pytest.mark.parametrize("path", FILES, ids=lambda p: f"{p.parent.name}/{p.stem}")
def test_the_count_before_expansion_is_the_expanded_size(path):
    # a file whose name uses {nrfe} without a default of its own is read as gpmegen build FILE --nrfe 3
    model = load_model_file(path, nrfe=None if "\nnrfe" in path.read_text(encoding="utf-8") else 3)
    assert coordinate_count(model) == len(expand(model).coordinates)


@pytest.mark.parametrize("nrfe", [1, 5])
def test_the_reference_arm_counts_three_joints_and_its_sdes(nrfe):
    assert coordinate_count(reference_model(nrfe)) == len(expand(reference_model(nrfe)).coordinates)
