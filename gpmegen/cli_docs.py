"""The command line's reference page, docs/command-line.md, made from the one source of the
command line's documentation: the argparse parser of :mod:`gpmegen.cli` with the descriptions,
examples and files written of :mod:`gpmegen.help_pages`.

``python -m gpmegen.cli_docs > docs/command-line.md`` (``make docs``) writes it; a test fails when
the committed page differs from what this prints. The page holds each command's ``--help`` as
the command prints it, at a fixed width, so it reads the same on every machine.
"""

from __future__ import annotations

import argparse
import os
import sys
from contextlib import contextmanager

from .cli import build_parser

WIDTH = 100  # columns of the help text on the page

INTRO = """\
# Command line reference

This page is generated from the command line itself (`python -m gpmegen.cli_docs >
docs/command-line.md`, or `make docs`): each section is what `gpmegen COMMAND --help` prints. Do
not edit it by hand; change `gpmegen/cli/parser.py` (options) or `gpmegen/help_pages.py` (descriptions,
examples, files written) and make it again. What the commands have in common (where models and
results go, errors, interruptions, limits) is in [runs.md](runs.md).
"""


@contextmanager
def _columns(width: int):
    """argparse wraps help text to the terminal's width, which it reads from ``COLUMNS``."""
    previous = os.environ.get("COLUMNS")
    os.environ["COLUMNS"] = str(width)
    try:
        yield
    finally:
        if previous is None:
            os.environ.pop("COLUMNS", None)
        else:
            os.environ["COLUMNS"] = previous


def _commands(parser: argparse.ArgumentParser) -> dict[str, argparse.ArgumentParser]:
    return next(a.choices for a in parser._actions if isinstance(a, argparse._SubParsersAction))


def _summaries(parser: argparse.ArgumentParser) -> dict[str, str]:
    action = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    return {choice.dest: choice.help for choice in action._choices_actions}


def page() -> str:
    """The reference page as Markdown."""
    with _columns(WIDTH):
        parser = build_parser()
        commands = _commands(parser)
        summaries = _summaries(parser)
        parts = [INTRO, "## Commands\n"]
        parts += [f"- [`gpmegen {name}`](#gpmegen-{name}): {summaries[name]}" for name in commands]
        parts += ["", "## gpmegen\n", "```text", parser.format_help().rstrip(), "```", ""]
        for name, sub in commands.items():
            parts += [f"## gpmegen {name}\n", "```text", sub.format_help().rstrip(), "```", ""]
    return "\n".join(parts)


def main() -> int:
    sys.stdout.write(page())
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
