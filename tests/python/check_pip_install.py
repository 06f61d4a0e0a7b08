"""`pip install .` (setup.py) and the package's interpreter check, run by CTest (tests/python).

    python3 check_pip_install.py CASE SOURCE_DIR PACKAGE_DIR WORK_DIR

CASE is one of
  venv           pip installs the built package (PACKAGE_DIR/tacmap, through TACMAP_PYTHON_PREBUILT)
                 into a venv made with --system-site-packages; the venv's python imports it from
                 its own site-packages, localizes one touch, and pip uninstalls it again
  no-numpy       the package under an interpreter without numpy (a venv without the system's
                 packages, like a pyenv python3): ImportError naming the interpreter it was built for
  other-python   the package as built for another Python (its compiled file and recorded extension
                 suffix renamed to Python 3.99's): ImportError naming both interpreters
  missing        the package without its compiled part: ImportError saying it is missing
  no-compiler, no-eigen, no-pybind11
                 pip install with no C++ compiler (CXX names none), with Eigen or pybind11 hidden
                 from CMake: pip fails with tacmap's one message naming the Debian packages
Run with the interpreter the package was built for; exits non-zero with the reason on failure.
"""

import os
import shutil
import subprocess
import sys
import sysconfig
import venv
from pathlib import Path


def run(command, env=None, expect_ok=True):
    result = subprocess.run(command, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                            env=env, check=False)
    if expect_ok and result.returncode != 0:
        sys.exit(f"FAILED ({result.returncode}): {' '.join(map(str, command))}\n{result.stdout}")
    return result


def expect_in(text, needles, what):
    missing = [n for n in needles if n not in text]
    if missing:
        sys.exit(f"{what}: expected {missing} in the output:\n{text}")


def make_venv(path, system_site_packages):
    shutil.rmtree(path, ignore_errors=True)
    venv.EnvBuilder(system_site_packages=system_site_packages, with_pip=True).create(path)
    return Path(path) / "bin" / "python"


def pip_env(work, **extra):
    env = dict(os.environ)
    env.pop("PYTHONPATH", None)  # the venv must find tacmap in its own site-packages
    env.update({"PIP_NO_INDEX": "1", "PIP_DISABLE_PIP_VERSION_CHECK": "1",
                "TACMAP_BUILD_DIR": str(Path(work) / "cmake-build")})
    env.update(extra)
    return env


def case_venv(source, package_dir, work):
    python = make_venv(Path(work) / "venv", system_site_packages=True)
    env = pip_env(work, TACMAP_PYTHON_PREBUILT=package_dir)
    run([python, "-m", "pip", "install", source], env=env)
    site = run([python, "-c", "import sysconfig; print(sysconfig.get_path('platlib'))"],
               env=env).stdout.strip()
    check = run([python, "-c", """
import numpy as np, tacmap
print(tacmap.__file__)
print(tacmap.__version__, tacmap.Localizer.__module__)
p = tacmap.load_protocol(%r)
x, y = p.locations[0]
sim = tacmap.Simulator(p.relief_mm(), p.mm_per_px)
r = tacmap.Localizer(p.map, p.mm_per_px).touch(sim.render(x, y))
print('verdict', r.verdict, np.isfinite(r.position_mm).all())
""" % str(Path(source) / "data" / "gecko" / "protocol.txt")], env=env).stdout
    lines = check.splitlines()
    if not lines[0].startswith(site + os.sep + "tacmap" + os.sep):
        sys.exit(f"tacmap was imported from {lines[0]}, not from the venv's {site}")
    if not lines[1].endswith(" tacmap"):
        sys.exit(f"the classes should say they are tacmap's: {lines[1]}")
    expect_in(check, ["verdict ", " True"], "one touch in the venv")
    run([python, "-m", "pip", "uninstall", "-y", "tacmap"], env=env)
    gone = run([python, "-c", "import tacmap"], env=env, expect_ok=False)
    if gone.returncode == 0:
        sys.exit("tacmap still imports after pip uninstall")


