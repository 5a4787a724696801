"""The ``aquafish`` command line: one entry point dispatching to the project's packages."""

from importlib.metadata import PackageNotFoundError as _PackageNotFoundError
from importlib.metadata import version as _version

try:  # the installed distribution's version (pyproject.toml); the same in the four packages
    __version__: str = _version("aquafish")
except _PackageNotFoundError:  # run from a source tree that is not installed
    __version__ = "0+unknown"
