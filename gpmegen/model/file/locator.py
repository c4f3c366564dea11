"""Where fields are in a model file: line numbers of TOML tables and keys by field path, and
the field path as the messages write it."""

from __future__ import annotations

import re

from ..chain import Branch


def _key_parts(text: str) -> list[str]:
    return [p[1:-1] if p[0] in "\"'" else p
            for p in re.findall(r'"[^"]*"|\'[^\']*\'|[A-Za-z0-9_-]+', text)]


class Locator:
    """Line numbers of the tables and keys of a TOML text, by field path.

    ``tomllib`` reports no positions, so the text is scanned: table headers (the k-th
    ``[[chain]]`` is ``("chain", k)``) and ``key =`` at the start of a line, with strings,
    comments and brackets tracked so that continuation lines of arrays are not mistaken for
    headers. Keys inside inline tables share the line of the table's key."""

    _HEADER = re.compile(r"^\s*(\[\[?)\s*([^\]]+?)\s*\]\]?\s*(#.*)?$")
    _PART = r'(?:"[^"]*"|\'[^\']*\'|[A-Za-z0-9_-]+)'
    _KEY = re.compile(rf"^\s*({_PART}(?:\s*\.\s*{_PART})*)\s*=")

    def __init__(self, text: str):
        self.lines: dict[tuple, int] = {}
        self.last = max(1, text.count("\n") + 1)
        arrays: dict[tuple, int] = {}
        table: tuple = ()
        depth = 0
        multiline = None
        for number, line in enumerate(text.splitlines(), 1):
            start = 0
            if multiline is None and depth == 0:
                header = self._HEADER.match(line)
                if header:
                    parts = _key_parts(header.group(2))
                    names: tuple = ()
                    path: list = []
                    for k, part in enumerate(parts):
                        names += (part,)
                        path.append(part)
                        last = k == len(parts) - 1
                        if header.group(1) == "[[" and last:
                            arrays[names] = arrays.get(names, 0) + 1
                        if names in arrays:
                            path.append(arrays[names] - 1)
                    table = tuple(path)
                    self.lines.setdefault(table, number)
                    continue
                key = self._KEY.match(line)
                if key:
                    parts = _key_parts(key.group(1))
                    for k in range(1, len(parts) + 1):
                        self.lines.setdefault(table + tuple(parts[:k]), number)
                    start = key.end()
            depth, multiline = self._scan(line, start, depth, multiline)

    @staticmethod
    def _scan(line, i, depth, multiline):
        """Bracket depth and open multi-line string after ``line[i:]``."""
        n = len(line)
        while i < n:
            if multiline:
                end = line.find(multiline, i)
                if end < 0:
                    return depth, multiline
                i, multiline = end + 3, None
                continue
            c = line[i]
            if c == "#":
                break
            if line.startswith('"""', i) or line.startswith("'''", i):
                multiline, i = line[i:i + 3], i + 3
                continue
            if c in "\"'":
                j = i + 1
                while j < n and line[j] != c:
                    j += 2 if (c == '"' and line[j] == "\\") else 1
                i = j + 1
                continue
            if c in "[{":
                depth += 1
            elif c in "]}":
                depth = max(0, depth - 1)
            i += 1
        return depth, multiline

    def line(self, path) -> int:
        path = tuple(path)
        for k in range(len(path), 0, -1):
            if path[:k] in self.lines:
                return self.lines[path[:k]]
        return 1



def field_text(path) -> str:
    text = ""
    for part in path:
        if isinstance(part, int):
            text += f"[{part}]"
        else:
            part = str(part)
            if not part.isprintable():  # keys are the user's: keep the message on one line
                part = repr(part)
            text += ("." if text else "") + part
    return text



def file_path(path, chain=()) -> tuple:
    """``path``, a field of a model whose elements are ``chain``, as a field of the model file
    that made it: a Branch element is made by the ``parent`` key of the ``[[chain]]`` table
    after it, and is no table of its own, so the k-th element of the chain is the table counted
    without the Branches before it."""
    path = tuple(path)
    if len(path) < 2 or path[0] != "chain" or not isinstance(path[1], int) or not chain:
        return path
    return ("chain", sum(not isinstance(e, Branch) for e in chain[:path[1]])) + path[2:]


def located(error, file: str, locator: Locator, chain=()):
    """``error`` of the model layer or the derivation as an error of the same type whose message
    starts with ``"<file>:<line>: <field>: "`` for the field it is about (``error.subject``),
    and names the line of a second field it is about (``error.other``); ``chain``: the model's
    chain, whose fields the error names (:func:`file_path`)."""
    subject, other = getattr(error, "subject", ()), getattr(error, "other", ())
    subject, other = file_path(subject, chain), file_path(other, chain)
    message = str(error)
    if other:
        message += f" (the other is {field_text(other)}, line {locator.line(other)})"
    if not subject:
        return type(error)(f"{file}: {message}")
    return type(error)(f"{file}:{locator.line(subject)}: {field_text(subject)}: {message}", subject, other)
