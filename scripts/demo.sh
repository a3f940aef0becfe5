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
"$FSKIN" render --model "$OUT/character.npz" --color-by-bone --view all --width 256 --height 384 --out "$OUT/character_bones.png"
"$FSKIN" render --mesh "$OUT/posed_0000.ply" --mesh "$OUT/posed_0003.ply" --mesh "$OUT/posed_clothed_0003.ply" --view all --width 256 --height 384 --out "$OUT/posed.png"
"$FSKIN" animate --model "$OUT/character.npz" --pose "$OUT/demo_poses.npz" --color-by-bone --fps 2 --out "$OUT/character_poses.glb"
echo "demo: outputs are in $OUT/"
