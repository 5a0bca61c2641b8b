#!/usr/bin/env bash
# Round-trip throughput of `varbo worker` fleets (issue 14): W workers (default 8) on one `random` study whose
# command answers at once, on a SQLite file and on a PostgreSQL study; trials/s = budget / wall time from the
# first worker's start to the last one's exit, median of R repeats. Without --pg-url a throwaway server is
# started (tests/store/pg_server.sh) and stopped afterwards. Prints a markdown table.
#
#   nice -n 15 bench/store/bench_throughput.sh build/bin/varbo [--workers 8] [--budget 400] [--repeats 3] [--pg-url URL]
set -euo pipefail
varbo=$(realpath "${1:?usage: bench_throughput.sh VARBO_EXE [--workers W] [--budget B] [--repeats R] [--pg-url URL]}")
shift
workers=8 budget=400 repeats=3 pg_url=""
while [ $# -gt 0 ]; do
  case "$1" in
    --workers) workers=$2; shift 2 ;;
    --budget) budget=$2; shift 2 ;;
    --repeats) repeats=$2; shift 2 ;;
    --pg-url) pg_url=$2; shift 2 ;;
    *) echo "unknown option $1" >&2; exit 2 ;;
  esac
done
here=$(cd "$(dirname "$0")" && pwd)
dir=$(mktemp -d /tmp/varbo-bench-throughput.XXXXXX)
cleanup() {
  [ -f "$dir/pg/datadir" ] && "$here/../../tests/store/pg_server.sh" stop "$dir/pg" >/dev/null
  rm -rf "$dir"
}
trap cleanup EXIT
if [ -z "$pg_url" ]; then
  "$here/../../tests/store/pg_server.sh" start "$dir/pg" >/dev/null
  pg_url=$(cat "$dir/pg/url")
fi
printf 'task: {type: branin}\nbudget: %s\nseed: 1\nalgorithm: {type: random}\nheartbeat_timeout: 30\n' "$budget" > "$dir/cfg.yaml"

# One fleet: create the study, start the workers, wait; prints trials/s.
fleet() {
  local study=$1
  "$varbo" -q study create "$study" "$dir/cfg.yaml" >/dev/null
  local t0 t1 pids=()
  t0=$(date +%s.%N)
  for _ in $(seq "$workers"); do
    "$varbo" -q worker "$study" --command 'cat > /dev/null; echo 1' >/dev/null 2>>"$dir/workers.log" &
    pids+=($!)
  done
  for p in "${pids[@]}"; do wait "$p"; done
  t1=$(date +%s.%N)
  echo "$budget $t0 $t1" | awk '{printf "%.1f\n", $1 / ($3 - $2)}'
}
median() { sort -g | awk '{v[NR] = $1} END {print (NR % 2) ? v[(NR + 1) / 2] : (v[NR / 2] + v[NR / 2 + 1]) / 2}'; }

echo "| store | workers | budget | trials/s (median of $repeats) | runs |"
echo "|---|---|---|---|---|"
for backend in sqlite postgresql; do
  runs=()
  for r in $(seq "$repeats"); do
    if [ "$backend" = sqlite ]; then study="$dir/s$r.db"; else study="$pg_url&study=throughput_$$_$r"; fi
    runs+=("$(fleet "$study")")
  done
  echo "| $backend | $workers | $budget | $(printf '%s\n' "${runs[@]}" | median) | ${runs[*]} |"
done
