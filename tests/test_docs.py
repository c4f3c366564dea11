"""The documentation as a user meets it: every fenced code block of README.md and docs/*.md runs
as pasted, or is marked as what it is, every relative link and anchor resolves, and the command
line's reference page is the one its parser and help pages make.

What each fence holds, and what is done with it:

- ``python``: the blocks of one page run in order in one interpreter, as one script pasted from
  the page (so a block may use what an earlier one made, and the ``if __name__ == "__main__":``
  guard that a process pool needs is tested as a user's script would need it);
- ``console`` (``$ command`` lines, the other lines their output) and ``bash`` (every line a
  command): run with the environment's ``gpmegen`` on PATH. A ``console`` command whose shown
  output holds ``error:`` must fail with that error's text up to its first comma; the others
  must succeed;
- ``toml``: loads as a model file (``gpmegen.read_model_file``), or, after
  ``<!-- fragment -->``, parses as TOML with the top-level keys of a model file;
- ``text``: output, diagrams and help text, not run.

All blocks of a page run in one temporary folder holding copies of ``examples/`` and
``tests/models/`` (never in the checkout: the test asserts that ``git status`` is unchanged),
python and shell blocks interleaved in the page's order. A block after ``<!-- long -->`` is left
out of its page's run and runs under the ``long`` marker, in a folder of its own, after the
page's other blocks before it; one after
``<!-- not run: REASON -->`` (a Makefile target, a cluster) is only checked to say why.
"""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
import tomllib
from dataclasses import dataclass
from importlib import metadata
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PAGES = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
LANGUAGES = ("python", "console", "bash", "toml", "text")
FENCE = re.compile(r"^(\s*)```(.*)$")
MARK = re.compile(r"^<!--\s*(fragment|long|not run:\s*(?P<reason>.*?))\s*-->$")
SYNC = "@@docs-block@@"
ERROR_LINE = re.compile(r"^[\w.-]+(?: [\w-]+)?: error: ")  # "gpmegen simulate: error: ...", as commands fail


@dataclass
class Block:
    page: Path
    line: int          # of the opening fence, 1-based
    language: str
    code: str
    mark: str | None   # "fragment", "long", "not run" or None

    def where(self) -> str:
        page = self.page.relative_to(ROOT) if self.page.is_relative_to(ROOT) else self.page.name
        return f"{page}:{self.line}"


def blocks(page: Path) -> list[Block]:
    """The fenced code blocks of ``page``, each with the marking comment just before it."""
    lines = page.read_text(encoding="utf-8").splitlines()
    found, i = [], 0
    while i < len(lines):
        opening = FENCE.match(lines[i])
        if not opening:
            i += 1
            continue
        indent, language = opening.group(1), opening.group(2).strip()
        end = next(j for j in range(i + 1, len(lines)) if lines[j].strip() == "```")
        code = "\n".join(line[len(indent):] if line.startswith(indent) else line for line in lines[i + 1:end])
        before = next((lines[j].strip() for j in range(i - 1, -1, -1) if lines[j].strip()), "")
        mark = MARK.match(before)
        kind = None if mark is None else ("not run" if mark.group(1).startswith("not run") else mark.group(1))
        found.append(Block(page, i + 1, language, code + "\n", kind))
        i = end + 1
    return found


ALL = [block for page in PAGES for block in blocks(page)]


# ---------------------------------------------------------------- what every block is


def test_every_code_block_says_what_it_is():
    """A fence without a language, or with one the test does not know, would go unchecked."""
    unknown = [f"{b.where()}: ```{b.language}" for b in ALL if b.language not in LANGUAGES]
    assert not unknown, f"mark these blocks as one of {LANGUAGES}: {unknown}"
    misplaced = [b.where() for b in ALL if b.mark == "fragment" and b.language != "toml"]
    assert not misplaced, f"<!-- fragment --> marks TOML blocks only: {misplaced}"
    unexplained = [b.where() for b in ALL if b.mark == "not run" and not _reason(b)]
    assert not unexplained, f"<!-- not run: REASON --> needs its reason: {unexplained}"


def _reason(block: Block) -> str:
    lines = block.page.read_text(encoding="utf-8").splitlines()
    before = next(lines[j].strip() for j in range(block.line - 2, -1, -1) if lines[j].strip())
    return MARK.match(before).group("reason") or ""


