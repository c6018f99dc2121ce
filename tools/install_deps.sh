#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# Installs the exact Debian 12 packages that vfit's build, tests and benchmarks need; with
# `style` also clang-format and clang-tidy, which CI's tools/check_style.sh runs, and, where
# npm is on the PATH, the Khronos glTF validator (the npm package gltf-validator, into
# build/npm/), which the tests of the written .glb files run when it is there.
# Idempotent: does nothing (and prints nothing) when every package is already present.
# Works as root or through sudo.
set -euo pipefail

packages=(
  build-essential cmake ninja-build pkg-config git
  libembree-dev libtbb-dev libeigen3-dev
  ocl-icd-opencl-dev opencl-c-headers opencl-clhpp-headers pocl-opencl-icd clinfo
  libopenmesh-dev libceres-dev
  libbenchmark-dev libgtest-dev libgmock-dev
  libpng-dev zlib1g-dev nlohmann-json3-dev
  pybind11-dev python3-dev python3-numpy python3-pytest
)
if [ "${1:-}" = style ]; then
  packages+=(clang-format clang-tidy)
fi

# The glTF validator, pinned; a failure (no network) only warns: its tests then skip.
install_validator() {
  [ "${1:-}" = style ] || return 0
  local here
  here=$(cd "$(dirname "$0")/.." && pwd)
  [ -d "$here/build/npm/node_modules/gltf-validator" ] && return 0
  if ! command -v npm >/dev/null 2>&1; then
    echo "install_deps: no npm on the PATH: the glTF validation tests will skip" >&2
    return 0
  fi
  mkdir -p "$here/build/npm"
  npm install --silent --no-audit --no-fund --prefix "$here/build/npm" gltf-validator@2.0.0-dev.3.10 >/dev/null 2>&1 ||
    echo "install_deps: could not install the npm package gltf-validator; the glTF validation tests will skip" >&2
}

missing=()
for p in "${packages[@]}"; do
  status=$(dpkg-query -W -f='${db:Status-Status}' "$p" 2>/dev/null || true)
  [ "$status" = "installed" ] || missing+=("$p")
done
if [ ${#missing[@]} -eq 0 ]; then
  install_validator "${1:-}"
  exit 0
fi

if [ "$(id -u)" -eq 0 ]; then
  sudo=()
elif command -v sudo >/dev/null 2>&1; then
  sudo=(sudo)
else
  echo "install_deps: need root or sudo to install: ${missing[*]}" >&2
  exit 1
fi

echo "install_deps: installing ${missing[*]}" >&2
export DEBIAN_FRONTEND=noninteractive
"${sudo[@]}" apt-get update -qq
"${sudo[@]}" apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
install_validator "${1:-}"
