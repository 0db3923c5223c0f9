"""Compile taskspace's native kernels against the installed Pinocchio.

Run ``python -m taskspace._native.build`` (``make native``; ``make demo`` and ``make test`` do).

The kernels are optional: without them taskspace runs its Python implementation. They are
built with the C++ compiler of the machine against the headers and libraries that the
``pin``, ``eigenpy`` and ``cmeel-eigen`` wheels install under ``cmeel.prefix``; the
Pinocchio version is recorded in the module, and the kernel is only used when it matches the
Pinocchio imported at run time.
"""

from __future__ import annotations

import argparse
import os
import shutil
import subprocess
import sys
import sysconfig
import time
from dataclasses import dataclass
from pathlib import Path

HERE = Path(__file__).resolve().parent


@dataclass(frozen=True)
class Kernel:
    """One kernel: its source and what it needs beyond Pinocchio's default library.

    Attributes:
        source: the C++ file.
        libs: extra libraries (``-l`` names) linked after ``pinocchio_default``.
        defines: extra compile definitions (those of the Pinocchio/coal CMake targets used).
    """

    source: Path
    libs: tuple[str, ...] = ()
    defines: tuple[str, ...] = ()


# Compile definitions of the pinocchio_collision and coal CMake targets (they fix the layout
# of GeometryModel/GeometryData and of coal's classes).
COLLISION_DEFINES = (
    "PINOCCHIO_WITH_COLLISION",
    "PINOCCHIO_WITH_HPP_FCL",
    "COAL_BACKWARD_COMPATIBILITY_WITH_HPP_FCL",
    "COAL_HAS_OCTOMAP",
    "COAL_HAVE_OCTOMAP",
    "OCTOMAP_MAJOR_VERSION=1",
    "OCTOMAP_MINOR_VERSION=10",
    "OCTOMAP_PATCH_VERSION=0",
)
SOURCES = {
    "_ik_kernel": Kernel(HERE / "ik_kernel.cpp"),
    "_planning_kernel": Kernel(
        HERE / "planning_kernel.cpp",
        libs=("pinocchio_collision", "coal"),
        defines=COLLISION_DEFINES,
    ),
}
# Compile definitions exported by Pinocchio's CMake targets (they fix the joint variant).
DEFINES = (
    "BOOST_MPL_LIMIT_LIST_SIZE=30",
    "BOOST_MPL_LIMIT_VECTOR_SIZE=30",
    "BOOST_MPL_CFG_NO_PREPROCESSED_HEADERS",
    "BOOST_FUSION_INVOKE_MAX_ARITY=12",
    "PINOCCHIO_ENABLE_TEMPLATE_INSTANTIATION",
    "NDEBUG",
)

# Vector instructions of the building machine (the kernels are built where they run). The
# alignment of fixed-size Eigen types stays at the 16 bytes of the Pinocchio wheels, so that
# Model and Data keep the layout of the library they come from. Eigen's heap allocator must
# match the wheels' too: with AVX the ideal alignment (32 or 64 bytes) exceeds 16, and Eigen
# would then allocate with its own offset-storing aligned malloc, so that freeing in a kernel
# what Pinocchio's library allocated (a pinocchio::Data, the vector of pinocchio::neutral)
# crashes; glibc's malloc already gives the 16 bytes that dynamic-size objects assume here.
ARCH_FLAGS = (
    "-march=native",
    "-DEIGEN_MAX_ALIGN_BYTES=16",
    "-DEIGEN_MAX_STATIC_ALIGN_BYTES=16",
    "-DEIGEN_MALLOC_ALREADY_ALIGNED=1",
)


class BuildError(RuntimeError):
    """The kernels could not be compiled (the message says what is missing)."""


def prefix() -> Path:
    """``cmeel.prefix`` of the environment (where the pin wheel put its headers)."""
    import cmeel  # type: ignore[import-untyped]

    for base in (
        Path(cmeel.__file__).resolve().parent.parent,
        Path(sysconfig.get_paths()["purelib"]),
    ):
        candidate = base / "cmeel.prefix"
        if (candidate / "include" / "pinocchio").is_dir():
            return candidate
    raise BuildError("no cmeel.prefix with Pinocchio headers (is the 'pin' wheel installed?)")


def command(name: str, kernel: Kernel, output: Path) -> list[str]:
    """The compiler command line of one kernel."""
    import numpy as np

    p = prefix()
    eigen = p / "include" / "eigen3"
    if not (eigen / "Eigen").is_dir():
        raise BuildError(f"Eigen headers not found in {eigen} (pip install 'cmeel-eigen>=3.4.1')")
    cxx = os.environ.get("CXX") or shutil.which("g++") or shutil.which("c++")
    if cxx is None:
        raise BuildError("no C++ compiler (install g++)")
    py_lib = f"boost_python{sys.version_info.major}{sys.version_info.minor}"
    return [
        cxx,
        "-std=c++17",
        "-O3",
        *ARCH_FLAGS,
        "-fPIC",
        "-shared",
        "-fvisibility=hidden",
        "-w",
        *[f"-D{d}" for d in (*DEFINES, *kernel.defines)],
        f"-I{p / 'include'}",
        f"-I{eigen}",
        f"-I{sysconfig.get_paths()['include']}",
        f"-I{np.get_include()}",
        str(kernel.source),
        "-o",
        str(output),
        f"-L{p / 'lib'}",
        f"-Wl,-rpath,{p / 'lib'}",
        "-lpinocchio_default",
        *[f"-l{lib}" for lib in kernel.libs],
        "-leigenpy",
        f"-l{py_lib}",
    ]


def build(force: bool = False, verbose: bool = True, only: list[str] | None = None) -> list[Path]:
    """Compile every kernel whose library is missing or older than its source or this file.

    Args:
        force: rebuild even if up to date.
        verbose: print the build time of each kernel.
        only: names of the kernels to consider (default: all of :data:`SOURCES`).
    """
    suffix = sysconfig.get_config_var("EXT_SUFFIX")
    built = []
    for name, kernel in SOURCES.items():
        if only is not None and name not in only:
            continue
        source = kernel.source
        output = HERE / f"{name}{suffix}"
        newest = max(source.stat().st_mtime, Path(__file__).stat().st_mtime)  # flags live here
        if not force and output.exists() and output.stat().st_mtime >= newest:
            continue
        cmd = command(name, kernel, output)
        t0 = time.perf_counter()
        proc = subprocess.run(cmd, capture_output=True, text=True, check=False)
        if proc.returncode != 0:
            raise BuildError(f"compiling {source.name} failed:\n{proc.stderr[-4000:]}")
        if verbose:
            print(f"built {output.name} in {time.perf_counter() - t0:.0f} s")
        built.append(output)
    return built


def main(argv: list[str] | None = None) -> int:
    """Command-line entry point."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--force", action="store_true", help="rebuild even if up to date")
    parser.add_argument(
        "--only", action="append", choices=sorted(SOURCES), help="build only this kernel"
    )
    args = parser.parse_args(argv)
    try:
        build(force=args.force, only=args.only)
    except BuildError as exc:
        print(f"taskspace native kernels not built: {exc}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
