#!/usr/bin/env bash
# The main job on the built-in data: make the built-in character and a posed
# dataset of it, train Fast-SNARF on the CPU, evaluate it within the training
# distribution and on out-of-distribution poses, mesh unseen poses, draw
# pictures and print the summary table. About 5 minutes on 2 cores.
# FSKIN_DEMO_KIND=quadruped runs the same job, with the same defaults, on the
# built-in 33-joint quadruped (`make demo-quadruped`).
set -euo pipefail
FSKIN=${1:-build/fskin}
OUT=${2:-demo-output}
STEPS=${FSKIN_DEMO_STEPS:-1000}
KIND=${FSKIN_DEMO_KIND:-humanoid}
mkdir -p "$OUT"
start=$(date +%s)
stage() { echo; echo "== $1 ($(( $(date +%s) - start )) s)"; }

stage "character, poses, dataset"
if [ "$KIND" = quadruped ]; then
  "$FSKIN" character --kind quadruped --out "$OUT/character.npz" --seed 0 --write-poses "$OUT/demo_poses.npz"
  WIDTH=384 HEIGHT=256
else
  "$FSKIN" character --out "$OUT/character.npz" --seed 0 --write-poses "$OUT/demo_poses.npz"
  "$FSKIN" character --out "$OUT/character_clothed.npz" --seed 0 --clothed
  WIDTH=256 HEIGHT=384
fi
"$FSKIN" render --model "$OUT/character.npz" --color-by-bone --view all --width $WIDTH --height $HEIGHT \
  --out "$OUT/character_bones.png"
"$FSKIN" poses train --model "$OUT/character.npz" --out "$OUT/train_poses.npz" --sequences 8 --frames 25
"$FSKIN" poses ood --model "$OUT/character.npz" --out "$OUT/ood_poses.npz" --count 20
"$FSKIN" poses ood --model "$OUT/character.npz" --out "$OUT/unseen_poses.npz" --count 3 --seed 7
"$FSKIN" data build --model "$OUT/character.npz" --poses "$OUT/train_poses.npz" \
  --ood-poses "$OUT/ood_poses.npz" --out "$OUT/data" --points 50000 --quiet

stage "training Fast-SNARF ($STEPS steps)"
# A fresh run each time (use `fskin train --resume` to continue one).
rm -rf "$OUT/run-fast-snarf"
"$FSKIN" train --data "$OUT/data" --method fast-snarf --steps "$STEPS" --out "$OUT/run-fast-snarf"

stage "evaluation"
"$FSKIN" eval "$OUT/run-fast-snarf" --split test-within --quiet
"$FSKIN" eval "$OUT/run-fast-snarf" --split test-ood --quiet

stage "meshes and pictures of unseen poses"
for k in 0 1 2; do
  "$FSKIN" mesh "$OUT/run-fast-snarf" --pose "$OUT/unseen_poses.npz" --index "$k" --resolution 128 \
    --largest-component --quiet --out "$OUT/unseen_$k.ply"
done
"$FSKIN" render --mesh "$OUT/unseen_0.ply" --mesh "$OUT/unseen_1.ply" --mesh "$OUT/unseen_2.ply" \
  --view all --width $WIDTH --height $HEIGHT --out "$OUT/unseen_poses.png"
# The canonical mesh once, coloured by the learned arg-max skinning bone, moved
# into the unseen poses by the learned skinning (one glTF with morph targets).
"$FSKIN" animate "$OUT/run-fast-snarf" --poses "$OUT/unseen_poses.npz" --repose --resolution 128 \
  --largest-component --fps 1 --quiet --out "$OUT/reposed"
"$FSKIN" render --mesh "$OUT/reposed/canonical.ply" --view all --width $WIDTH --height $HEIGHT \
  --out "$OUT/canonical_learned_bones.png"

stage "summary"
"$FSKIN" report "$OUT/run-fast-snarf" --out "$OUT/report.md" --json "$OUT/report.json"
echo "demo: finished in $(( $(date +%s) - start )) s; outputs are in $OUT/"
