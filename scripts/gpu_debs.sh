#!/usr/bin/env bash
# Here (a Debian 12 machine with the package mirrors): downloads the .deb files of
# the C++ libraries fskin builds against into .gpu-debs/ (git-ignored, ~8 MB),
# for scripts/gpu_check.sh on a lent GPU machine, whose image has nvcc, CMake,
# ninja and PyTorch but none of Debian's C++ libraries. Carry `.gpu-debs` with
# the device run.
set -euo pipefail
cd "$(dirname "$0")/.."
mkdir -p .gpu-debs
cd .gpu-debs
for p in libfmt-dev libfmt9 nlohmann-json3-dev libeigen3-dev libcli11-dev libzip-dev libzip4 \
         libstb-dev libstb0 libtinygltf-dev libassimp-dev libassimp5 libdraco-dev libdraco7 \
         libminizip-dev libminizip1 libpugixml1v5 libpolyclipping22 libgtest-dev libgmock-dev \
         libbenchmark-dev libbenchmark1debian zlib1g-dev libtinyobjloader-dev pkgconf pkgconf-bin libpkgconf3; do
  apt-get download "$p" > /dev/null
done
ls -1 | wc -l | xargs echo "gpu_debs: .deb files in .gpu-debs:"
