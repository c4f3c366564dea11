"""The FMU's archive (``gpmegen export --format fmu``): the files :mod:`gpmegen.codegen.backends.fmu`
renders for a case started as ``gpmegen simulate`` starts it, the binary compiled from them, and
the zip.

The archive holds

- ``modelDescription.xml`` (:func:`gpmegen.codegen.backends.fmu.model_description`);
- ``binaries/linux64/<model>.so``: the model's generated C (``model.c``, as gpmegen builds it),
  gpmegen's solver library (``gpmegen/csrc``) and the FMI wrapper (``gpmegen/fmi``) compiled into
  one shared library with gpmegen's flags, but for the processor: ``-march=native`` is left out, so
  that the binary runs on any x86-64 Linux (the flags that fix the roundings are kept). ``model.c``
  is compiled in its two parts as gpmegen compiles it, the solver library's object taken from the
  C cache;
- ``sources/``: every file of that compile, the C files listed in ``<SourceFiles>``, so that an
  importer builds the FMU for its own platform.

The start values are those of the run ``gpmegen simulate`` would make: the case's consistent start
and its parameter values (the reference arm's constraint constants bound). The archive is the same
byte for byte for the same model and compiler: its entries sorted, with a fixed time stamp and
compression.
"""

from __future__ import annotations

import io
import os
import shlex
import tempfile
import zipfile
from pathlib import Path

from ... import folder as folders
from ... import limits, outputs
from ...codegen.backends.casadi import check_inputs
from ...codegen.backends.fmu import (
    CONFIG,
    MODEL_FILES,
    WRAPPER,
    FmuBackend,
    config_header,
    guid,
    layout,
    model_description,
    wrapper_sources,
)
from ...errors import BuildError
from ...fileio import atomic_write_bytes
from ...runtime import ccompile, cstack
from ..post import driving

PLATFORM = "linux64"
#: Time stamp of every archive entry (the earliest a zip holds), for archives that are the same byte for byte.
ZIP_TIME = (1980, 1, 1, 0, 0, 0)


def stack_bytes(n: int, m: int) -> int:
    """Bytes of stack (an upper bound) of the FMU's calls for a model of ``n`` coordinates and ``m``
    constraints: the solver library's RK4 or DOP853 (:func:`gpmegen.runtime.cstack.call_bytes`),
    whose stages solve the GPME through the wrapper's own M and f (n² + n doubles), and
    :data:`gpmegen.runtime.cstack.RESERVE`."""
    calls = max(cstack.call_bytes(call, n, m, False) for call in ("rk4", "dop853"))
    return calls + 8 * (n * n + n) + cstack.RESERVE


def portable_flags() -> tuple:
    """gpmegen's flags of a model library without ``-march=native``: the FMU runs on other machines
    (the flags that fix the roundings are kept)."""
    return tuple(f for f in ccompile.DEFAULT_FLAGS if not f.startswith("-march"))


def compile_binary(sources: dict, identifier: str, progress=None) -> bytes:
    """The FMU's shared library, as bytes: ``model.c`` of ``sources`` (file name → text) compiled
    in its two parts as gpmegen compiles a model (:func:`gpmegen.runtime.ccompile.part_flags`), the
    wrapper, and the solver library's object from the C cache (compiled there once per compiler and
    flags, :func:`gpmegen.runtime.ccompile.build_solver`), all with :func:`portable_flags` (and
    the GCC flags under GCC). The compile runs in a fresh folder on relative names, so that no path
    of this machine enters the binary."""
    compiler = ccompile.find_compiler()
    solver = ccompile.build_solver(portable_flags(), progress=progress, compiler=compiler)
    flags = solver.flags
    cc = [os.path.abspath(compiler[0]), *compiler[1:]]
    target = f"{identifier}.so"
    compiles = [[*cc, *part, "-fPIC", f"-D{ccompile.PARTS}={k}", "-c", "model.c", "-o", f"model{k}.o"]
                for k, part in enumerate(ccompile.part_flags(flags), start=1)]
    compiles.append([*cc, *flags, "-fPIC", "-c", WRAPPER[0], "-o", "wrapper.o"])
    link = [*cc, *flags, *ccompile.LINK_FLAGS, "-o", target, "model1.o", "model2.o", "wrapper.o", str(solver.path),
            "-lm"]
    with tempfile.TemporaryDirectory(prefix="gpmegen-fmu-") as folder:
        for name, text in sources.items():
            Path(folder, name).write_text(text, encoding="utf-8")
        if progress:
            progress(f"compiling the FMU's binary ({identifier}.so)")
        results = ccompile._run_compilers(compiles, folder, progress)
        if all(code == 0 for code, _ in results):
            results += ccompile._run_compilers([link], folder, None)
        for argv, (code, diagnostics) in zip(compiles + [link], results):
            if code != 0:
                raise BuildError(f"compiling the FMU's binary failed (exit {code}):\n{diagnostics[:4000]}\n"
                                 f"command: {' '.join(shlex.quote(a) for a in argv)}")
        return Path(folder, target).read_bytes()