@pytest.mark.parametrize("block", [b for b in ALL if b.language == "toml"], ids=lambda b: b.where())
def test_every_toml_block_loads_as_a_model_file_or_a_fragment_of_one(block, tmp_path):
    from gpmegen.analysis.run.model_files import read_model_file

    data = tomllib.loads(block.code)  # a block that is no TOML fails here, naming its line
    if block.mark == "fragment":
        unknown = sorted(set(_keys(data)) - _vocabulary())
        assert not unknown, f"{block.where()}: keys {unknown} are no model file's"
        return
    _copy_inputs(tmp_path)
    path = tmp_path / "model.toml"
    path.write_text(block.code, encoding="utf-8")
    read_model_file(path)


# tables whose keys are the model's own names (params: a controller's; coordinates and
# constraint_units: [presentation]'s labels of its coordinates and constraints)
FREE_NAMES = ("parameters", "q", "qd", "set", "params", "coordinates", "constraint_units")


def _keys(table: dict):
    """Every key of a TOML table and of the tables within it, but the model's own names."""
    for key, value in table.items():
        yield key
        values = value if isinstance(value, list) else [value]
        for item in values:
            if isinstance(item, dict) and key not in FREE_NAMES:
                yield from _keys(item)


def _vocabulary() -> set[str]:
    """The keys the model file reader knows: the names it asks for, as quoted in its source and
    in the element kinds' (which read their own tables)."""
    words = set()
    for source in [*(ROOT / "gpmegen" / "model" / "file").glob("*.py"),
                   *(ROOT / "gpmegen" / "model" / "elements").glob("*.py")]:
        words |= set(re.findall(r"[\"']([A-Za-z_][A-Za-z0-9_]*)[\"']", source.read_text(encoding="utf-8")))
    return words


# ---------------------------------------------------------------- links


def slug(heading: str) -> str:
    """GitHub's anchor of a heading: lower case, markup and punctuation dropped, spaces to '-'."""
    text = re.sub(r"[`*_]|!?\[([^\]]*)\]\([^)]*\)", lambda m: m.group(1) or "", heading.strip()).lower()
    return re.sub(r"[^\w\- ]", "", text).replace(" ", "-")


def anchors(page: Path) -> set[str]:
    seen: dict[str, int] = {}
    out = set()
    inside = False
    for line in page.read_text(encoding="utf-8").splitlines():
        if line.lstrip().startswith("```"):
            inside = not inside
        if inside or not line.startswith("#"):
            continue
        base = slug(line.lstrip("#"))
        count = seen.get(base, 0)
        seen[base] = count + 1
        out.add(base if count == 0 else f"{base}-{count}")
    return out


def links(page: Path) -> list[tuple[int, str]]:
    """The link targets of ``page`` outside code, with their lines."""
    found, inside = [], False
    for number, line in enumerate(page.read_text(encoding="utf-8").splitlines(), 1):
        if line.lstrip().startswith("```"):
            inside = not inside
            continue
        if inside:
            continue
        line = re.sub(r"`[^`]*`", "", line)
        found += [(number, target) for target in re.findall(r"\]\(([^)\s]+)\)", line)]
    return found


def test_every_relative_link_and_anchor_resolves():
    broken = []
    for page in PAGES:
        for number, target in links(page):
            if re.match(r"[a-z]+:", target):
                continue
            path, _, anchor = target.partition("#")
            file = (page.parent / path).resolve() if path else page
            if not file.exists():
                broken.append(f"{page.relative_to(ROOT)}:{number}: {target} (no such file)")
            elif anchor and file.suffix == ".md" and anchor not in anchors(file):
                broken.append(f"{page.relative_to(ROOT)}:{number}: {target} (no such heading)")
    assert not broken, "\n".join(broken)


# ---------------------------------------------------------------- the command line's page


def test_command_line_page_is_the_one_its_parser_and_help_pages_make():
    from gpmegen import cli_docs

    committed = (ROOT / "docs" / "command-line.md").read_text(encoding="utf-8")
    assert committed == cli_docs.page(), "docs/command-line.md is out of date: make docs"


