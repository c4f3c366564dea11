"""Commands that write a model: ``build`` (the generated NumPy and C modules) and ``export``
(URDF, CasADi functions, an FMU)."""
from __future__ import annotations

import functools
import time
from pathlib import Path

from .. import limits, outputs
from ..model.size import coordinate_count
from .common import UsageError, open_case, progress


def cmd_build(args) -> int:
    from ..codegen import backends as registry
    from ..codegen import build
    from ..folder import check_replaceable, read_manifest
    from ..runtime.loader import default_directory
    from ..symbolic.transforms import DEFAULT as DEFAULT_TRANSFORMS

    out = Path(args.out) if args.out is not None else default_directory()  # where the other commands look
    cases = [open_case(args.model_file, n) for n in (args.nrfe or [None])]
    models = [case.model for case in cases]  # a bad model is refused before anything is written
    for model in models:  # a folder without gpmegen's manifest is always built again, so refused at once
        if args.force or read_manifest(out / model.name) is None:
            check_replaceable(out / model.name, registry.folder_files())
            # and a build too long for the limits, before --out is created
            limits.check_build(coordinate_count(model), model.name, jacobians=args.jacobians)
    outputs.writable_folder(out)
    backends = ("numpy", "c")  # both are always rendered: the NumPy module is the C one's oracle
    transforms, asked = DEFAULT_TRANSFORMS, ""
    if args.transforms is not None:
        transforms, asked = args.transforms, f" --transforms {','.join(args.transforms) or 'none'}"
    if args.jacobians:
        asked += " --jacobians"
    total = time.perf_counter()
    for case, model in zip(cases, models):
        result = case.located(functools.partial(build, model, out, backends, force=args.force, progress=progress,
                                                command=case.command + asked, transforms=transforms,
                                                jacobians=args.jacobians))
        case.record_start(result.folder)
        sizes = ", ".join(f"{name} {size / 1024:.0f} KiB" for name, size in result.files.items())
        state = "up to date, skipped (use --force to rebuild)" if result.skipped else f"built in {result.seconds:.2f} s"
        print(f"{result.model}: n_dof = {result.n_dof}, {state}; {result.folder}: {sizes}")
    if len(cases) > 1:
        print(f"total {time.perf_counter() - total:.2f} s")
    return 0


def cmd_export(args) -> int:
    from ..fileio import atomic_write_bytes
    from ..model.urdf_export import urdf_text

    case = open_case(args.model_file, args.nrfe)
    out = Path(args.out)
    if args.format == "casadi":
        return _export_casadi(case, out, args)
    if args.format == "fmu":
        return _export_fmu(case, out, args)
    if args.inputs:
        raise UsageError("--inputs is for --format casadi and fmu (a URDF holds no inputs); leave it out")
    if out.is_dir():
        raise UsageError(f"--out {out} is a folder; give the file to write, e.g. --out {out / 'arm.urdf'}")
    outputs.check([out], [args.model_file], args.overwrite)
    text = case.located(functools.partial(urdf_text, case.model))
    print(f"wrote {atomic_write_bytes(out, text.encode('utf-8'))}: {case.model.name} as URDF")
    return 0


def _export_casadi(case, out, args) -> int:
    """``export --format casadi``: the model's CasADi functions in the folder ``out``."""
    from ..codegen.backends import casadi as casadi_export

    casadi_export.require_casadi()  # before the derivation, which takes a while
    outputs.check([out], [args.model_file], overwrite=True)  # never over the model file; its own files below
    command = "gpmegen export " + " ".join(
        [*([str(args.model_file)] if args.model_file else []), *(["--nrfe", str(args.nrfe)] if args.nrfe else []),
         "--format casadi", f"--out {out}", *(["--inputs", ",".join(args.inputs)] if args.inputs else [])])
    made = case.located(functools.partial(casadi_export.export, case.model, out, args.inputs or (), command,
                                          args.overwrite))
    print(f"wrote {out}: {case.model.name} as CasADi functions {', '.join(made)} (.casadi) and their source "
          f"{casadi_export.SOURCE}")
    return 0


def _export_fmu(case, out, args) -> int:
    """``export --format fmu``: the model as an FMU (FMI 2.0 Model Exchange and Co-Simulation) in the file ``out``."""
    from ..codegen.backends import fmu as fmu_export

    outputs.check([out], [args.model_file], overwrite=True)  # never over the model file
    made = case.located(functools.partial(fmu_export.export, case, out, args.inputs or (), args.overwrite,
                                          progress=progress))
    print(f"wrote {made}: {case.model.name} as an FMU (FMI 2.0 Model Exchange and Co-Simulation, "
          f"binary for {fmu_export.PLATFORM} and sources)")
    return 0
