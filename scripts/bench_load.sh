#!/usr/bin/env bash
# Training throughput on a shared machine: fskin train alone, two fskin
# trainings side by side, one next to busy non-fskin processes (one busy loop
# per core) and one next to a parallel compiler (one loop of `c++ -O2`
# compiles per core, as `make -j$(nproc)` would be). Prints steps/s (steps
# over their summed time in log.jsonl, the first 20 steps left out: a mean, as
# the slow steps of a loaded run are the point) and each case's ratio to solo.
#
# Usage: scripts/bench_load.sh [FSKIN] [DATASET] [STEPS]
#   FSKIN    the fskin binary (default build/fskin)
#   DATASET  a dataset directory (default demo-output/data, from `make demo`)
#   STEPS    training steps per run (default 150)
# Extra environment for every fskin run can be given in FSKIN_ENV, e.g.
# FSKIN_ENV="GOMP_SPINCOUNT=300000", and global fskin options in FSKIN_ARGS,
# e.g. FSKIN_ARGS="--threads 2" (a fixed thread count), to compare settings.
set -euo pipefail
FSKIN=${1:-build/fskin}
DATA=${2:-demo-output/data}
STEPS=${3:-150}
[ -x "$FSKIN" ] || { echo "bench_load: $FSKIN is not an executable (build first)" >&2; exit 2; }
[ -f "$DATA/manifest.json" ] || { echo "bench_load: $DATA is not a dataset (run make demo, or give one)" >&2; exit 2; }
WORK=$(mktemp -d /tmp/fskin-load.XXXXXX)
trap 'kill $(jobs -p) 2>/dev/null || true; rm -rf "$WORK"' EXIT

train() {  # train RUN_NAME: one training run, quiet
  env ${FSKIN_ENV:-} "$FSKIN" ${FSKIN_ARGS:-} train --data "$DATA" --steps "$STEPS" --out "$WORK/$1" --quiet >/dev/null
}
train_next_to() {  # train_next_to RUN_NAME LOOP: train while one copy of LOOP runs per core
  local others=() i
  for i in $(seq "$(nproc)"); do
    i=$i timeout 900 bash -c "$2" & others+=($!)
  done
  train "$1"
  kill "${others[@]}" 2>/dev/null || true
  wait "${others[@]}" 2>/dev/null || true
}
steps_per_s() {  # steps_per_s RUN_NAME
  /usr/bin/python3 - "$WORK/$1/log.jsonl" <<'PY'
import json, sys
rows = [json.loads(l) for l in open(sys.argv[1])][20:]
s = [r["seconds"] for r in rows]
threads = [r.get("threads", 0) for r in rows]
print(f"{len(s) / sum(s):.3f} (threads {sum(threads) / len(threads):.2f})")
PY
}

train solo
solo=$(steps_per_s solo)

train duo_a & a=$!
train duo_b & b=$!
wait $a $b
duo_a=$(steps_per_s duo_a)
duo_b=$(steps_per_s duo_b)

# A bounded busy loop per core (each stops by itself after 15 minutes at the latest).
train_next_to busy 'while :; do :; done'
busy=$(steps_per_s busy)

# A C++ translation unit that keeps an optimising compiler busy for seconds.
cat > "$WORK/unit.cpp" <<'CPP'
#include <algorithm>
#include <map>
#include <regex>
#include <string>
#include <vector>
std::vector<std::string> words(const std::string& s) {
  std::regex word("[a-z]+");
  std::vector<std::string> out;
  for (auto it = std::sregex_iterator(s.begin(), s.end(), word); it != std::sregex_iterator(); ++it) out.push_back(it->str());
  std::map<std::string, int> count;
  for (const auto& w : out) ++count[w];
  std::sort(out.begin(), out.end(), [&](const auto& a, const auto& b) { return count[a] > count[b]; });
  return out;
}
CPP
# One compile loop per core, bounded like the busy loops; each writes its own object.
train_next_to compiled "while :; do c++ -O2 -c '$WORK/unit.cpp' -o \"$WORK/unit_\$i.o\"; done"
compiled=$(steps_per_s compiled)

ratio() { /usr/bin/python3 -c "print(f'{${1%% *} / ${2%% *}:.2f}')"; }
echo "machine: $(nproc) cores, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | xargs); ${FSKIN_ENV:-no extra environment}; ${FSKIN_ARGS:-no global options}"
echo "| case | steps/s | vs solo |"
echo "|---|---:|---:|"
echo "| solo | $solo | 1.00 |"
echo "| two fskin trainings, first | $duo_a | $(ratio "$duo_a" "$solo") |"
echo "| two fskin trainings, second | $duo_b | $(ratio "$duo_b" "$solo") |"
echo "| next to $(nproc) busy loops | $busy | $(ratio "$busy" "$solo") |"
echo "| next to $(nproc) compiler loops (c++ -O2) | $compiled | $(ratio "$compiled" "$solo") |"
