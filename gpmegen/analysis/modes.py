"""The former place of :mod:`gpmegen.analysis.post.modes`, kept because the Python API's page named
it."""

from .post.modes import *  # noqa: F403
