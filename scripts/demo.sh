#!/usr/bin/env bash
# The main job on the built-in data (grows as the pipeline does): generate the
# built-in character, pose it into a few poses and write meshes.
set -euo pipefail
FSKIN=${1:-build/fskin}
OUT=${2:-demo-output}
mkdir -p "$OUT"
"$FSKIN" character --out "$OUT/character.npz" --seed 0 --write-poses "$OUT/demo_poses.npz"
"$FSKIN" character --out "$OUT/character_clothed.npz" --seed 0 --clothed
"$FSKIN" pose --model "$OUT/character.npz" --pose "$OUT/demo_poses.npz" --out "$OUT/posed.ply"
"$FSKIN" pose --model "$OUT/character_clothed.npz" --pose "$OUT/demo_poses.npz" --out "$OUT/posed_clothed.ply"
echo "demo: outputs are in $OUT/"