def archive(files: dict) -> bytes:
    """A zip of ``files`` (archive name → bytes): entries sorted, each with the same time stamp,
    permissions and compression, so that the same files give the same bytes."""
    buffer = io.BytesIO()
    with zipfile.ZipFile(buffer, "w") as zf:
        for name in sorted(files):
            info = zipfile.ZipInfo(name, date_time=ZIP_TIME)
            info.compress_type = zipfile.ZIP_DEFLATED
            info.create_system = 3   # Unix, so that the permissions below are read
            info.external_attr = (0o755 if name.endswith(".so") else 0o644) << 16
            zf.writestr(info, files[name], compresslevel=9)
    return buffer.getvalue()


def fmu_files(case, inputs=(), start=None, progress=None) -> dict:
    """The FMU's files (archive name → bytes) of ``case`` (:mod:`gpmegen.analysis.run.cases`) started as
    ``gpmegen simulate`` starts it (``start``: its statics, default the case's first), with inputs on
    the coordinates ``inputs``."""
    say = progress or (lambda line: None)
    ccompile.find_compiler()  # refused in one line before the statics when there is none
    model = case.model
    begun = case.started("numpy", start or case.starts[0], {}, say)   # the FMU compiles model.c itself
    loaded = begun.model
    inputs = check_inputs(loaded.coordinates, inputs)
    generated = {name: folders.read_verified(Path(loaded.folder), name) for name in MODEL_FILES}
    lambda_units = driving.lambda_units(model, case.metadata(loaded).get("constraint_units", {}))
    lay = layout(model, loaded, begun.q, begun.qd, inputs, lambda_units)
    config = config_header(model.name, loaded, inputs, lay.references, begun.q, begun.qd,
                           redundant_rows=bool(model.closures))
    sources = {**generated, **ccompile.solver_sources(), **wrapper_sources(), CONFIG: config}
    fmu_guid = guid(sources)
    sources[CONFIG] = config.replace("@GUID@", fmu_guid)
    c_files = sorted(name for name in sources if name.endswith(".c"))
    limits.check_compile(len(generated["model.c"].encode()), Path(loaded.folder) / "model.c")
    binary = compile_binary(sources, model.name, say)
    say(f"the FMU keeps up to {stack_bytes(loaded.n_dof, len(loaded.constraint_names)) / 1024:.0f} KiB of scratch "
        f"arrays on the stack of the thread that calls it")
    description = model_description(model, model.name, fmu_guid, lay, c_files)
    files = {"modelDescription.xml": description.encode("utf-8"),
             f"binaries/{PLATFORM}/{model.name}.so": binary}
    files.update({f"sources/{name}": text.encode("utf-8") for name, text in sources.items()})
    return files


def export(case, out, inputs=(), overwrite=False, start=None, progress=None) -> Path:
    """Write the FMU of ``case`` into the file ``out`` (``NAME.fmu``); ``overwrite`` replaces an
    earlier one. Returns its path."""
    FmuBackend().check(case.source)
    out = Path(out)
    if out.is_dir():
        raise outputs.OutputError(f"--out {out} is a folder; give the file to write, e.g. --out "
                                  f"{out / (case.model.name + '.fmu')}")
    if out.suffix != ".fmu":
        raise outputs.OutputError(f"--out {out} does not end in .fmu; name the FMU NAME.fmu, e.g. --out "
                                  f"{out.with_suffix('.fmu')}")
    outputs.check([out], (), overwrite)
    return atomic_write_bytes(out, archive(fmu_files(case, inputs, start, progress)))
