"""Free text of a model (its description, parameter units, the rebuild command with the model
file's path) written so that it can stand in a C block comment and a Python docstring whatever
it holds.

The text is rewritten into an alphabet that can neither end a C comment nor a triple-quoted
Python string, nor change how the code around it is read:

- kept as they are: printable ASCII from space to ``~`` except backslash and double quote, and
  the line break ``\\n`` where the place holds several lines;
- ``*``, ``/`` and ``?`` are kept only between two kept characters that are none of these three,
  so that no ``*/`` or ``/*`` (C comments) and no ``??`` (C trigraphs such as ``??/``, a
  backslash) can form, neither inside the text nor with what stands next to it in the template;
- every other character (backslash, double quote, the other control characters and line
  separators such as ``\\r``, ``\\v``, ``\\f``, U+0085, U+2028, NUL, and all non-ASCII) and every
  ``*``, ``/``, ``?`` not kept is written ``<U+XXXX>``, its code point.

Without backslashes no line can be spliced (C) and nothing can be escaped (Python); without
double quotes a docstring cannot end; the output is ASCII, so the files are too.
"""

from __future__ import annotations

PLAIN = frozenset(chr(c) for c in range(0x20, 0x7F)) - {"\\", '"'}
# Each of these is harmless alone, dangerous next to another of them or to a character the
# template puts beside the text ("*/", "/*", "??/").
PAIRED = frozenset("*/?")


def visible(char: str) -> str:
    """A character written by its code point, ``<U+XXXX>``."""
    return f"<U+{ord(char):04X}>"


def comment_text(text, multiline: bool = False) -> str:
    """``text`` in the safe alphabet of this module (see its docstring); ``multiline``: keep
    ``\\n`` as line breaks (else it is written ``<U+000A>`` too)."""
    text = str(text)
    plain = PLAIN | {"\n"} if multiline else PLAIN

    def kept(k: int) -> bool:
        char = text[k]
        if char not in plain:
            return False
        if char not in PAIRED:
            return True
        return 0 < k < len(text) - 1 and all(
            text[j] in plain and text[j] not in PAIRED for j in (k - 1, k + 1)
        )

    return "".join(text[k] if kept(k) else visible(text[k]) for k in range(len(text)))
