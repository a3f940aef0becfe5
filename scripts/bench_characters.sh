#!/usr/bin/env bash
# Accuracy of the default training on fskin's characters, over seeds: builds
# each character's dataset once (cached in $OUT), trains `fskin train` with the
# defaults plus any extra arguments, evaluates within distribution and out of
# distribution, and prints each run and the mean and spread per character.
#
#   scripts/bench_characters.sh [--kinds "lowpoly-animal lowpoly-humanoid"] [--seeds "0 1 2"]
#                               [--tag NAME] [--data NAME "fskin data build arguments"]
#                               [-- extra fskin train arguments]
# Environment: FSKIN (default build/fskin), OUT (default bench-characters),
# THREADS (default 2: training is deterministic for a seed and a fixed thread
# count, and its result depends on the count, so the runs fix it).
#
# Characters and their splits (docs/benchmarks.md, "Real-asset-like characters"):
#   lowpoly-animal    train on its idle + walk clips, OOD = its run clip
#   lowpoly-humanoid  train on idle + walk + wave, OOD = run
#   humanoid          the demo's 8 x 25 training poses and 20 OOD poses
#   quadruped         the same generators for the built-in quadruped
# Data: 50,000 points per frame (the demo's); --data builds a variant beside the
# default dataset, in $OUT/<kind>/data-NAME. Results go to
# $OUT/results.jsonl, one line per run.
set -euo pipefail
FSKIN=${FSKIN:-build/fskin}
OUT=${OUT:-bench-characters}
KINDS="lowpoly-animal lowpoly-humanoid"
SEEDS="0 1 2"
TAG=default
DATA=data
DATA_ARGS=()
THREADS=${THREADS:-2}
while [ $# -gt 0 ]; do
  case "$1" in
    --kinds) KINDS=$2; shift 2 ;;
    --seeds) SEEDS=$2; shift 2 ;;
    --tag) TAG=$2; shift 2 ;;
    --data) DATA=data-$2; read -r -a DATA_ARGS <<< "$3"; shift 3 ;;
    --) shift; break ;;
    *) echo "bench_characters: unknown argument $1" >&2; exit 2 ;;
  esac
done
EXTRA=("$@")
mkdir -p "$OUT"

dataset() {  # kind -> $OUT/<kind>/$DATA (data build resumes and skips the frames it has)
  local kind=$1 dir="$OUT/$1"
  mkdir -p "$dir"
  if [ ! -f "$dir/ood_poses.npz" ]; then
    case "$kind" in
      lowpoly-humanoid|lowpoly-animal)
        "$FSKIN" character --kind "$kind" --out "$dir/model.npz" --clips "$dir/clips.npz" > /dev/null
        local train=idle,walk
        [ "$kind" = lowpoly-humanoid ] && train=idle,walk,wave
        "$FSKIN" poses select "$dir/clips.npz" --train "$train" --out-train "$dir/train_poses.npz" \
          --test run --out-test "$dir/ood_poses.npz" > /dev/null ;;
      humanoid|quadruped)
        "$FSKIN" character --kind "$kind" --out "$dir/model.npz" --seed 0 > /dev/null
        "$FSKIN" poses train --model "$dir/model.npz" --out "$dir/train_poses.npz" --sequences 8 --frames 25 > /dev/null
        "$FSKIN" poses ood --model "$dir/model.npz" --out "$dir/ood_poses.npz" --count 20 > /dev/null ;;
      *) echo "bench_characters: unknown kind $kind" >&2; exit 2 ;;
    esac
  fi
  "$FSKIN" data build --model "$dir/model.npz" --poses "$dir/train_poses.npz" --ood-poses "$dir/ood_poses.npz" \
      --out "$dir/$DATA" --points 50000 --quiet ${DATA_ARGS[@]+"${DATA_ARGS[@]}"} > /dev/null
}

iou() {  # eval json, key
  /usr/bin/python3 -c "import json,sys; print(json.load(open(sys.argv[1]))[sys.argv[2]])" "$1" "$2"
}

for kind in $KINDS; do
  dataset "$kind"
  for seed in $SEEDS; do
    run="$OUT/$kind/run-$TAG-$seed"
    rm -rf "$run"
    start=$(date +%s.%N)
    "$FSKIN" --threads "$THREADS" train --data "$OUT/$kind/$DATA" --out "$run" --quiet --set seed="$seed" "${EXTRA[@]}" > "$run.log" 2>&1 ||
      { echo "bench_characters: training failed, see $run.log" >&2; exit 1; }
    seconds=$(/usr/bin/python3 -c "import sys; print(round(float(sys.argv[2]) - float(sys.argv[1]), 1))" "$start" "$(date +%s.%N)")
    "$FSKIN" eval "$run" --split test-within --quiet > /dev/null
    "$FSKIN" eval "$run" --split test-ood --quiet > /dev/null
    line=$(printf '{"tag": "%s", "data": "%s", "kind": "%s", "seed": %s, "threads": %s, "train_s": %s, "within_bbox": %s, "within_surf": %s, "ood_bbox": %s, "ood_surf": %s}' \
      "$TAG" "$DATA" "$kind" "$seed" "$THREADS" "$seconds" \
      "$(iou "$run/eval-test-within.json" mean_iou_bbox)" "$(iou "$run/eval-test-within.json" mean_iou_surf)" \
      "$(iou "$run/eval-test-ood.json" mean_iou_bbox)" "$(iou "$run/eval-test-ood.json" mean_iou_surf)")
    echo "$line" | tee -a "$OUT/results.jsonl"
  done
done

/usr/bin/python3 - "$OUT/results.jsonl" "$TAG" "$KINDS" <<'PY'
import json, statistics, sys
rows = [json.loads(l) for l in open(sys.argv[1]) if l.strip()]
print(f"\n{'tag':24} {'kind':18} {'n':>2} {'train s':>8} {'within bbox':>14} {'within surf':>14} {'OOD bbox':>14} {'OOD surf':>14}")
for kind in sys.argv[3].split():
    sel = [r for r in rows if r["tag"] == sys.argv[2] and r["kind"] == kind]
    if not sel: continue
    def cell(key):
        v = [r[key] for r in sel]
        sd = statistics.stdev(v) if len(v) > 1 else 0.0
        return f"{statistics.mean(v):.3f} ± {sd:.3f}"
    secs = statistics.median(r["train_s"] for r in sel)
    print(f"{sys.argv[2]:24} {kind:18} {len(sel):>2} {secs:8.0f} {cell('within_bbox'):>14} {cell('within_surf'):>14} {cell('ood_bbox'):>14} {cell('ood_surf'):>14}")
PY
