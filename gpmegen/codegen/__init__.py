"""Code generation: common subexpressions, printers and Jinja rendering into ``generated/``."""

from .render import BuildResult, build, input_hash, render

__all__ = ["BuildResult", "build", "input_hash", "render"]