def case_no_numpy(source, package_dir, work):
    python = make_venv(Path(work) / "venv-bare", system_site_packages=False)
    env = pip_env(work, PYTHONPATH=package_dir)
    result = run([python, "-c", "import tacmap"], env=env, expect_ok=False)
    if result.returncode == 0:
        sys.exit("import tacmap succeeded under an interpreter without numpy")
    expect_in(result.stdout, ["numpy is not importable", "python3-numpy",
                              f"It was built for {sys.executable}",
                              f"this interpreter is {python}"], "no numpy")


def case_other_python(source, package_dir, work):
    copy = Path(work) / "other" / "tacmap"
    shutil.rmtree(copy.parent, ignore_errors=True)
    shutil.copytree(Path(package_dir) / "tacmap", copy)
    # The same files as a build for "Python 3.99" would have: its suffix recorded and on the file.
    other = ".cpython-399-x86_64-linux-gnu.so"
    suffix = sysconfig.get_config_var("EXT_SUFFIX")
    (copy / f"_tacmap{suffix}").rename(copy / f"_tacmap{other}")
    info = (copy / "_build_info.py").read_text()
    (copy / "_build_info.py").write_text(info.replace(f'"ext_suffix": "{suffix}"',
                                                      f'"ext_suffix": "{other}"'))
    env = pip_env(work, PYTHONPATH=str(copy.parent))
    result = run([sys.executable, "-c", "import tacmap"], env=env, expect_ok=False)
    if result.returncode == 0:
        sys.exit("import tacmap succeeded with a module built for another Python")
    expect_in(result.stdout, ["another Python version or ABI", "It was built for ",
                              f"this interpreter is {sys.executable}", "-m pip install ."],
              "another Python")


def case_missing(source, package_dir, work):
    copy = Path(work) / "missing" / "tacmap"
    shutil.rmtree(copy.parent, ignore_errors=True)
    shutil.copytree(Path(package_dir) / "tacmap", copy)
    for compiled in copy.glob("_tacmap.*"):
        compiled.unlink()
    env = pip_env(work, PYTHONPATH=str(copy.parent))
    result = run([sys.executable, "-c", "import tacmap"], env=env, expect_ok=False)
    if result.returncode == 0:
        sys.exit("import tacmap succeeded without its compiled module")
    expect_in(result.stdout, ["is missing: the package's compiled part was not built",
                              "-m pip install ."], "missing")


def bad_build(source, work, what, needles, **env_extra):
    python = make_venv(Path(work) / "venv", system_site_packages=True)
    shutil.rmtree(Path(work) / "cmake-build", ignore_errors=True)
    result = run([python, "-m", "pip", "install", source], env=pip_env(work, **env_extra),
                 expect_ok=False)
    if result.returncode == 0:
        sys.exit(f"pip install succeeded {what}")
    expect_in(result.stdout, ["tacmap: cannot build the Python module for",
                              "sudo apt-get install g++ cmake"] + needles, what)


def main():
    case, source, package_dir, work = sys.argv[1:5]
    Path(work).mkdir(parents=True, exist_ok=True)
    if case == "venv":
        case_venv(source, package_dir, work)
    elif case == "no-numpy":
        case_no_numpy(source, package_dir, work)
    elif case == "other-python":
        case_other_python(source, package_dir, work)
    elif case == "missing":
        case_missing(source, package_dir, work)
    elif case == "no-compiler":
        bad_build(source, work, "without a compiler", ["no C++ compiler was found"],
                  CXX="/nonexistent/c++")
    elif case == "no-eigen":
        bad_build(source, work, "without Eigen", ["libeigen3-dev"],
                  TACMAP_CMAKE_ARGS="-DCMAKE_DISABLE_FIND_PACKAGE_Eigen3=ON")
    elif case == "no-pybind11":
        bad_build(source, work, "without pybind11", ["pybind11-dev"],
                  TACMAP_CMAKE_ARGS="-DCMAKE_DISABLE_FIND_PACKAGE_pybind11=ON")
    else:
        sys.exit(f"unknown case {case!r}")
    print(f"{case}: passed")


if __name__ == "__main__":
    main()
