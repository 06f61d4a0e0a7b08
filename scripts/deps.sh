# Shared by the scripts in scripts/ (sourced, not run): make sure the Debian packages a
# command needs are installed. As root it installs what is missing; otherwise it prints the exact
# `sudo apt-get install ...` line and exits non-zero, so nothing half-works.

# tacmap_require_packages PACKAGE...
tacmap_require_packages() {
  local missing=()
  local pkg
  for pkg in "$@"; do
    if ! dpkg-query -W -f='${Status}' "$pkg" 2>/dev/null | grep -q "install ok installed"; then
      missing+=("$pkg")
    fi
  done
  [ "${#missing[@]}" -eq 0 ] && return 0
  if [ "$(id -u)" -ne 0 ]; then
    echo "tacmap: missing Debian packages: ${missing[*]}" >&2
    echo "Install them, then run this command again:" >&2
    echo "  sudo apt-get update && sudo apt-get install -y ${missing[*]}" >&2
    exit 1
  fi
  echo "tacmap: installing ${missing[*]}" >&2
  export DEBIAN_FRONTEND=noninteractive
  apt-get update -qq >&2
  apt-get install -y -qq --no-install-recommends "${missing[@]}" >&2
}

# Everything the library, its tests, examples and benchmarks build with.
TACMAP_BUILD_PACKAGES=(cmake make ninja-build g++ libeigen3-dev libxsimd-dev doctest-dev libbenchmark-dev libstb-dev libcli11-dev pybind11-dev python3-dev python3-numpy python3-matplotlib doxygen pkgconf libvlfeat-dev libtbb-dev python3-pip python3-setuptools python3-wheel python3-venv python3-build)

# The one build folder of scripts/demo, scripts/python_demo (through `pip install .`, setup.py)
# and scripts/install: Release, the library with tacmap::precompiled (built once, for all three),
# the examples, the tools where CLI11 and stb are found, the Python module when asked. Each
# script builds only the targets it needs. TACMAP_BUILD_DIR chooses another folder.
TACMAP_DEFAULT_BUILD_DIR="${TACMAP_BUILD_DIR:-build/default}"

# tacmap_configure_default_build [CMAKE_OPTION...]: configures TACMAP_DEFAULT_BUILD_DIR (quietly;
# the log is printed when the configure fails). Run from the source folder.
tacmap_configure_default_build() {
  local dir="${TACMAP_DEFAULT_BUILD_DIR}"
  local generator=()
  mkdir -p "${dir}"
  if [ ! -f "${dir}/CMakeCache.txt" ] && command -v ninja > /dev/null; then
    generator=(-G Ninja)
  fi
  cmake -S . -B "${dir}" "${generator[@]}" -DCMAKE_BUILD_TYPE=Release -DTACMAP_BUILD_TESTS=OFF \
        -DTACMAP_BUILD_EXAMPLES=ON -DTACMAP_BUILD_BENCH=OFF "$@" > "${dir}/configure.log" 2>&1 \
    || { cat "${dir}/configure.log" >&2; exit 1; }
}
