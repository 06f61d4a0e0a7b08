"""`pip install .`: builds tacmap's Python package with CMake for the interpreter that runs pip
and installs it into that interpreter's environment (a venv, or --user).

Offline, with Debian's packages only (no scikit-build, nothing from PyPI):

    sudo apt-get install g++ cmake ninja-build libeigen3-dev libxsimd-dev pybind11-dev \\
        python3-dev python3-numpy python3-pip python3-setuptools python3-wheel python3-venv
    python3 -m venv --system-site-packages ~/tacmap-env   # numpy (and matplotlib) from Debian
    ~/tacmap-env/bin/python -m pip install .

There is deliberately no pyproject.toml: with one, pip builds in an isolated environment and
downloads setuptools from PyPI first, which fails offline. Without it, Debian's pip (23.0) finds
the system's setuptools and wheel and builds right here. A newer pip that insists on isolation
works offline with `pip install --no-build-isolation .`; `python3 -m build --no-isolation
--wheel` (Debian: python3-build) makes a wheel the same way.

The build: CMake configures build/default (the folder scripts/demo, scripts/python_demo and
scripts/install share; TACMAP_BUILD_DIR chooses another) with TACMAP_BUILD_PYTHON=ON and this
interpreter as Python3_EXECUTABLE, builds the target tacmap_python (which links
tacmap::precompiled) and copies the package <build>/python/tacmap into the wheel. Environment:
  TACMAP_BUILD_DIR      the CMake build folder (default: build/default in the source folder)
  TACMAP_CMAKE_ARGS     more arguments for the configure (e.g. -DCMAKE_CXX_COMPILER=clang++)
  TACMAP_JOBS           parallel compile jobs (default: the number of CPUs)
  TACMAP_PYTHON_PREBUILT  a folder holding an already-built package `tacmap/` for this
                        interpreter: installed as is, without CMake (tests/python uses it)
A missing compiler, CMake, Eigen, xsimd, pybind11, numpy or Python headers stops the build with
one message naming the Debian packages to install.
"""

import os
import re
import shlex
import shutil
import subprocess
import sys
import sysconfig
from pathlib import Path

from setuptools import Extension, setup
from setuptools.command.build_ext import build_ext

ROOT = Path(__file__).resolve().parent
# Everything the module's build needs, by Debian package (scripts/deps.sh installs them all).
DEBIAN_PACKAGES = ("g++ cmake ninja-build libeigen3-dev libxsimd-dev pybind11-dev python3-dev "
                   "python3-numpy")


def tacmap_version():
    text = (ROOT / "include" / "tacmap" / "config.hpp").read_text()
    parts = [re.search(rf"^#define TACMAP_VERSION_{part} (\d+)$", text, re.MULTILINE)
             for part in ("MAJOR", "MINOR", "PATCH")]
    return ".".join(part.group(1) for part in parts)


def fail(what, details=""):
    """Stops the build with one message: what is wrong, and the Debian packages that fix it."""
    lines = ["", "=" * 78, f"tacmap: cannot build the Python module for {sys.executable}: {what}"]
    if details:
        lines += ["", details.rstrip()]
    lines += ["", "On Debian or Ubuntu, install what the build needs, then run pip again:",
              f"  sudo apt-get install {DEBIAN_PACKAGES}", "=" * 78, ""]
    sys.stderr.write("\n".join(lines))
    sys.stderr.flush()
    raise SystemExit(1)


def cmake_error_text(output):
    """The CMake errors of a failed configure (tacmap's name the missing Debian package)."""
    errors = re.findall(r"^CMake Error.*?(?=^-- |^CMake (?:Error|Warning)|^Call Stack|\Z)", output,
                        re.MULTILINE | re.DOTALL)
    return "\n".join(error.strip() for error in errors) or output[-3000:]


def find_compiler():
    names = [os.environ["CXX"]] if os.environ.get("CXX") else ["c++", "g++", "clang++"]
    for name in names:
        path = shutil.which(shlex.split(name)[0]) if name.strip() else None
        if path:
            return path
    return None


