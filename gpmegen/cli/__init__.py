"""Command line: ``gpmegen build | export | statics | simulate | invert | sweep | plot | animate | modes |
linearize | metrics | convergence | demo``.

Usage and model errors exit with status 2, runtime failures with 1, an interruption (Ctrl-C,
SIGTERM) with 130; each prints one line naming the problem and the fix, never a traceback.

The parser is in :mod:`.parser`, the argparse types in :mod:`.types`, the commands in
:mod:`.build`, :mod:`.runs`, :mod:`.studies` and :mod:`.figures`, what they share in
:mod:`.common`, and :func:`main` with its error handling in :mod:`.console`.
"""

# Each command imports what it runs inside its own function: the console starts on every command
# (and for --help), and the package's stages (SymPy, the code generator, Matplotlib) are loaded
# only by the commands that use them. The modules here import at their top only what the parser
# and the error handling need.
from .console import main, quick_exit
from .parser import build_parser
from .types import method_name

__all__ = ["build_parser", "main", "method_name", "quick_exit"]
