"""The former place of :mod:`gpmegen.analysis.post.closures`, kept because the Python API's page named
it."""

from .post.closures import *  # noqa: F403
