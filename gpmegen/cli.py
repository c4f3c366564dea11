"""Command line: ``gpmegen build | statics | simulate | plot | demo``.

Usage errors exit with status 2, runtime failures with 1; either prints one line naming the
problem and the fix, never a traceback.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

from .errors import BuildError, GpmegenError, ModelError


def positive_int(text: str) -> int:
    """argparse type: a whole number ≥ 1."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a whole number (use 1 for the rigid arm)") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"{value} is below 1 (use 1 for the rigid arm, 2 or more for a flexible arm)")
    return value


def positive_float(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
    if not value > 0 or value == float("inf"):
        raise argparse.ArgumentTypeError(f"{text} must be a positive finite number")
    return value


def nonnegative_float(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
    if not value >= 0 or value == float("inf"):
        raise argparse.ArgumentTypeError(f"{text} must be zero or a positive finite number")
    return value


def parameter_override(text: str):
    name, sep, value = text.partition("=")
    if not sep:
        raise argparse.ArgumentTypeError(f"{text!r}: write a parameter override as NAME=VALUE")
    try:
        return name.strip(), float(value)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r}: the value of {name.strip()!r} is not a number") from None


class UsageError(GpmegenError):
    """A problem with the command line itself (exit status 2)."""


def progress(message: str) -> None:
    print(f"gpmegen: {message}", file=sys.stderr, flush=True)


def _writable_folder(path: Path) -> None:
    """Refuse early an output folder that cannot be written, so nothing is half-written."""
    import tempfile

    probe = path
    while not probe.exists() and probe != probe.parent:
        probe = probe.parent
    if not probe.is_dir():
        raise UsageError(f"output folder {path}: {probe} is a file, not a folder; choose another --out")
    try:
        path.mkdir(parents=True, exist_ok=True)
        with tempfile.TemporaryFile(dir=path):
            pass
    except OSError as exc:
        raise UsageError(f"output folder {path} is not writable ({exc.strerror}); choose another --out") from None


def cmd_build(args) -> int:
    from .codegen import build
    from .model import reference_model

    out = Path(args.out)
    _writable_folder(out)
    backends = ("numpy", "c")  # both are always rendered: the NumPy module is the C one's oracle
    total = time.perf_counter()
    for nrfe in args.nrfe:
        model = reference_model(nrfe)
        result = build(model, out, backends, force=args.force, progress=progress,
                       command=f"gpmegen build --nrfe {nrfe}")
        sizes = ", ".join(f"{name} {size / 1024:.0f} KiB" for name, size in result.files.items())
        state = "up to date, skipped (use --force to rebuild)" if result.skipped else f"built in {result.seconds:.2f} s"
        print(f"{result.model}: n_dof = {result.n_dof}, {state}; {result.folder}: {sizes}")
    if len(args.nrfe) > 1:
        print(f"total {time.perf_counter() - total:.2f} s")
    return 0


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="gpmegen",
        description="Reference dynamics models (GPME) of manipulators with flexible links, as generated code.",
    )
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    sub.required = True

    b = sub.add_parser("build", help="generate the NumPy and C modules of the reference manipulator")
    b.add_argument("--nrfe", type=positive_int, nargs="+", default=[5],
                   help="number of rigid finite elements of the arm (1: rigid); several allowed")
    b.add_argument("--out", default="generated", help="output folder (default: generated/)")
    b.add_argument("--backend", choices=("numpy", "c", "all"), default="all",
                   help="backends to generate (both are always written; the NumPy one is the C one's oracle)")
    b.add_argument("--force", action="store_true", help="rebuild even when the inputs are unchanged")
    b.set_defaults(func=cmd_build)
    return parser


def main(argv=None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return args.func(args)
    except UsageError as exc:
        print(f"gpmegen {args.command}: error: {exc}", file=sys.stderr)
        return 2
    except (ModelError, BuildError) as exc:
        print(f"gpmegen {args.command}: error: {exc}", file=sys.stderr)
        return 2 if isinstance(exc, ModelError) else 1
    except GpmegenError as exc:
        print(f"gpmegen {args.command}: error: {exc}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        print(f"gpmegen {args.command}: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
