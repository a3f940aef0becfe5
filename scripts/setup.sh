#!/usr/bin/env bash
# Installs every Debian package fskin needs. Idempotent: does nothing when all
# are present, so `make test` / `make demo` can call it every time.
set -euo pipefail

PACKAGES=(
  build-essential cmake ninja-build ccache pkg-config
  libtorch-dev
  # Without the optimised BLAS LibTorch falls back to the reference BLAS and
  # MLPs run ~25x slower.
  libopenblas0-pthread
  libeigen3-dev libfmt-dev nlohmann-json3-dev libcli11-dev
  libzip-dev zlib1g-dev
  libembree-dev
  libstb-dev libtinygltf-dev libtinyobjloader-dev
  libgtest-dev libgmock-dev libbenchmark-dev
)

missing=()
for p in "${PACKAGES[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done
if [ ${#missing[@]} -eq 0 ]; then
  exit 0
fi
echo "setup: installing ${missing[*]}"
SUDO=""
if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -q
$SUDO apt-get install -y -q --no-install-recommends "${missing[@]}"
