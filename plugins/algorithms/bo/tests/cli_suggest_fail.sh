#!/usr/bin/env bash
# Issue 11 through the CLI: `varbo suggest` → `varbo fail` cycles must not return the same θ again (before
# failure-aware BO, 5 cycles gave 5 points within 2e-5). The 6 design trials are observed with a cost whose
# minimum (x1 = −4, x2 = 10) draws the model to one place; then every suggestion fails.
# usage: cli_suggest_fail.sh VARBO_BINARY WORK_DIR
set -euo pipefail
varbo=$1
dir=$2
rm -rf "$dir"
mkdir -p "$dir"
cat > "$dir/s.yaml" <<YAML
task: {type: branin}
budget: 30
seed: 3
algorithm: {type: bo}
YAML
"$varbo" study create "$dir/s.db" "$dir/s.yaml" > /dev/null
field() { sed -n "s/.* $1=\([^ ]*\).*/\1/p"; }
for _ in 1 2 3 4 5 6; do
  line=$("$varbo" suggest "$dir/s.db")
  id=$(echo "$line" | sed -n 's/^trial \([0-9]*\).*/\1/p')
  x1=$(echo "$line" | field x1)
  x2=$(echo "$line" | field x2)
  cost=$(awk -v a="$x1" -v b="$x2" 'BEGIN { printf "%.12g", (a + 4) ^ 2 + (b - 10) ^ 2 }')
  "$varbo" observe "$dir/s.db" "$id" "$cost" > /dev/null
done
: > "$dir/failed.txt"
for _ in 1 2 3 4 5 6; do
  line=$("$varbo" suggest "$dir/s.db")
  id=$(echo "$line" | sed -n 's/^trial \([0-9]*\).*/\1/p')
  echo "$(echo "$line" | field x1) $(echo "$line" | field x2)" >> "$dir/failed.txt"
  "$varbo" fail "$dir/s.db" "$id" --reason "the robot fell" > /dev/null
done
# Smallest distance between two failed suggestions, in fractions of the box [-5, 10] × [0, 15].
awk '{ x[NR] = ($1 + 5) / 15; y[NR] = $2 / 15 }
     END { m = 1e9
           for (i = 1; i <= NR; ++i) for (j = 1; j < i; ++j) {
             d = sqrt((x[i] - x[j]) ^ 2 + (y[i] - y[j]) ^ 2); if (d < m) m = d }
           printf "6 failed suggestions via the CLI; closest pair %.3g apart (box fractions)\n", m
           exit (m > 0.02 ? 0 : 1) }' "$dir/failed.txt"
