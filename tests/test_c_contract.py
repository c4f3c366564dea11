"""The generated code's contract: documented functions, the C header, per-model symbols and the
status codes of gpmegen.status."""

import re
import subprocess

import numpy as np
import pytest

from gpmegen.codegen import render
from gpmegen.codegen.functions import arguments, model_functions
from gpmegen.folder import write_folder
from gpmegen.model import reference_model
from gpmegen.runtime import ccompile
from gpmegen.runtime.loader import import_numpy_module
from gpmegen.status import SolveStatus
from gpmegen.symbolic import derive


@pytest.fixture(scope="module")
def built(tmp_path_factory):
    """The rigid and the two-rfe arm generated into one folder: ``{n_rfe: model folder}``."""
    out = tmp_path_factory.mktemp("generated")
    folders = {}
    for nrfe in (1, 2):
        model = reference_model(nrfe)
        folders[nrfe] = out / model.name
        write_folder(folders[nrfe], render(model, ("numpy", "c")))
    return folders


def _documented(text: str, c: bool) -> list[str]:
    """``name: description`` lines of one docstring or C comment."""
    prefix = r"(?:out_)?" if c else ""
    return re.findall(rf"^\s+{prefix}(\w+): (.*)$", text, re.M)


def test_every_function_documents_its_arguments_and_the_documented_shapes_hold(built):
    folder = built[1]
    module = import_numpy_module(folder)
    header = (folder / "model.h").read_text()
    n, n_p, m = len(module.COORDINATES), len(module.PARAMETERS), len(module.CONSTRAINTS)
    values = {"t": 0.3, "q": np.full(n, 0.2), "qd": np.full(n, 0.1), "a": np.full(n, 0.3), "lam": np.full(m, 0.5),
              "p": np.array(module.DEFAULTS)}
    for fn in model_functions(derive(reference_model(1))):
        described = list(arguments(fn, n, n_p, m))
        python = getattr(module, fn.name)
        assert _documented(python.__doc__, c=False) == described, fn.name
        comment = header[:header.index(f"{module.MODEL}_{fn.name}(")].rsplit("/*", 1)[1]
        assert _documented(comment, c=True) == described, fn.name
        results = python(*(values[a] for a in fn.inputs))
        results = results if isinstance(results, tuple) else (results,)
        for result, (name, text) in zip(results, described[len(fn.inputs):], strict=True):
            assert text.startswith(f"{np.shape(result)} "), (fn.name, name, text)
    assert "(3,) coordinates in COORDINATES order" in python.__doc__


def test_the_header_declares_the_status_codes_of_gpmegen_status(built):
    """model.h and the solver library's header declare the same codes, those of gpmegen.status, and
    the C (the model's and the solver library's) returns each of them somewhere."""
    solver = ccompile.solver_sources()
    for header in ((built[1] / "model.h").read_text(), solver[ccompile.SOLVER_HEADER]):
        enum = re.search(r"enum gpmegen_status \{(.*?)\};", header, re.S).group(1)
        assert re.findall(r"GPMEGEN_(\w+) = (\d+)", enum) == [(s.name, str(s.value)) for s in SolveStatus]
    source = (built[1] / "model.c").read_text() + "".join(solver.values())
    status_returns = re.findall(r"return (GPMEGEN_\w+)", source)
    assert {f"GPMEGEN_{s.name}" for s in SolveStatus} == set(status_returns)


def test_the_cffi_declarations_are_the_header_without_preprocessor_lines(built):
    header = (built[1] / "model.h").read_text()
    cdef = ccompile.declarations(header)
    assert "#" not in cdef and "manipulator_nrfe1_rk4(" in cdef
    functions = model_functions(derive(reference_model(1)))
    assert sorted(ccompile.short_names(re.findall(r"(\w+)\(", cdef))) == sorted(
        [fn.name for fn in functions] + [fn.name + "_batch" for fn in functions if fn.batched]
        + ["input_hash", "n_dof", "n_constraints", "n_parameters", "n_points", "gpme_motion",
           "gpme_accelerations", "gpme_accelerations_batch", "gpme_jacobian", "rk4", "dop853", "radau", "genalpha",
           "dop853_memory_bytes", "radau_memory_bytes", "actuated_motion", "rk4_actuated",
           "dop853_actuated"])


@pytest.mark.requires_cc
def test_the_library_binds_its_functions_under_their_short_names(built, shared_cache):
    _, lib, _ = ccompile.load_library(built[2] / "model.c", cache=shared_cache)
    assert lib.n_dof() == 6 and not hasattr(lib, "manipulator_nrfe2_n_dof")


@pytest.mark.requires_cc
def test_two_models_link_into_one_program(built, tmp_path, shared_cache):
    """Each exported name carries its model's prefix and the rest is static: two models'
    C files compile and link beside a main() that calls both."""
    calls, expected = [], []
    for folder in built.values():
        module = import_numpy_module(folder)
        n, name = len(module.COORDINATES), module.MODEL
        q = 0.1 * np.arange(1, n + 1)
        array = ", ".join(repr(float(x)) for x in q)
        p = ", ".join(repr(x) for x in module.DEFAULTS)
        calls.append(f"""    {{
        const double q[{n}] = {{{array}}}, p[{len(module.DEFAULTS)}] = {{{p}}};
        double M[{n * n}];
        {name}_mass_matrix(q, p, M);
        printf("%d %.17g\\n", {name}_n_dof(), M[{n * n - 1}]);
    }}""")
        expected.append((n, module.mass_matrix(q, module.DEFAULTS)[-1, -1]))
    includes = "".join(f'#include "{folder.name}/model.h"\n' for folder in built.values())
    main = tmp_path / "main.c"
    # each header twice: the include guards keep the second from declaring anything again
    main.write_text(f"#include <stdio.h>\n{includes}{includes}\nint main(void)\n{{\n" + "\n".join(calls)
                    + "\n    return GPMEGEN_OK;\n}\n")
    program = tmp_path / "two_models"
    cc = ccompile.find_compiler()
    sources = [str(folder / "model.c") for folder in built.values()]
    solver = str(ccompile.build_solver(cache=shared_cache).path)  # one copy serves both models
    link = subprocess.run([*cc, "-std=c99", "-Wall", "-Wextra", "-Werror", "-I", str(built[1].parent),
                           f"-I{ccompile.solver_include()}", str(main), *sources, solver, "-lm", "-o", str(program)],
                          capture_output=True, text=True)
    assert link.returncode == 0, link.stderr
    printed = subprocess.run([str(program)], check=True, capture_output=True, text=True).stdout.split("\n")[:2]
    for line, (n, m_last) in zip(printed, expected, strict=True):
        got_n, got_m = line.split()
        assert int(got_n) == n and float(got_m) == pytest.approx(m_last, rel=1e-12)


# make check-c: a compile of its own
@pytest.mark.long
@pytest.mark.requires_cc
def test_a_compiler_named_relative_to_the_callers_folder_still_compiles(built, tmp_path, fresh_cache, monkeypatch):
    """The compiler runs in a private folder holding the header: a relative $CC still names it."""
    (tmp_path / "mycc").symlink_to(ccompile.find_compiler()[0])
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("CC", "./mycc")
    assert ccompile.build_library(built[1] / "model.c", cache=fresh_cache).compiled
