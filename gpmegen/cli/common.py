"""What the commands share: their usage error, progress lines, the results path check, the case
a command runs, the default backend, the start and the one run specification of the options."""
from __future__ import annotations

import sys
from pathlib import Path

from .. import outputs
from ..analysis.run.runspec import RunSpec
from ..errors import GpmegenError


class UsageError(GpmegenError):
    """A problem with the command line itself (exit status 2)."""


def progress(message: str) -> None:
    print(f"gpmegen: {message}", file=sys.stderr, flush=True)


def check_results_path(out: Path, overwrite: bool = False, inputs=(), also=()) -> None:
    """Refuse, before any work, a results path that cannot take a run's files (complete or
    partial) and ``also`` (paths written with them): not .npz, a folder, one of the command's
    ``inputs``, in a folder that cannot be written, or holding the results of an earlier run
    (unless ``overwrite``)."""
    from ..analysis.post import results as results_io

    if out.suffix != ".npz":
        raise UsageError(f"--out {out}: results are written as .npz (a .csv is written beside it)")
    for path in (*results_io.targets(out), *results_io.targets(out, complete=False)):
        if path.is_dir():
            raise UsageError(f"results file {out}: {path} is a folder; choose another name ending in .npz")
    outputs.check(results_io.targets(out, complete=False), inputs, overwrite=True)  # a partial pair is remade
    outputs.check([*results_io.targets(out), *also], inputs, overwrite, what="an earlier run's results",
                  fix="pass --overwrite to replace them, or choose another --out")
    outputs.writable_folder(out.parent)


def open_case(model_file, nrfe):
    """The case a command runs (:func:`gpmegen.analysis.run.opening.case_for`)."""
    from ..analysis.run.opening import case_for

    return case_for(model_file, nrfe)


def default_backend() -> str:
    """"c" when a C compiler is found, else "numpy" (and says so)."""
    from ..runtime import loader

    return loader.default_backend(progress)


def start_of(case, start):
    """``start``, or the case's default start; a start the case does not take is a usage error."""
    start = start or case.starts[0]
    if start not in case.starts:
        raise UsageError(case.start_refusal)
    return start


def run_spec(args, start=None) -> RunSpec:
    """The one :class:`RunSpec` of a command's run options (those its parser has) and ``start``."""
    actuated = getattr(args, "actuated", None)
    return RunSpec(t_end=args.t_end, dt=args.dt, method=args.method, save_every=args.save_every,
                   save_dt=getattr(args, "save_dt", None), rtol=getattr(args, "rtol", None),
                   atol=getattr(args, "atol", None), rho_inf=getattr(args, "rho_inf", None), start=start,
                   repartition=getattr(args, "repartition", False),
                   actuated=() if actuated == ["none"] else actuated,
                   internal_dynamics=getattr(args, "internal_dynamics", False))


class SimulationStopped(GpmegenError):
    """The run ended early (diverged or interrupted); partial results were written.
    ``interrupted``: by Ctrl-C or SIGTERM (exit status 130), else it diverged (1)."""

    def __init__(self, message, interrupted=False):
        super().__init__(message)
        self.interrupted = interrupted


def check_terms(nrfe, terms) -> None:
    """--terms 2 needs three levels: refused before any run."""
    if len(nrfe) < terms + 1:
        raise UsageError(f"--terms {terms} removes {terms} terms of the discretization error and needs {terms + 1} "
                         f"distinct --nrfe or more (e.g. --nrfe 10 20 40)")
