#!/usr/bin/env bash
# The avatar job on the built-in data (`make demo-avatar`): the textured
# built-in character rendered in posed frames by 4 cameras on a ring (an image
# dataset in PeopleSnapshot's layout), a canonical radiance field trained
# through the Fast-SNARF deformer on the CPU, PSNR / SSIM on held-out views
# and on held-out poses seen from held-out views (one JSON per split), and a
# picture of the learned avatar beside the ground truth in unseen poses from
# unseen views; then the same with an avatar of articulated 3-D Gaussians
# (docs/gaussian_avatars.md), exported as Gaussians and as the character's
# mesh with their colours baked in, and the three side by side.
# FSKIN_AVATAR_STEPS and FSKIN_AVATAR_SIZE shorten it.
set -euo pipefail
FSKIN=${1:-build/fskin}
OUT=${2:-demo-avatar-output}
STEPS=${FSKIN_AVATAR_STEPS:-3000}
SIZE=${FSKIN_AVATAR_SIZE:-256}
mkdir -p "$OUT"
start=$(date +%s)
stage() { echo; echo "== $1 ($(( $(date +%s) - start )) s)"; }

stage "character, poses, image dataset (${SIZE}x${SIZE})"
"$FSKIN" character --out "$OUT/character.npz" --seed 0
"$FSKIN" poses train --model "$OUT/character.npz" --out "$OUT/train_poses.npz" --sequences 4 --frames 10
# Held-out poses: new motions of the training distribution (another seed).
"$FSKIN" poses train --model "$OUT/character.npz" --out "$OUT/held_out_poses.npz" --sequences 2 --frames 4 --seed 7
"$FSKIN" data images --model "$OUT/character.npz" --poses "$OUT/train_poses.npz" \
  --held-out-poses "$OUT/held_out_poses.npz" --out "$OUT/images" --size "$SIZE" --views 4 --held-out-views 4 \
  --novel-view-frames 8 --quiet

stage "training the avatar ($STEPS steps)"
rm -rf "$OUT/run"
"$FSKIN" avatar train --data "$OUT/images" --out "$OUT/run" --steps "$STEPS"

stage "evaluation"
"$FSKIN" avatar eval "$OUT/run" --split novel_view --json "$OUT/eval_novel_view.json" --quiet
"$FSKIN" avatar eval "$OUT/run" --split novel_pose --json "$OUT/eval_novel_pose.json" --quiet

stage "pictures and mesh"
# Ground truth (left) and the learned avatar (right), unseen poses from unseen views.
"$FSKIN" avatar render "$OUT/run" --split novel_pose --index 0,3,6 --compare --out "$OUT/novel_poses_vs_truth.png"
"$FSKIN" avatar mesh "$OUT/run" --resolution 128 --out "$OUT/avatar_canonical.ply"

stage "the same dataset as articulated 3-D Gaussians ($STEPS steps)"
rm -rf "$OUT/gaussians"
gaussians_start=$(date +%s)
"$FSKIN" avatar train --data "$OUT/images" --out "$OUT/gaussians" --representation gaussians --steps "$STEPS"
gaussians_seconds=$(( $(date +%s) - gaussians_start ))
"$FSKIN" avatar eval "$OUT/gaussians" --split novel_view --json "$OUT/gaussians_eval_novel_view.json" --quiet
"$FSKIN" avatar eval "$OUT/gaussians" --split novel_pose --json "$OUT/gaussians_eval_novel_pose.json" --quiet
"$FSKIN" avatar render "$OUT/gaussians" --split novel_pose --index 0,3,6 --compare \
  --out "$OUT/gaussians_novel_poses_vs_truth.png"
# For engines: the Gaussians as a skinned glTF (KHR_gaussian_splatting) playing the held-out poses, and,
# for engines that draw no Gaussians, the character's mesh with the Gaussians' colours baked into it.
"$FSKIN" avatar export "$OUT/gaussians" --split novel_pose --out "$OUT/gaussian_avatar.glb"
"$FSKIN" avatar export "$OUT/gaussians" --mesh --split novel_pose --out "$OUT/gaussian_avatar_mesh.glb"
"$FSKIN" avatar eval "$OUT/gaussians" --mesh --split novel_view --json "$OUT/mesh_eval_novel_view.json" --quiet
"$FSKIN" avatar eval "$OUT/gaussians" --mesh --split novel_pose --json "$OUT/mesh_eval_novel_pose.json" --quiet
echo
echo "== volume avatar vs Gaussian avatar (PSNR over the whole image / the subject's box, dB)"
/usr/bin/python3 - "$OUT" "$gaussians_seconds" <<'PY'
import json, sys
out = sys.argv[1]
for name, prefix in (("volume", "eval"), ("gaussians", "gaussians_eval"), ("gaussians as a mesh", "mesh_eval")):
    row = [name]
    for split in ("novel_view", "novel_pose"):
        scores = json.load(open(f"{out}/{prefix}_{split}.json"))
        row.append(f"{split} {scores['mean_psnr']:.2f} / {scores['mean_psnr_subject_box']:.2f}")
        if split == "novel_pose":
            row.append(f"render {scores['median_render_seconds']:.2f} s")
    print("  ".join(row))
print(f"gaussians trained in {sys.argv[2]} s")
PY
echo "demo-avatar: finished in $(( $(date +%s) - start )) s; outputs are in $OUT/"
