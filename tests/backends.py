"""A model loaded on each backend for tests that compare them: the C one only where a compiler
builds it (its tests then skip)."""

import pytest

import gpmegen


def each_backend(model, **options) -> dict:
    """``{"numpy": loaded, "c": loaded}`` of ``model`` with ``options`` (as :func:`gpmegen.load`
    takes them); without "c" where the C model cannot be built (no compiler)."""
    loaded = {"numpy": gpmegen.load(model, backend="numpy", **options)}
    try:
        loaded["c"] = gpmegen.load(model, backend="c", **options)
    except gpmegen.errors.BuildError:
        pass
    return loaded


def on(loaded: dict, backend: str):
    """The model of ``backend`` in ``loaded`` (from :func:`each_backend`); the test skips without it."""
    if backend not in loaded:
        pytest.skip("no C compiler")
    return loaded[backend]