class CMakeExtension(Extension):
    def __init__(self):
        super().__init__("tacmap._tacmap", sources=[])


class cmake_build_ext(build_ext):
    """Builds the extension with CMake and copies the package tacmap/ into build_lib."""

    def run(self):
        prebuilt = os.environ.get("TACMAP_PYTHON_PREBUILT")
        package = Path(prebuilt) / "tacmap" if prebuilt else self.cmake_build()
        suffix = sysconfig.get_config_var("EXT_SUFFIX")
        if not (package / f"_tacmap{suffix}").exists():
            fail(f"{package} holds no _tacmap{suffix}, the compiled module for this interpreter",
                 "Found: " + ", ".join(sorted(p.name for p in package.glob("*"))))
        destination = Path(self.get_ext_fullpath("tacmap._tacmap")).parent
        destination.mkdir(parents=True, exist_ok=True)
        for name in ("__init__.py", "_build_info.py", f"_tacmap{suffix}"):
            shutil.copy2(package / name, destination / name)

    def cmake_build(self):
        cmake = shutil.which("cmake")
        if not cmake:
            fail("CMake (3.22 or later) was not found on PATH.")
        if not find_compiler():
            fail("no C++ compiler was found (CXX, c++, g++ or clang++ on PATH); tacmap needs a "
                 "C++20 compiler, e.g. GCC 12.")
        build_dir = Path(os.environ.get("TACMAP_BUILD_DIR") or ROOT / "build" / "default")
        if not build_dir.is_absolute():
            build_dir = ROOT / build_dir
        configure = [cmake, "-S", str(ROOT), "-B", str(build_dir), "-DCMAKE_BUILD_TYPE=Release",
                     "-DTACMAP_BUILD_PYTHON=ON", f"-DPython3_EXECUTABLE={sys.executable}"]
        if not (build_dir / "CMakeCache.txt").exists():
            # A new folder: configured as scripts/deps.sh's tacmap_configure_default_build does,
            # so that scripts/demo and scripts/install reuse it (only tacmap_python is built here).
            configure += ["-DTACMAP_BUILD_TESTS=OFF", "-DTACMAP_BUILD_EXAMPLES=ON",
                          "-DTACMAP_BUILD_BENCH=OFF"]
            if shutil.which("ninja"):
                configure += ["-G", "Ninja"]
        configure += shlex.split(os.environ.get("TACMAP_CMAKE_ARGS", ""))
        print(f"tacmap: configuring {build_dir} for {sys.executable}", flush=True)
        result = subprocess.run(configure, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                                text=True, check=False)
        if result.returncode != 0:
            fail("the CMake configure failed; it said:", cmake_error_text(result.stdout))
        jobs = os.environ.get("TACMAP_JOBS") or str(os.cpu_count() or 2)
        print(f"tacmap: building the module (target tacmap_python, {jobs} jobs; a few minutes "
              "the first time)", flush=True)
        build = subprocess.run([cmake, "--build", str(build_dir), "--target", "tacmap_python",
                                "-j", jobs], check=False)
        if build.returncode != 0:
            fail("the build failed (the compiler's messages are above).")
        return build_dir / "python" / "tacmap"


# setuptools' own scratch folders in the build folder, not in the source folder's top level (and
# one per build folder, so that two builds at once do not share them).
SCRATCH = Path(os.environ.get("TACMAP_BUILD_DIR") or ROOT / "build" / "default") / "setuptools"
if not SCRATCH.is_absolute():
    SCRATCH = ROOT / SCRATCH
SCRATCH.mkdir(parents=True, exist_ok=True)

setup(
    name="tacmap",
    version=tacmap_version(),
    description="Localize a tactile sensor's contact on a visual map with a recursive Bayes "
                "filter",
    license="See LICENSE",
    python_requires=">=3.9",
    install_requires=[],  # numpy: from the system (Debian python3-numpy), never from PyPI
    ext_modules=[CMakeExtension()],
    cmdclass={"build_ext": cmake_build_ext},
    options={"build": {"build_base": str(SCRATCH)}, "egg_info": {"egg_base": str(SCRATCH)}},
    zip_safe=False,
)
