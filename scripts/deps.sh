#!/usr/bin/env bash
# Installs the Debian packages mountcal needs (SPEC §1) when they are missing.
# As root it runs apt-get non-interactively; otherwise it prints the exact command and fails.
# Usage: source scripts/deps.sh && mountcal_ensure_deps [extra packages...]
set -euo pipefail

MOUNTCAL_DEPS=(build-essential cmake pkg-config libeigen3-dev libceres-dev libflann-dev liblz4-dev
  libopenmesh-dev libproj-dev proj-data nlohmann-json3-dev libcli11-dev
  libgtest-dev libgmock-dev libbenchmark-dev zlib1g-dev ninja-build libgdal-dev
  pybind11-dev python3-dev python3-numpy python3-pytest python3-matplotlib)

# The CMake generator arguments for a build directory: none when it is configured already (it
# keeps its generator), else Ninja — it compiles a target's sources while the libraries it links
# are still being built, where Make waits for them, so two cores stay busy.
mountcal_generator() {  # BUILD_DIR
  if [ ! -f "$1/CMakeCache.txt" ] && command -v ninja >/dev/null; then
    echo "-GNinja"
  fi
}

mountcal_ensure_deps() {
  local missing=() p
  for p in "${MOUNTCAL_DEPS[@]}" "$@"; do
    if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
      missing+=("$p")
    fi
  done
  if [ ${#missing[@]} -eq 0 ]; then
    return 0
  fi
  local cmd="apt-get install -y --no-install-recommends ${missing[*]}"
  if [ "$(id -u)" -ne 0 ]; then
    echo "mountcal: missing Debian packages. Run as root:" >&2
    echo "  apt-get update && DEBIAN_FRONTEND=noninteractive $cmd" >&2
    return 1
  fi
  echo "mountcal: installing ${missing[*]}" >&2
  export DEBIAN_FRONTEND=noninteractive
  apt-get update -qq
  # shellcheck disable=SC2086
  apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
}
