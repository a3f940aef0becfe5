#!/usr/bin/env bash
# Installs every Debian package fskin needs. Idempotent: does nothing when all
# are present, so `make test` / `make demo` can call it every time.
set -euo pipefail

PACKAGES=(
  build-essential cmake ninja-build ccache pkg-config python3
  libtorch-dev
  # Without the optimised BLAS LibTorch falls back to the reference BLAS and
  # MLPs run ~25x slower.
  libopenblas0-pthread
  libeigen3-dev libfmt-dev nlohmann-json3-dev libcli11-dev
  libzip-dev zlib1g-dev
  libembree-dev
  libstb-dev libtinygltf-dev libtinyobjloader-dev
  # k-d tree for nearest-vertex queries (geometry/nearest_vertex.h).
  libnanoflann-dev
  # FBX / Collada import; the test models are BSD-licensed rigs the tests read.
  libassimp-dev assimp-testmodels
  # torch.distributed's Gloo backend (data-parallel training across processes).
  libgloo-dev
  libgtest-dev libgmock-dev libbenchmark-dev
  # The Python module (python/): Debian's torch 1.13 is libtorch-dev's LibTorch.
  python3-dev python3-torch python3-numpy python3-pytest pybind11-dev
  # Type-checks a user's script against the module's stubs (python/tests/test_stubs.py).
  mypy
)

missing=()
for p in "${PACKAGES[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done
# The tests check our glTF files with the Khronos glTF-Validator and three.js
# (tools/gltf-check, from the npm registry). Any node >= 18 with npm will do,
# Debian's or another vendor's (whose nodejs package conflicts with Debian's npm).
if ! command -v node >/dev/null || ! command -v npm >/dev/null; then
  missing+=(nodejs npm)
fi
if [ ${#missing[@]} -gt 0 ]; then
  echo "setup: installing ${missing[*]}"
  SUDO=""
  if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi
  export DEBIAN_FRONTEND=noninteractive
  $SUDO apt-get update -q
  $SUDO apt-get install -y -q --no-install-recommends "${missing[@]}"
fi

# The glTF checkers, at the versions pinned in package-lock.json.
GLTF_CHECK="$(dirname "$0")/../tools/gltf-check"
if [ ! -f "$GLTF_CHECK/node_modules/.package-lock.json" ] ||
   [ "$GLTF_CHECK/package-lock.json" -nt "$GLTF_CHECK/node_modules/.package-lock.json" ]; then
  echo "setup: installing the glTF checkers (npm ci in tools/gltf-check)"
  npm ci --prefix "$GLTF_CHECK" --no-audit --no-fund --loglevel=error
fi
