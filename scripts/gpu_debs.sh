#!/usr/bin/env bash
# Here (a Debian 12 machine with the package mirrors): downloads the .deb files of
# the C++ libraries fskin builds against into .gpu-debs/ (git-ignored, ~8 MB),
# for scripts/gpu_check.sh on a lent GPU machine, whose image has nvcc, CMake,
# ninja and PyTorch but none of Debian's C++ libraries. Carry `.gpu-debs` with
# the device run. With a built fskin CLI as argument it also builds a small dataset
# of the built-in character into .gpu-debs/data (~10 MB; building one needs Embree,
# which the GPU image lacks), so the GPU check can time training on the device.
#
#   bash scripts/gpu_debs.sh [build/fskin]
set -euo pipefail
cd "$(dirname "$0")/.."
mkdir -p .gpu-debs
cd .gpu-debs
for p in libfmt-dev libfmt9 nlohmann-json3-dev libeigen3-dev libcli11-dev libzip-dev libzip4 \
         libstb-dev libstb0 libtinygltf-dev libassimp-dev libassimp5 libdraco-dev libdraco7 \
         libminizip-dev libminizip1 libpugixml1v5 libpolyclipping22 libgtest-dev libgmock-dev \
         libbenchmark-dev libbenchmark1debian zlib1g-dev libtinyobjloader-dev libnanoflann-dev pkgconf pkgconf-bin \
         libpkgconf3; do
  apt-get download "$p" > /dev/null
done
ls -1 | wc -l | xargs echo "gpu_debs: .deb files in .gpu-debs:"
if [ -n "${1:-}" ]; then
  FSKIN=$(readlink -f "$1")
  mkdir -p data
  "$FSKIN" character --out data/character.npz --seed 0 > /dev/null
  "$FSKIN" poses train --model data/character.npz --out data/train_poses.npz --sequences 4 --frames 25 > /dev/null
  "$FSKIN" poses ood --model data/character.npz --out data/ood_poses.npz --count 10 > /dev/null
  rm -rf data/set
  "$FSKIN" data build --model data/character.npz --poses data/train_poses.npz --ood-poses data/ood_poses.npz \
    --out data/set --points 20000 --quiet > /dev/null
  du -sh data | xargs echo "gpu_debs: dataset"
fi
