#!/usr/bin/env bash
# "Your own character" end to end on a rig fskin knows nothing about: a
# humanoid with other proportions and Mixamo-style joint names, written as a
# rigged glTF file with an animation clip (as a DCC tool would), then
# imported, posed from its clip's joint ranges, built into a dataset and
# trained with fskin's defaults (no --set). About 5 minutes on 2 cores.
set -euo pipefail
FSKIN=${1:-build/fskin}
OUT=${2:-own-character-output}
STEPS=${FSKIN_DEMO_STEPS:-1000}
mkdir -p "$OUT"
start=$(date +%s)
stage() { echo; echo "== $1 ($(( $(date +%s) - start )) s)"; }

stage "a rigged glTF character with a clip"
"$FSKIN" character --out "$OUT/base.npz" --seed 5 --height 1.3 --girth 1.2 --leg-length 0.85 \
  --arm-length 1.15 --head-size 1.2 --shoulder-width 1.1
"$FSKIN" poses train --model "$OUT/base.npz" --out "$OUT/base_clip.npz" --sequences 8 --frames 25 --seed 3
printf '%s\n' Hips LeftUpLeg RightUpLeg Spine LeftLeg RightLeg Spine1 LeftFoot RightFoot Spine2 \
  LeftToeBase RightToeBase Neck LeftShoulder RightShoulder Head LeftArm RightArm LeftForeArm \
  RightForeArm LeftHand RightHand LeftHandIndex1 RightHandIndex1 | sed 's/^/mixamorig:/' > "$OUT/names.txt"
"$FSKIN" export --model "$OUT/base.npz" --clip "$OUT/base_clip.npz" --joint-names "$OUT/names.txt" \
  --out "$OUT/rig.glb"

stage "import, poses from the clip's ranges, dataset"
"$FSKIN" import "$OUT/rig.glb" --out "$OUT/model.npz" --clips "$OUT/clips.npz"
"$FSKIN" poses train --model "$OUT/model.npz" --ranges-from "$OUT/clips.npz" --out "$OUT/train_poses.npz" \
  --sequences 8 --frames 25
"$FSKIN" poses ood --model "$OUT/model.npz" --ranges-from "$OUT/clips.npz" --out "$OUT/ood_poses.npz" --count 20
"$FSKIN" data build --model "$OUT/model.npz" --poses "$OUT/train_poses.npz" --ood-poses "$OUT/ood_poses.npz" \
  --out "$OUT/data" --points 50000 --quiet

stage "training Fast-SNARF with the defaults ($STEPS steps)"
rm -rf "$OUT/run"
"$FSKIN" train --data "$OUT/data" --method fast-snarf --steps "$STEPS" --out "$OUT/run" --quiet

stage "evaluation"
"$FSKIN" eval "$OUT/run" --split test-within --quiet
"$FSKIN" eval "$OUT/run" --split test-ood --quiet
"$FSKIN" report "$OUT/run" --out "$OUT/report.md"
"$FSKIN" export "$OUT/run" --clip "$OUT/ood_poses.npz" --resolution 128 --out "$OUT/avatar.glb"
echo "own character: finished in $(( $(date +%s) - start )) s; outputs are in $OUT/"