def _runs(tmp_path) -> tuple:
    """Short runs of a model that has everything but closed loops, forces between points and
    control (the flexible arm), of one that closes a loop (the four-bar), of one with a force
    element (the hung mass) and of one under computed torque (the two links of ct_arm.toml):
    their results files."""
    from gpmegen.cli import main

    run = tmp_path / "run.npz"
    assert main(["simulate", "--nrfe", "5", "--t-end", "0.002", "--dt", "1e-4", "--save-every", "5",
                 "--backend", "numpy", "--out", str(run)]) == 0  # the flexible arm: every figure applies
    loop = tmp_path / "loop.npz"
    assert main(["simulate", str(ROOT / "examples" / "four_bar.toml"), "--t-end", "0.002", "--dt", "1e-4",
                 "--save-every", "5", "--backend", "numpy", "--out", str(loop)]) == 0
    hung = tmp_path / "hung.npz"
    assert main(["simulate", str(ROOT / "tests" / "models" / "spring_hanger.toml"), "--t-end", "0.002", "--dt",
                 "1e-4", "--save-every", "5", "--backend", "numpy", "--out", str(hung)]) == 0
    controlled = tmp_path / "controlled.npz"
    assert main(["simulate", str(ROOT / "tests" / "models" / "ct_arm.toml"), "--t-end", "0.002", "--dt", "1e-4",
                 "--save-every", "5", "--backend", "numpy", "--out", str(controlled)]) == 0
    return run, loop, hung, controlled


def test_plot_lists_exactly_the_figures_its_help_page_lists(tmp_path):
    """The help pages of plot and demo list the figures from the list the plots are drawn from,
    and the four runs between them have every figure of the list but those of --reference, each
    its own (the test below draws them, in make check-c)."""
    from gpmegen import cli_docs
    from gpmegen.analysis.figures import run_figures
    from gpmegen.analysis.figures.figure_list import FIGURES
    from gpmegen.analysis.post import results as results_io

    page = cli_docs.page()
    for command in ("plot", "demo"):
        help_text = page.split(f"## gpmegen {command}\n", 1)[1].split("\n## ", 1)[0]
        assert all(f"  {figure.stem}: " in help_text for figure in FIGURES), command
    stems = [{stem for stem, _ in run_figures.figures([results_io.load(path)])} for path in _runs(tmp_path)]
    assert not {"closure_reactions", "force_elements", "tracking_error", "control_effort"} & stems[0]
    assert "closure_reactions" in stems[1] and "force_elements" in stems[2]
    assert {"tracking_error", "control_effort"} <= stems[3]
    assert sorted(set().union(*stems)) == sorted(figure.stem for figure in FIGURES if not figure.reference)


@pytest.mark.long
def test_plot_writes_exactly_the_figures_its_help_page_lists(tmp_path):
    """Real plots of the four runs (the controlled one with --reference) write exactly the figures
    of the list between them."""
    from gpmegen.analysis.figures.figure_list import FIGURES
    from gpmegen.cli import main

    run, loop, hung, controlled = _runs(tmp_path)
    out = tmp_path / "figures"
    assert main(["plot", str(run), "--out", str(out)]) == 0
    assert main(["plot", str(loop), "--out", str(tmp_path / "loop_figures")]) == 0
    assert main(["plot", str(hung), "--out", str(tmp_path / "hung_figures")]) == 0
    assert main(["plot", str(controlled), "--reference", str(controlled), "--out", str(tmp_path / "ct_figures")]) == 0
    assert "force_elements.png" in {p.name for p in (tmp_path / "hung_figures").iterdir()}
    written = {p.name for folder in (out, tmp_path / "loop_figures", tmp_path / "hung_figures",
                                     tmp_path / "ct_figures") for p in folder.iterdir() if p.suffix == ".png"}
    assert not {"closure_reactions.png", "force_elements.png"} & {p.name for p in out.iterdir()}
    assert sorted(written) == sorted(f"{figure.stem}.png" for figure in FIGURES)


# ---------------------------------------------------------------- the blocks run


def _copy_inputs(folder: Path) -> None:
    shutil.copytree(ROOT / "examples", folder / "examples")
    shutil.copytree(ROOT / "tests" / "models", folder / "tests" / "models")


def _git_status() -> str | None:
    if not (ROOT / ".git").exists() or shutil.which("git") is None:
        return None
    return subprocess.run(["git", "status", "--porcelain", "--untracked-files=all"], cwd=ROOT,
                          capture_output=True, text=True, check=True).stdout


def _environment(shared_cache) -> dict:
    env = dict(os.environ)
    env["PATH"] = f"{Path(sys.executable).parent}{os.pathsep}{env.get('PATH', '')}"
    env["GPMEGEN_CACHE"] = str(shared_cache)
    env["MPLBACKEND"] = "Agg"
    env.pop("COLUMNS", None)
    return env


def _commands(block: Block) -> list[tuple[str, list[str]]]:
    """A console block's commands, each with the output lines shown after it."""
    out: list[tuple[str, list[str]]] = []
    pending = ""
    for line in block.code.splitlines():
        if pending:
            pending += "\n" + line
        elif line.startswith("$ "):
            pending = line[2:]
        else:
            if out:
                out[-1][1].append(line)
            continue
        if not pending.endswith("\\"):
            out.append((pending, []))
            pending = ""
    return out


