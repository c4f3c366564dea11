"""Shared fixtures, and what makes the suite fast: work done once per run, not once per test.

- Every build derives and renders a model once per ``pytest`` run, for both xdist workers
  (:func:`shared_renders`): the files of a render are kept in a folder the workers share, keyed
  by the model's input hash (the one its build manifest records) and every build option, and a
  second build of the same model anywhere in the run (another module's folder, the other worker)
  takes them from there, its progress lines said again. Each build still writes its own folder,
  so a test may change or break its build without another seeing it. Only builds are served
  so: a test that calls ``gpmegen.codegen.render`` itself, or a child process, derives afresh.
- One C cache for the whole run (:func:`shared_cache`, the run's ``GPMEGEN_CACHE``), shared by
  the workers and the commands they start: a model compiled (and checked in a child process) by
  one module is reused by every other. A test that must see a compile happen gives
  ``GPMEGEN_CACHE`` (or ``cache=``) a folder of its own: :func:`fresh_cache`, which already
  holds the solver library, unless the test is about that.
- ``env`` (per module): a private generated folder and the shared C cache, set in the
  environment; ``rigid``/``flexible``: the reference arm at n_rfe 1 and 5 (NumPy backend), loaded
  once per worker from the committed snapshots (``generated_elsewhere``).
- The objects a worker holds when a module starts (imports, derivations, loaded models) are
  moved out of the garbage collector's sight (:func:`frozen_heap`): a full collection no longer
  walks them again and again under the next module's tests.
- :func:`shared_folder` gives a new fixture a folder shared by the run's workers; hold
  :class:`gpmegen.folder.FolderLock` on what you put there so that one worker makes it and the
  other waits and then finds it.
"""

import gc
import hashlib
import json
import os
import signal
import sys

import numpy as np
import pytest

import gpmegen
from gpmegen.errors import BuildError
from gpmegen.fileio import atomic_write_bytes
from gpmegen.runtime import ccompile

# Tests send Ctrl-C (SIGINT) to child processes. A suite started in the background by a
# non-interactive shell (`make test &`) starts with SIGINT ignored, and an ignored signal stays
# ignored across exec, so the children would never hear it; give the workers Python's own handler,
# which every child then starts without.
if signal.getsignal(signal.SIGINT) == signal.SIG_IGN:
    signal.signal(signal.SIGINT, signal.default_int_handler)


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
    return gpmegen.load("manipulator", nrfe=1, backend="numpy")


@pytest.fixture(scope="session")
def flexible(generated_elsewhere):
    return gpmegen.load("manipulator", nrfe=5, backend="numpy")


def shared_folder(tmp_path_factory, name):
    """The folder ``name`` shared by the processes of this ``pytest`` run: beside the xdist
    workers' own base temporary folders (their common parent belongs to this run alone), or in
    the base temporary folder of a run without xdist."""
    base = tmp_path_factory.getbasetemp()
    if os.environ.get("PYTEST_XDIST_WORKER"):
        base = base.parent
    folder = base / name
    folder.mkdir(exist_ok=True)
    return folder


@pytest.fixture(scope="session", autouse=True)
def shared_cache(tmp_path_factory):
    """One C cache for the whole run, both workers: a model compiled by one module is reused by
    every other (the cache is keyed by the hash of the source, compiler and flags, so what one
    compiles is what another would, and a library is written by rename, so a worker never sees
    half of one). It is the environment's ``GPMEGEN_CACHE`` for the whole run, so that a test
    and the commands it starts never compile into the user's own cache (``~/.cache``), where
    nothing of this run would find it again."""
    folder = shared_folder(tmp_path_factory, "c-cache")
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("GPMEGEN_CACHE", str(folder))
        yield folder


