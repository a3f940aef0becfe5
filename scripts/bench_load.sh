#!/usr/bin/env bash
# Training throughput on a shared machine: fskin train alone, two fskin
# trainings side by side, and one next to busy non-fskin processes (one
# busy loop per core, as a parallel compiler would be). Prints steps/s (steps
# over their summed time in log.jsonl, the first 20 steps left out: a mean, as
# the slow steps of a loaded run are the point) and each case's ratio to solo.
#
# Usage: scripts/bench_load.sh [FSKIN] [DATASET] [STEPS]
#   FSKIN    the fskin binary (default build/fskin)
#   DATASET  a dataset directory (default demo-output/data, from `make demo`)
#   STEPS    training steps per run (default 150)
# Extra environment for every fskin run can be given in FSKIN_ENV, e.g.
# FSKIN_ENV="GOMP_SPINCOUNT=300000" to compare settings.
set -euo pipefail
FSKIN=${1:-build/fskin}
DATA=${2:-demo-output/data}
STEPS=${3:-150}
[ -x "$FSKIN" ] || { echo "bench_load: $FSKIN is not an executable (build first)" >&2; exit 2; }
[ -f "$DATA/manifest.json" ] || { echo "bench_load: $DATA is not a dataset (run make demo, or give one)" >&2; exit 2; }
WORK=$(mktemp -d /tmp/fskin-load.XXXXXX)
trap 'kill $(jobs -p) 2>/dev/null || true; rm -rf "$WORK"' EXIT

train() {  # train RUN_NAME: one training run, quiet
  env ${FSKIN_ENV:-} "$FSKIN" train --data "$DATA" --steps "$STEPS" --out "$WORK/$1" --quiet >/dev/null
}
steps_per_s() {  # steps_per_s RUN_NAME
  /usr/bin/python3 - "$WORK/$1/log.jsonl" <<'PY'
import json, sys
s = [json.loads(l)["seconds"] for l in open(sys.argv[1])][20:]
print(f"{len(s) / sum(s):.3f}")
PY
}

train solo
solo=$(steps_per_s solo)

train duo_a & a=$!
train duo_b & b=$!
wait $a $b
duo_a=$(steps_per_s duo_a)
duo_b=$(steps_per_s duo_b)

hogs=()
for _ in $(seq "$(nproc)"); do
  # A bounded busy loop (stops by itself after 15 minutes at the latest).
  timeout 900 bash -c 'while :; do :; done' & hogs+=($!)
done
train busy
kill "${hogs[@]}" 2>/dev/null || true
wait "${hogs[@]}" 2>/dev/null || true
busy=$(steps_per_s busy)

ratio() { /usr/bin/python3 -c "print(f'{$1 / $2:.2f}')"; }
echo "machine: $(nproc) cores, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | xargs); ${FSKIN_ENV:-no extra environment}"
echo "| case | steps/s | vs solo |"
echo "|---|---:|---:|"
echo "| solo | $solo | 1.00 |"
echo "| two fskin trainings, first | $duo_a | $(ratio "$duo_a" "$solo") |"
echo "| two fskin trainings, second | $duo_b | $(ratio "$duo_b" "$solo") |"
echo "| next to $(nproc) busy loops | $busy | $(ratio "$busy" "$solo") |"