def _run_shell(block: Block, folder: Path, env: dict) -> None:
    if block.language == "bash":
        done = subprocess.run(["bash", "-e", "-o", "pipefail", "-c", block.code], cwd=folder, env=env,
                              capture_output=True, text=True)
        assert done.returncode == 0, (f"{block.where()}: exit {done.returncode}\n"
                                      f"{done.stdout[-2000:]}{done.stderr[-3000:]}")
        return
    commands = _commands(block)
    assert commands, f"{block.where()}: a console block without '$ ' commands: mark it ```text"
    for command, shown in commands:
        done = subprocess.run(["bash", "-o", "pipefail", "-c", command], cwd=folder, env=env,
                              capture_output=True, text=True)
        error = next((line for line in shown if ERROR_LINE.match(line)), None)
        if error is None:
            assert done.returncode == 0, (f"{block.where()}: {command!r} exit {done.returncode}\n"
                                          f"{done.stdout[-2000:]}{done.stderr[-3000:]}")
        else:
            expected = error.split(",")[0]
            assert done.returncode != 0 and expected in done.stderr, (
                f"{block.where()}: {command!r} should fail with {expected!r}; exit {done.returncode}\n"
                f"{done.stderr[-3000:]}")


PRELUDE = f'''import sys as _docs_sys


def _docs_block(k):
    if __name__ == "__main__":
        print("{SYNC}", k, flush=True)
        if _docs_sys.stdin.readline().strip() != "go":
            raise SystemExit(3)
'''


class PythonPage:
    """The python blocks of one page as one script, run in one interpreter; the script stops
    before each block until told to go on, so that the page's shell blocks run in between."""

    def __init__(self, python_blocks: list[Block], folder: Path, env: dict):
        self.blocks = python_blocks
        text, self.starts = PRELUDE, []
        for k, block in enumerate(python_blocks):
            text += f"\n_docs_block({k})\n"
            self.starts.append(text.count("\n") + 1)
            text += block.code
        text += f"\n_docs_block({len(python_blocks)})\n"
        self.script = folder / "docs_page.py"
        self.script.write_text(text, encoding="utf-8")
        self.stderr = folder / "docs_page.stderr"
        self.folder, self.env = folder, env
        self.process = None
        self.paused_at = None  # the block the script waits before

    def _wait(self, k: int) -> None:
        if self.process is None:
            self.process = subprocess.Popen([sys.executable, self.script.name], cwd=self.folder, env=self.env,
                                            stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                                            stderr=self.stderr.open("w"), text=True)
        while self.paused_at != k:
            line = self.process.stdout.readline()
            if not line:
                self.process.wait()
                self._fail()
            if line.startswith(SYNC):
                self.paused_at = int(line.split()[-1])

    def _fail(self):
        err = self.stderr.read_text(encoding="utf-8")
        lines = [int(n) for n in re.findall(rf'File "[^"]*{self.script.name}", line (\d+)', err)]
        k = max((i for i, start in enumerate(self.starts) if lines and start <= lines[-1]), default=None)
        where = self.blocks[k].where() if k is not None else "the page's python blocks"
        pytest.fail(f"{where}: the block failed (exit {self.process.returncode})\n{err[-4000:]}")

    def finish_previous(self, k: int) -> None:
        """Let the blocks before ``k`` run to their end (so that a shell block may follow them)."""
        if k > 0 or self.process is not None:
            self._wait(k)

    def run(self, k: int) -> None:
        self._wait(k)
        self.process.stdin.write("go\n")
        self.process.stdin.flush()
        self.paused_at = None

    def close(self) -> None:
        if self.process is None:
            return
        self._wait(len(self.blocks))
        self.process.stdin.write("go\n")
        self.process.stdin.close()
        if self.process.wait() != 0:
            self._fail()
        self.process.stdout.close()


def _run_blocks(chosen: list[Block], folder: Path, env: dict) -> None:
    python = [b for b in chosen if b.language == "python"]
    page = PythonPage(python, folder, env)
    try:
        for block in chosen:
            if block.language == "python":
                page.run(python.index(block))
            elif block.language in ("console", "bash"):
                page.finish_previous(sum(1 for b in python if b.line < block.line))
                _run_shell(block, folder, env)
        page.close()
    finally:
        if page.process is not None and page.process.poll() is None:
            page.process.kill()
            page.process.wait()


RUN = ("python", "console", "bash")


def _runnable(page: Path) -> list[Block]:
    return [b for b in blocks(page) if b.language in RUN and b.mark is None]


