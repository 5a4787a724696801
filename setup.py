"""Builds the compiled simulator step during ``pip install``; the metadata is in pyproject.toml.

The step (``aquafish_gym/native/_aquafish_step.so``) is a PyBullet plugin loaded with ctypes,
not a Python extension module: it is compiled by ``aquafish_gym/native/build.py`` (the same
function as ``python -m aquafish_gym.native.build``) with the system C++ compiler and the
project's own PyBullet ABI header, with no network. ``pip install -e .`` builds it in place.

It is optional: without a compiler, or if the compile fails, the install still succeeds and
the simulator runs its NumPy path (``aquafish doctor`` says why and how to get the compiled
one). ``AQUAFISH_REQUIRE_NATIVE=1`` in the environment makes such a failure fail the install.
"""

import importlib.util
import os
from pathlib import Path

from setuptools import Extension, setup
from setuptools.command.build_ext import build_ext

NATIVE = Path(__file__).resolve().parent / "aquafish_gym" / "native"


def _native_build():
    """aquafish_gym/native/build.py, loaded by path: importing the package needs its dependencies."""
    spec = importlib.util.spec_from_file_location("_aquafish_native_build", NATIVE / "build.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


class BuildPlugin(build_ext):
    """Compile the plugin with build.py's flags (no fused multiply-add), named ``_aquafish_step.so``."""

    def get_ext_filename(self, fullname):
        # not a Python module (no ABI tag): the loader looks for exactly this name
        return os.path.join(*fullname.split(".")) + ".so"

    def build_extension(self, ext):
        native = _native_build()
        output = Path(self.get_ext_fullpath(ext.name))
        try:
            native.compile_library(output)
        except native.BuildError as err:
            # no library of an earlier build may stand in for this one (in the wheel, or in place)
            output.unlink(missing_ok=True)
            if self.editable_mode:
                (NATIVE / output.name).unlink(missing_ok=True)
            if os.environ.get("AQUAFISH_REQUIRE_NATIVE") == "1":
                raise SystemExit(f"aquafish: the compiled simulator step was not built: {err}") from None
            print(f"aquafish: WARNING: the compiled simulator step was not built, the simulator will run its "
                  f"NumPy path: {str(err).splitlines()[0]}")


setup(
    ext_modules=[Extension("aquafish_gym.native._aquafish_step", sources=["aquafish_gym/native/aquafish_step.cpp"],
                           depends=["aquafish_gym/native/pybullet_abi.h", "aquafish_gym/native/build.py"],
                           optional=True)],
    cmdclass={"build_ext": BuildPlugin},
)
