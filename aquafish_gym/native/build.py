"""Build the compiled step (``aquafish_step.cpp``) into a PyBullet plugin next to this file.

``python -m aquafish_gym.native.build`` (``make`` runs it): fetches the public C headers
of the installed PyBullet version from its source distribution on the package index
(``pip download pybullet==X --no-binary :all:``, about 80 MB, once; only the headers of
``examples/SharedMemory`` are kept, under ``aquafish_gym/native/include/pybullet-X``) and
compiles the plugin with the system C++ compiler (``$CXX``, default ``c++``). The library
calls no PyBullet symbol directly (it looks the C API up in the loaded module), so it
needs no PyBullet library to link against.

Exits with a message naming what is missing (compiler, network, headers) if it cannot.
The flags forbid fused multiply-adds, so the C++ arithmetic rounds exactly as NumPy's.
"""

from __future__ import annotations

import argparse
import importlib.metadata
import os
import shutil
import subprocess
import sys
import tarfile
import tempfile
from pathlib import Path

HERE = Path(__file__).resolve().parent
SOURCE = HERE / "aquafish_step.cpp"
LIBRARY = HERE / "_aquafish_step.so"
#: Compiler flags: no fused multiply-add, so that the C++ arithmetic rounds exactly as NumPy's.
CFLAGS = ("-O2", "-fPIC", "-shared", "-fvisibility=hidden", "-ffp-contract=off", "-std=c++11", "-Wall", "-Werror")


class BuildError(RuntimeError):
    """The plugin could not be built; the message says why and what to install."""


def headers_dir(version: str) -> Path:
    """Directory of PyBullet ``version``'s ``examples/SharedMemory`` headers, fetched if missing.

    Raises:
        BuildError: if the source distribution cannot be downloaded or lacks the headers.
    """
    target = HERE / "include" / f"pybullet-{version}"
    if (target / "PhysicsClientC_API.h").exists():
        return target
    with tempfile.TemporaryDirectory() as tmp:
        cmd = [sys.executable, "-m", "pip", "download", f"pybullet=={version}", "--no-binary", ":all:", "--no-deps",
               "--no-build-isolation", "-q", "-d", tmp]
        done = subprocess.run(cmd, capture_output=True, text=True)
        archives = list(Path(tmp).glob("pybullet-*.tar.gz"))
        if done.returncode != 0 or not archives:
            raise BuildError(f"could not download the PyBullet {version} source distribution for its C headers "
                             f"({' '.join(cmd)}): {done.stderr.strip()[-500:]}")
        staging = Path(tmp) / "headers"
        with tarfile.open(archives[0]) as archive:
            for member in archive.getmembers():
                parts = Path(member.name).parts
                if member.isfile() and member.name.endswith(".h") and parts[1:3] == ("examples", "SharedMemory") \
                        and len(parts) <= 5:
                    member.name = str(Path(*parts[3:]))
                    archive.extract(member, staging, filter="data")
        if not (staging / "PhysicsClientC_API.h").exists() or not (staging / "plugins" / "b3PluginContext.h").exists():
            raise BuildError(f"the PyBullet {version} source distribution has no examples/SharedMemory headers")
        target.parent.mkdir(parents=True, exist_ok=True)
        partial = target.with_name(target.name + ".partial")
        shutil.rmtree(partial, ignore_errors=True)
        shutil.copytree(staging, partial)
        os.replace(partial, target)
    return target


def build(force: bool = False) -> Path:
    """Compile the plugin (skipped when it is newer than its source, unless ``force``).

    Returns:
        The library's path.

    Raises:
        BuildError: no C compiler, no headers, or a compile error (its output included).
    """
    if not force and LIBRARY.exists() and LIBRARY.stat().st_mtime >= SOURCE.stat().st_mtime:
        return LIBRARY
    compiler = os.environ.get("CXX", "c++")
    if shutil.which(compiler) is None:
        raise BuildError(f"no C++ compiler {compiler!r} on PATH: install g++ or clang++ (e.g. apt install g++), "
                         "or set CXX; without it the simulator runs its NumPy path")
    include = headers_dir(importlib.metadata.version("pybullet"))
    partial = LIBRARY.with_name(LIBRARY.name + ".partial")
    cmd = [compiler, *CFLAGS, f"-I{include}", str(SOURCE), "-o", str(partial), "-ldl"]
    done = subprocess.run(cmd, capture_output=True, text=True)
    if done.returncode != 0:
        partial.unlink(missing_ok=True)
        raise BuildError(f"compiling {SOURCE.name} failed ({' '.join(cmd)}):\n{done.stderr}")
    os.replace(partial, LIBRARY)
    return LIBRARY


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