@pytest.fixture
def untouched_checkout():
    before = _git_status()
    yield
    assert _git_status() == before, "a documented command changed files of the checkout"


# Pages whose blocks build and compile several models of their own, export FMUs or run studies
# (5-40 s of CPU each): they run in make check-c, the README and the other pages in make test.
LONG_PAGES = ("tutorial.md", "integrators.md", "exports.md", "studies.md", "model-file.md", "python-api.md", "runs.md")


@pytest.mark.parametrize("page", [pytest.param(p, marks=[pytest.mark.long] if p.name in LONG_PAGES else [])
                                  for p in PAGES[1:] if _runnable(p)], ids=lambda p: str(p.relative_to(ROOT)))
def test_every_code_block_of_the_page_runs_as_pasted(page, tmp_path, shared_cache, untouched_checkout):
    _copy_inputs(tmp_path)
    _run_blocks(_runnable(page), tmp_path, _environment(shared_cache))


def test_every_readme_code_block_runs_as_pasted(tmp_path, shared_cache, untouched_checkout):
    """The README on its own (the page a new user reads first)."""
    _copy_inputs(tmp_path)
    _run_blocks(_runnable(ROOT / "README.md"), tmp_path, _environment(shared_cache))


@pytest.mark.long
@pytest.mark.parametrize("block", [b for b in ALL if b.mark == "long" and b.language in RUN], ids=lambda b: b.where())
def test_long_code_block_runs_after_the_blocks_before_it(block, tmp_path, shared_cache, untouched_checkout):
    """After the blocks of its page before it (whose files it may read), as the page is pasted."""
    if "panda" in block.code or "baxter" in block.code:  # their URDFs come with the example-robot-data
        # package (data, no module)
        try:
            metadata.distribution("example-robot-data")
        except metadata.PackageNotFoundError:
            pytest.skip("example-robot-data is not installed (pip install -e .[test])")
    _copy_inputs(tmp_path)
    before = [b for b in _runnable(block.page) if b.line < block.line]
    _run_blocks([*before, block], tmp_path, _environment(shared_cache))


# ---------------------------------------------------------------- the checks themselves


def test_a_toml_fragment_with_a_key_no_model_file_knows_is_refused():
    misspelled = tomllib.loads('[[chain]]\njoint = "a"\nstifness = 1.0\n')
    right = tomllib.loads('[[chain]]\njoint = "a"\nstiffness = 1.0\n[parameters]\nmy_name = 1.0\n')
    assert set(_keys(misspelled)) - _vocabulary() == {"stifness"}
    assert not set(_keys(right)) - _vocabulary()


def _page(folder: Path, text: str) -> list[Block]:
    page = folder / "page.md"
    page.write_text(text, encoding="utf-8")
    return blocks(page)


def test_python_and_shell_blocks_of_a_page_run_in_its_order_in_one_interpreter(tmp_path):
    chosen = _page(tmp_path, """\
```python
made = 1
open("a.txt", "w").write("from python")
```

```console
$ cat a.txt > b.txt
```

```python
assert made == 1 and open("b.txt").read() == "from python"
```
""")
    _run_blocks(chosen, tmp_path, dict(os.environ))


def test_a_block_using_a_name_no_earlier_block_made_fails_naming_its_line(tmp_path):
    """As the README's generated-model block did with q, qd and t."""
    chosen = _page(tmp_path, "```python\nx = 1\n```\n\ntext\n\n```python\nprint(q)\n```\n")
    with pytest.raises(pytest.fail.Exception, match=r"page.md:7: the block failed(.|\n)*NameError: name 'q'"):
        _run_blocks(chosen, tmp_path, dict(os.environ))


def test_a_console_command_shown_failing_must_fail_with_that_error(tmp_path):
    shown = _page(tmp_path, "```console\n$ echo 'prog: error: no such thing, really' >&2; exit 2\n"
                            "prog: error: no such thing, really\n```\n")
    _run_blocks(shown, tmp_path, dict(os.environ))
    output = _page(tmp_path, "```console\n$ echo 'per output, its discretization error: 1e-6'\n"
                             "per output, its discretization error: 1e-6\n```\n")
    _run_blocks(output, tmp_path, dict(os.environ))  # output that speaks of an error is no failure
    passing = _page(tmp_path, "```console\n$ true\nprog: error: no such thing, really\n```\n")
    with pytest.raises(AssertionError, match="should fail with 'prog: error: no such thing'"):
        _run_blocks(passing, tmp_path, dict(os.environ))
