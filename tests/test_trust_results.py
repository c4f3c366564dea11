"""Results that can be trusted: a run ends at t_end with its final state saved, on one grid for
the C and NumPy backends."""

from __future__ import annotations

import numpy as np
import pytest

import gpmegen
from gpmegen.analysis import results as results_io
from gpmegen.analysis import study
from gpmegen.cli import main
from gpmegen.errors import BuildError
from gpmegen.runtime import integrate
from gpmegen.runtime.ccompile import find_compiler


def _has_compiler():
    try:
        return bool(find_compiler())
    except BuildError:
        return False


needs_c = pytest.mark.skipif(not _has_compiler(), reason="no C compiler")


# ---- a run ends at t_end, with its final state ------------------------------------------------

# Command lines whose last sample was wrong: t_end not a whole number of save intervals, or of
# steps, or both. The first two are run on the C backend alone (the NumPy one takes seconds).
RUNS = {
    "save-every-300": ["--t-end", "0.2", "--save-every", "300"],
    "t-end-0.10005": ["--t-end", "0.10005"],
    "dt-3e-5": ["--dt", "3e-5", "--t-end", "0.1"],
    "short-save-every-300": ["--t-end", "0.02", "--save-every", "300"],
    "last-step-shorter": ["--t-end", "0.010005", "--save-every", "300"],
}


def _t_end(key):
    argv = RUNS[key]
    return float(argv[argv.index("--t-end") + 1])


@pytest.fixture(scope="module")
def cli_runs(tmp_path_factory):
    """Results of ``gpmegen simulate --nrfe 1 <RUNS[key]> --backend <backend>``, run once each."""
    folder = tmp_path_factory.mktemp("runs")
    done = {}

    def run(key, backend):
        if (key, backend) not in done:
            out = folder / f"{key}_{backend}.npz"
            assert main(["simulate", "--nrfe", "1", "--backend", backend, *RUNS[key], "--out", str(out)]) == 0
            done[key, backend] = results_io.load(out)
        return done[key, backend]

    return run


@pytest.mark.parametrize("t0, t_end, dt, n_steps, last", [
    (0.0, 0.2, 1e-5, 20000, 1e-5),
    (0.0, 0.1, 3e-5, 3334, 1e-5),
    (0.0, 0.10005, 1e-5, 10005, 1e-5),
    (0.0, 0.100055, 1e-5, 10006, 5e-6),
    (0.0, 1.0, 2.0, 1, 1.0),
    (4.0, 4.3, 1e-3, 300, 1e-3),
    (0.0, 10.0, 1e-5, 1000000, 1e-5),
    (0.0, 0.0, 1e-5, 0, None),
])
def test_grid_ends_at_t_end_with_a_shorter_last_step_where_needed(t0, t_end, dt, n_steps, last):
    g = integrate.grid(t0, t_end, dt)
    assert g.n_steps == n_steps
    assert g.time(0) == t0 and g.time(n_steps) == t_end
    if n_steps:
        assert g.step(n_steps) == pytest.approx(last, rel=1e-6)
        k = n_steps // 2
        if 0 < k < n_steps:  # inner steps on t0 + k dt, without accumulated round-off
            assert g.time(k) == t0 + k * dt and g.step(k) == dt


@needs_c
@pytest.mark.parametrize("key", ["save-every-300", "t-end-0.10005", "last-step-shorter"])
def test_last_row_off_the_save_grid_is_the_final_state_not_the_last_saved_one(cli_runs, key):
    """``--t-end 0.2 --save-every 300``: the last row used to repeat the state saved at step
    19800, stamped 0.2 s (max|Φ| 1.2e-3 in the summary instead of 5e-15)."""
    res, t_end = cli_runs(key, "c"), _t_end(key)
    argv = RUNS[key]
    every = int(argv[argv.index("--save-every") + 1]) if "--save-every" in argv else 100
    grid = integrate.grid(0.0, t_end, 1e-5)
    np.testing.assert_array_equal(res["t"], [grid.time(k) for k in [*range(0, grid.n_steps, every), grid.n_steps]])
    assert res["t"][-1] == t_end
    assert np.abs(res["phi"][-1]).max() < 1e-12
    # the same final state as one continuous C call over the whole run
    model, q0 = study.initial_state(gpmegen.load(nrfe=1, backend="c"))
    np.testing.assert_array_equal(res["q"][0], q0)
    t, q, qd, w, status = model.rk4(q0, np.zeros(3), t_end, 1e-5, save_every=10 ** 9)
    assert status == 0 and list(t) == [0.0, t_end]
    np.testing.assert_array_equal(res["q"][-1], q[-1])
    np.testing.assert_array_equal(res["qd"][-1], qd[-1])


@needs_c
@pytest.mark.parametrize("key", ["dt-3e-5", "short-save-every-300", "last-step-shorter"])
def test_c_and_numpy_save_the_same_rows_and_end_at_t_end(cli_runs, key):
    """``--dt 3e-5 --t-end 0.1`` used to end at 0.09999 s, and the C backend's last row was not
    its final state where t_end is off the save grid."""
    c, n = cli_runs(key, "c"), cli_runs(key, "numpy")
    np.testing.assert_array_equal(c["t"], n["t"])
    assert c["t"][-1] == _t_end(key)
    for name in ("q", "qd"):
        scale = np.abs(n[name]).max()
        np.testing.assert_allclose(c[name], n[name], rtol=1e-9, atol=1e-9 * scale)


@pytest.mark.parametrize("backend", ["numpy", pytest.param("c", marks=needs_c)])
def test_a_step_longer_than_the_run_is_cut_to_end_at_t_end(backend):
    """``--dt 2 --t-end 1`` used to take no step at all and report success."""
    model, q0 = study.initial_state(gpmegen.load(nrfe=1, backend=backend))
    res = study.simulate(model, q0, t_end=1.0, dt=2.0, save_every=1)
    np.testing.assert_array_equal(res["t"], [0.0, 1.0])
    assert not np.array_equal(res["q"][-1], q0)  # a step of 1 s was taken (and diverges, as it should)
