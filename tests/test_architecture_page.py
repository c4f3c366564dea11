"""docs/architecture.md names real places: every backticked path of the package exists, and every
name given after a path (`path` `name`, `path` `Class.method`, ...) is defined in that file.

A path is read relative to `gpmegen/` (or the repository, for `tests/`, `templates/`, `docs/`);
a folder stands for itself (`cli/`). After a Python file, each following backticked name up to
the next `;`, `|`, other text or other path must be a def, class or assignment there (each part
of a dotted name, as `Reader.read`); after a C, header or template file it must occur there as
part of a word (its `<k>`/`*` placeholders left out).
"""

from __future__ import annotations

import ast
import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PAGE = ROOT / "docs" / "architecture.md"
SUFFIXES = (".py", ".c", ".h", ".j2", ".toml", ".md")
TOP = ("tests/", "templates/", "docs/", "benchmarks/", "examples/", "generated/")


def resolve(text: str) -> Path | None:
    """The file or folder a backticked path names, or None when it names none.

    A bare file name (`plots.py`, in a table of one subpackage's modules) is looked for anywhere
    in the package, the templates and the generated snapshots (`model.c`).
    """
    text = text.removeprefix("gpmegen/")
    if "/" not in text.rstrip("/"):
        name = text.rstrip("/")
        found = [hit for folder in ("gpmegen", "templates", "generated") for hit in (ROOT / folder).rglob(name)]
        if text == "pyproject.toml" or not found:
            return (ROOT / text) if (ROOT / text).exists() else None
        return found[0]
    bases = [ROOT] if text.startswith(TOP) or text == "pyproject.toml" else [ROOT / "gpmegen"]
    for base in bases:
        if (base / text).exists():
            return base / text
    return None


def is_path(text: str) -> bool:
    """Whether a backticked span is written as a path of the project."""
    if " " in text or "(" in text or "<" in text:
        return False
    return text.endswith(SUFFIXES) or (text.endswith("/") and text[0].isalpha())


def python_names(path: Path) -> set[str]:
    """Every name a Python file defines: functions, classes, methods, assignments."""
    names: set[str] = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
            names.add(node.name)
        elif isinstance(node, (ast.Assign, ast.AnnAssign)):
            targets = node.targets if isinstance(node, ast.Assign) else [node.target]
            for target in targets:
                for sub in ast.walk(target):
                    if isinstance(sub, ast.Name):
                        names.add(sub.id)
                    elif isinstance(sub, ast.Attribute):
                        names.add(sub.attr)
    return names


def defines(path: Path, name: str) -> bool:
    """Whether `name` (maybe dotted, maybe with a placeholder) is defined in the file."""
    if path.suffix == ".py":
        names = python_names(path)
        return all(part in names for part in name.split("."))
    word = re.sub(r"<[^>]*>|\*", "", name).strip("_")
    return re.search(r"\b\w*" + re.escape(word) + r"\w*\b", path.read_text()) is not None


def spans() -> list[tuple[int, str, str]]:
    """(line, backticked text, the text before the next backtick) of the page."""
    found = []
    parts = PAGE.read_text().split("`")
    number = 1 + parts[0].count("\n")
    for k in range(1, len(parts) - 1, 2):
        found.append((number, parts[k], parts[k + 1]))
        number += parts[k].count("\n") + parts[k + 1].count("\n")
    return found


def pairs() -> list[tuple[int, str, str]]:
    """(line, path, name) for each name written right after a path with its folder, or a list of
    them (separated by commas or "and"); a bare file name is left out, its folder unsaid."""
    result = []
    current: str | None = None
    for number, text, after in spans():
        if is_path(text):
            named = text.endswith((".py", ".c", ".h", ".j2")) and "/" in text
            current = text if named else None
        elif current is not None and re.fullmatch(r"[A-Za-z_<>*][\w.<>*]*", text):
            result.append((number, current, text))
        if not re.fullmatch(r"\s*(,|, and|and)?\s*", after):
            current = None
    return result


def test_every_backticked_path_exists():
    missing = [f"line {n}: {text}" for n, text, _ in spans() if is_path(text) and resolve(text) is None]
    assert not missing, "docs/architecture.md names paths that do not exist:\n" + "\n".join(missing)


def test_every_name_after_a_path_is_defined_there():
    wrong = []
    for number, path_text, name in pairs():
        path = resolve(path_text)
        if path is not None and path.is_file() and not defines(path, name):
            wrong.append(f"line {number}: {path_text} {name}")
    assert not wrong, "docs/architecture.md names what its file does not define:\n" + "\n".join(wrong)
