"""Build the compiled step (``aquafish_step.cpp``) into a PyBullet plugin next to this file.

``pip install .`` / ``pip install -e .`` / ``pip wheel .`` compile it through ``setup.py``,
which calls :func:`compile_library` from this file; ``python -m aquafish_gym.native.build``
rebuilds it in place (a developer's shortcut after editing the C++). Both use the system C++
compiler (``$CXX``, else ``c++``, ``g++`` or ``clang++``) and the project's own declarations
of PyBullet's C ABI (``pybullet_abi.h``): nothing is downloaded, and no PyBullet is needed
to build. The library calls no PyBullet symbol directly (it looks the C API up in the loaded
pybullet module), so it links against nothing but ``libdl``.

The flags forbid fused multiply-adds, so the C++ arithmetic rounds exactly as NumPy's.
This module imports only the standard library: ``setup.py`` loads it by path, before any
dependency is installed.
"""

from __future__ import annotations

import argparse
import os
import shlex
import shutil
import subprocess
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
SOURCE = HERE / "aquafish_step.cpp"
HEADER = HERE / "pybullet_abi.h"
LIBRARY = HERE / "_aquafish_step.so"
#: Compiler flags: no fused multiply-add, so that the C++ arithmetic rounds exactly as NumPy's.
CFLAGS = ("-O2", "-fPIC", "-shared", "-fvisibility=hidden", "-ffp-contract=off", "-std=c++11", "-Wall")
#: Tried in this order when ``$CXX`` is not set.
COMPILERS = ("c++", "g++", "clang++")


class BuildError(RuntimeError):
    """The plugin could not be built; the message says why and what to install."""


def find_compiler() -> list[str] | None:
    """The C++ compiler command (``$CXX`` if set, else the first of :data:`COMPILERS` on PATH), or None."""
    cxx = os.environ.get("CXX", "").strip()
    if cxx:
        cmd = shlex.split(cxx)
        return cmd if shutil.which(cmd[0]) else None
    for name in COMPILERS:
        if shutil.which(name):
            return [name]
    return None


def compile_library(output: Path | str = LIBRARY) -> Path:
    """Compile ``aquafish_step.cpp`` into ``output`` (written whole or not at all).

    Raises:
        BuildError: no C++ compiler, or a compile error (its output included).
    """
    output = Path(output)
    compiler = find_compiler()
    if compiler is None:
        wanted = os.environ.get("CXX") or " / ".join(COMPILERS)
        raise BuildError(f"no C++ compiler ({wanted}) on PATH: install one (e.g. `apt install g++`) or set CXX")
    output.parent.mkdir(parents=True, exist_ok=True)
    partial = output.with_name(output.name + ".partial")
    cmd = [*compiler, *CFLAGS, f"-I{HERE}", str(SOURCE), "-o", str(partial), "-ldl"]
    done = subprocess.run(cmd, capture_output=True, text=True)
    if done.returncode != 0:
        partial.unlink(missing_ok=True)
        raise BuildError(f"compiling {SOURCE.name} failed ({' '.join(cmd)}):\n{done.stderr}")
    os.replace(partial, output)
    return output


def build(force: bool = False) -> Path:
    """Compile the plugin in place (skipped when it is newer than its sources, unless ``force``).

    Returns:
        The library's path.

    Raises:
        BuildError: as :func:`compile_library`.
    """
    if not force and LIBRARY.exists() and LIBRARY.stat().st_mtime >= max(SOURCE.stat().st_mtime,
                                                                         HEADER.stat().st_mtime):
        return LIBRARY
    return compile_library(LIBRARY)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--force", action="store_true", help="rebuild even if the library is up to date")
    args = parser.parse_args(argv)
    try:
        path = build(force=args.force)
    except BuildError as err:
        print(f"aquafish_gym.native.build: {err}", file=sys.stderr)
        return 1
    print(f"built {path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
