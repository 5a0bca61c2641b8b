#!/usr/bin/env bash
# Cost of one CRBO iteration at d = 100 with N = 200 data (issue 4): a cart-pole study with 99 features
# (d = 100), 200 initial points around θ0 and one CRBO trial; prints the fit and acquisition seconds of trial 201.
# Usage: bench/crbo/iteration_cost.sh BUILD_DIR [THREADS]
set -euo pipefail
BUILD=${1:?usage: iteration_cost.sh BUILD_DIR [THREADS]}
THREADS=${2:-2}
SRC=$(cd "$(dirname "$0")/../.." && pwd)
OUT=${OUT:-/tmp/varbo_bench_crbo}/iteration_d100
mkdir -p "$(dirname "$OUT")"
sed -e "s|^output: .*|output: $OUT|" -e "s|^budget: .*|budget: 201|" -e "s|features: 129|features: 99|" \
    -e "s|initial_points: 12$|initial_points: 200|" -e "s|^seed: .*|seed: 1\nthreads: $THREADS|" \
    "$SRC/examples/crbo_cartpole.yaml" > "$OUT.yaml"
"$BUILD/bin/varbo" run "$OUT.yaml" > "$OUT.log" 2>&1
python3 -c "
import csv; r=list(csv.DictReader(open('$OUT/trials.csv')))[-1]
print(f'| d = 100, N = 200, $THREADS threads | {r[\"phase\"]} | fit {float(r[\"fit_seconds\"]):.2f} s | acquisition {float(r[\"acquisition_seconds\"]):.2f} s | total {float(r[\"fit_seconds\"])+float(r[\"acquisition_seconds\"]):.2f} s |')"
