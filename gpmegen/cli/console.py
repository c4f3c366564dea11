"""The command line's entry: parse, run the command, and map its errors to one line and an exit
status."""
from __future__ import annotations

import contextlib
import gc
import os
import sys
import warnings

from .. import limits
from ..analysis.figures.plots import IncompatibleResults
from ..analysis.post.results import ResultsError
from ..errors import (
    BuildError,
    DerivationError,
    GpmegenError,
    MissingExtraError,
    ModelError,
    ModelWarning,
    OutputError,
    RunSpecError,
)
from .common import SimulationStopped, UsageError, progress
from .parser import build_parser


@contextlib.contextmanager
def _warnings_as_lines():
    """A :class:`ModelWarning` printed as one line, as the command line's other warnings are
    (Python's own format adds the source line it was raised at)."""
    with warnings.catch_warnings():
        shown = warnings.showwarning

        def show(message, category, filename, lineno, file=None, line=None):
            if issubclass(category, ModelWarning):
                progress(f"warning: {message}")
            else:
                shown(message, category, filename, lineno, file, line)

        warnings.showwarning = show
        yield


def main(argv=None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        with limits.lifted() if getattr(args, "no_limits", False) else contextlib.nullcontext(), \
                _warnings_as_lines():
            return args.func(args)
    except SimulationStopped as exc:
        print(f"gpmegen {args.command}: {'' if exc.interrupted else 'error: '}{exc}", file=sys.stderr)
        return 130 if exc.interrupted else 1
    except (UsageError, RunSpecError, limits.LimitError, IncompatibleResults, ResultsError, OutputError,
            MissingExtraError) as exc:  # what the user gave or asked for: a results file too
        print(f"gpmegen {args.command}: error: {exc}", file=sys.stderr)
        return 2
    except (ModelError, DerivationError, BuildError) as exc:
        print(f"gpmegen {args.command}: error: {exc}", file=sys.stderr)
        return 1 if isinstance(exc, BuildError) else 2
    except GpmegenError as exc:
        print(f"gpmegen {args.command}: error: {exc}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        print(f"gpmegen {args.command}: interrupted", file=sys.stderr)
        return 130
    except MemoryError:
        print(f"gpmegen {args.command}: error: out of memory; ask for a smaller model or run (without "
              f"--no-limits, work that needs more memory than is available is refused before it starts)",
              file=sys.stderr)
        return 1
    except OSError as exc:
        where = f" {exc.filename}" if getattr(exc, "filename", None) else ""
        print(f"gpmegen {args.command}: error:{where} {exc.strerror or exc}", file=sys.stderr)
        return 1
    except Exception as exc:  # a defect: say so in one line, the traceback on request
        if _caused_by_interrupt(exc):
            print(f"gpmegen {args.command}: interrupted", file=sys.stderr)
            return 130
        if os.environ.get("GPMEGEN_DEBUG"):
            raise
        print(f"gpmegen {args.command}: internal error: {type(exc).__name__}: {exc} (this is a bug; rerun with "
              f"GPMEGEN_DEBUG=1 for the traceback and report it)", file=sys.stderr)
        return 1


def _caused_by_interrupt(exc: BaseException) -> bool:
    """Whether Ctrl-C or SIGTERM is behind ``exc``: an extension module whose initialization the
    interrupt stops (a command imports what it runs when it runs) reports it as an ImportError
    raised from the KeyboardInterrupt."""
    seen = set()
    while exc is not None and id(exc) not in seen:
        if isinstance(exc, KeyboardInterrupt):
            return True
        seen.add(id(exc))
        exc = exc.__cause__ or exc.__context__
    return False


def quick_exit(code: int) -> int:
    """``code``, with the objects made so far set aside from the garbage collector: the
    interpreter's collections at exit would otherwise walk SymPy's millions of them (2.8 s after a
    run's last line at load 10, 0.3 s without), and a stopped run is to end promptly."""
    gc.freeze()
    return code

