"""The package list, the one part of the build that pyproject.toml cannot say: every package
under gpmegen/, found rather than listed (so that a new subpackage is never left out of the
wheel), and the top-level templates/ installed as the package gpmegen.templates (its folder is
the package-dir entry in pyproject.toml). setuptools' find, in pyproject.toml or here, only names
packages after their folders, so gpmegen.templates is the one name given by hand."""

from setuptools import find_packages, setup

setup(packages=[*find_packages(include=["gpmegen", "gpmegen.*"]), "gpmegen.templates"])
