#!/usr/bin/env bash
# Starts N ranks of a command on this machine the way torchrun does: each gets
# RANK, WORLD_SIZE, LOCAL_RANK, MASTER_ADDR and MASTER_PORT (a free loopback
# port unless MASTER_PORT is set). Debian 12's torchrun (torch 1.13 under
# Python 3.11) stops before starting any rank, so fskin ships this instead.
# Ctrl-C / SIGTERM reach every rank; a failing rank stops the others; the
# exit status is the first failing rank's, or 0.
#
#   scripts/launch_ranks.sh 2 build/fskin --threads 1 train --data ds --out run
set -euo pipefail
if [ $# -lt 2 ] || ! [[ "$1" =~ ^[1-9][0-9]*$ ]]; then
  echo "usage: $0 RANKS COMMAND [ARGS...]" >&2
  exit 2
fi
ranks=$1
shift
port=${MASTER_PORT:-$(/usr/bin/python3 -c 'import socket; s = socket.socket(); s.bind(("127.0.0.1", 0)); print(s.getsockname()[1])')}
pids=()
interrupted=0
forward() {
  interrupted=1
  kill -s "$1" "${pids[@]}" 2>/dev/null || true
}
trap 'forward INT' INT
trap 'forward TERM' TERM
for ((rank = 0; rank < ranks; rank++)); do
  RANK=$rank WORLD_SIZE=$ranks LOCAL_RANK=$rank MASTER_ADDR=${MASTER_ADDR:-127.0.0.1} MASTER_PORT=$port "$@" &
  pids+=($!)
done
# A rank that fails takes the others down (two SIGTERMs: they may be waiting
# on it in a collective), rather than leaving them to time out.
status=0
remaining=$ranks
while ((remaining > 0)); do
  set +e
  wait -n
  code=$?
  set -e
  if ((code > 128 && interrupted)); then  # the wait itself was interrupted by Ctrl-C / SIGTERM
    interrupted=0
    continue
  fi
  remaining=$((remaining - 1))
  if ((code != 0 && status == 0)); then
    status=$code
    kill -TERM "${pids[@]}" 2>/dev/null || true
    sleep 1
    kill -TERM "${pids[@]}" 2>/dev/null || true
  fi
done
exit $status
