# Shared by scripts/demo and scripts/test (sourced, not run): make sure the Debian packages a
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
TACMAP_BUILD_PACKAGES=(cmake make ninja-build g++ libeigen3-dev libxsimd-dev doctest-dev libbenchmark-dev libstb-dev libcli11-dev pybind11-dev python3-dev python3-numpy python3-matplotlib doxygen pkgconf libvlfeat-dev libtbb-dev)