@pytest.fixture
def fresh_cache(tmp_path, shared_cache):
    """A new C cache for one test, empty but for the solver library's object: compiled once per
    run into the shared cache (one worker compiles, the other waits) and copied, bytes and record,
    so a test that must see a model compile happen does not pay for the solver library's too
    (about 4 s of CPU each). Tests of the solver library's own compile use an empty folder."""
    from gpmegen.folder import FolderLock

    with FolderLock(shared_cache / "solver"):
        solver = ccompile.build_solver(cache=shared_cache)
    cache = tmp_path / "cache"
    cache.mkdir()
    for path in (solver.path, solver.path.with_suffix(".json")):
        atomic_write_bytes(cache / path.name, path.read_bytes())
    return cache


def _tunables() -> list:
    """The module-level constants of the generator (``gpmegen.codegen``, ``gpmegen.symbolic``)
    as they are now: a test may change one (e.g. the block size of the C), which changes what a
    render gives without changing the model's input hash."""
    found = []
    for name, module in sorted(sys.modules.items()):
        if module is None or not name.startswith(("gpmegen.codegen", "gpmegen.symbolic")):
            continue
        for attr, value in sorted(vars(module).items()):
            if attr.isupper() and isinstance(value, (bool, int, float, str, tuple, frozenset)):
                found.append(f"{name}.{attr}={value!r}")
    return found


@pytest.fixture(scope="session", autouse=True)
def shared_renders(tmp_path_factory):
    """Builds take the derivation and rendering of a model from the run's shared store when it
    was done before in this run (see the module's docstring): ``gpmegen.codegen.render``'s
    ``render`` as the build calls it, its result kept under a key of everything it depends on.
    One worker renders while holding the key's lock; the other waits and then reads it."""
    import importlib

    from gpmegen.folder import FolderLock

    module = importlib.import_module("gpmegen.codegen.render")
    original = module.render
    store = shared_folder(tmp_path_factory, "renders")

    def render(model, backends=("numpy",), progress=None, command=None, digest=None,
               transforms=module.DEFAULT_TRANSFORMS, jacobians=False):
        key = hashlib.sha256(json.dumps([
            module.input_hash(model, backends, transforms, jacobians), digest, model.name, list(backends),
            command, list(transforms), bool(jacobians), _tunables()]).encode()).hexdigest()[:24]
        kept = store / f"{key}.json"
        with FolderLock(kept):
            if kept.exists():
                record = json.loads(kept.read_text(encoding="utf-8"))
                for line in record["said"]:
                    if progress is not None:
                        progress(line)
                return record["files"]
            said = []

            def tell(line):
                said.append(line)
                if progress is not None:
                    progress(line)

            files = original(model, backends, tell, command, digest, transforms, jacobians)
            atomic_write_bytes(kept, json.dumps({"files": files, "said": said}).encode("utf-8"))
            return files

    module.render = render
    yield store
    module.render = original


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


@pytest.fixture(scope="module", autouse=True)
def frozen_heap():
    """``gc.freeze()`` as each module starts: the worker's heap grows to hundreds of thousands of
    objects (SymPy's, the loaded models', the imported engines'), and every full collection
    walked all of them again: a test that allocates much (Hypothesis drawing 500 strings) spent
    more time in the collector than in itself (5.1 s against 1.6 s frozen). Frozen objects are
    never collected, so the cycles a module leaves stay allocated: memory, not correctness."""
    gc.freeze()
    yield


@pytest.fixture
def rng():
    return np.random.default_rng(20261122)


@pytest.fixture(scope="session", autouse=True)
def generated_elsewhere(tmp_path_factory):
    """Tests build models into a temporary folder, never into the repository's ``generated/``
    (which holds only the committed snapshots); the snapshots are copied there to start from."""
    import shutil
    from pathlib import Path

    folder = tmp_path_factory.mktemp("generated")
    repo = Path(__file__).resolve().parents[1] / "generated"
    for snapshot in sorted(repo.glob("manipulator_nrfe*")):
        shutil.copytree(snapshot, folder / snapshot.name)
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("GPMEGEN_GENERATED", str(folder))
        yield folder


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
