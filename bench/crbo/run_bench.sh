#!/usr/bin/env bash
# End-to-end CRBO benchmarks (issue 4): runs studies through the varbo CLI and prints tables of medians and
# quartiles. Usage:
#   bench/crbo/run_bench.sh BUILD_DIR [synthetic|policy|all] [SEEDS] [BUDGET]
# Defaults: all, 10 seeds, 100 evaluations. Output folders go to $OUT (default /tmp/varbo_bench_crbo).
# The machine may be shared: studies run one after another (VARBO threads as configured by the CLI).
set -euo pipefail
BUILD=${1:?usage: run_bench.sh BUILD_DIR [synthetic|policy|all] [SEEDS] [BUDGET]}
WHAT=${2:-all}
SEEDS=${3:-10}
BUDGET=${4:-100}
POLICY_TASK=${POLICY_TASK:-pendulum}   # pendulum (d = 65) or cartpole (d = 130)
OUT=${OUT:-/tmp/varbo_bench_crbo}
SRC=$(cd "$(dirname "$0")/../.." && pwd)
VARBO="$BUILD/bin/varbo"
mkdir -p "$OUT"

# Rewrites an example config: task seed/dim, run seed, budget, output folder.
make_config() {  # example out seed [dim]
  local ex=$1 out=$2 seed=$3 dim=${4:-}
  sed -e "s|^seed: .*|seed: $seed|" -e "s|^budget: .*|budget: $BUDGET|" -e "s|^output: .*|output: $out|" \
      -e "s|seed: 0}|seed: $seed}|" ${dim:+-e "s|dim: 5|dim: $dim|"} "$SRC/examples/$ex"
}

stats() {  # python: rows "label value" on stdin -> median [q1, q3] per label
  python3 -c '
import sys, statistics as st
from collections import defaultdict
d = defaultdict(list)
for line in sys.stdin:
    k, v = line.rsplit(None, 1); d[k].append(float(v))
for k in d:
    v = sorted(d[k]); q = st.quantiles(v, n=4) if len(v) > 1 else [v[0]] * 3
    print(f"| {k} | {q[1]:.4g} | [{q[0]:.4g}, {q[2]:.4g}] | {len(v)} |")'
}

if [[ $WHAT == synthetic || $WHAT == all ]]; then
  for dim in 2 5; do
    rows=""
    for seed in $(seq 1 "$SEEDS"); do
      for m in crbo bo; do
        dir="$OUT/gp_d${dim}_${m}_s${seed}"
        make_config "${m}_gp_sample.yaml" "$dir" "$seed" "$dim" > "$OUT/cfg.yaml"
        # Initial design of standard BO: the same size as CRBO's (ceil(sqrt(d)) points).
        "$VARBO" run "$OUT/cfg.yaml" > "$dir.log" 2>&1 || { echo "study failed: $dir (see $dir.log)"; continue; }
        opt=$(python3 -c "import json;print(json.load(open('$dir/summary.json'))['known_optimum'])")
        rows+=$(python3 - "$dir/trials.csv" "$opt" "$m" <<'PY'
import csv, sys
rows = list(csv.DictReader(open(sys.argv[1]))); opt = float(sys.argv[2]); best = float("inf")
out = []
for i, r in enumerate(rows, 1):
    if r["ok"] in ("1", "true"): best = min(best, float(r["cost"]))
    if i in (10, 25, 50, 100): out.append(f"{sys.argv[3]} n={i} {abs(best - opt)}")
print("\n".join(out))
PY
)$'\n'
      done
    done
    echo "### GP samples d = $dim: simple regret |min y - y*| after n evaluations ($SEEDS seeds, budget $BUDGET)"
    echo "| method, n | median | [q1, q3] | runs |"; echo "|---|---|---|---|"
    printf "%s" "$rows" | grep -v '^$' | stats
  done
fi

if [[ $WHAT == policy || $WHAT == all ]]; then
  rows=""
  for seed in $(seq 1 "$SEEDS"); do
    for m in crbo turbo cmaes bo; do
      dir="$OUT/${POLICY_TASK}_${m}_s${seed}"
      make_config "${m}_${POLICY_TASK}.yaml" "$dir" "$seed" > "$OUT/cfg.yaml"
      "$VARBO" run "$OUT/cfg.yaml" > "$dir.log" 2>&1 || { echo "study failed: $dir (see $dir.log)"; continue; }
      # R̄_n: the average observed return = −mean cost over all episodes of the run.
      rbar=$(python3 -c "
import csv; r=[-float(x['cost']) for x in csv.DictReader(open('$dir/trials.csv')) if x['ok'] in ('1','true')]
print(sum(r)/len(r))")
      # J(θ*): 10 fresh rollouts of the recommended policy, via a one-trial study that starts at θ* (the
      # around_initial_point sampler with radius 0 returns θ0) and a task averaging 10 episodes.
      theta=$(python3 -c "import json;print(json.load(open('$dir/summary.json'))['recommended_theta'])")
      task=$(grep '^task:' "$SRC/examples/crbo_${POLICY_TASK}.yaml" | sed 's/^task: {\(.*\)}/\1/')
      cat > "$OUT/eval.yaml" <<YAML
task: {$task, rollouts: 10}
budget: 1
seed: $((1000 + seed))
output: $dir/eval10
initial_point: $theta
algorithm: {type: random, sampler: {type: around_initial_point, radius: 0}}
YAML
      "$VARBO" run "$OUT/eval.yaml" > "$dir.eval.log" 2>&1 || { echo "evaluation failed: $dir"; continue; }
      j=$(python3 -c "import csv;print(-float(next(csv.DictReader(open('$dir/eval10/trials.csv')))['cost']))")
      rows+="$m Rbar_n $rbar"$'\n'"$m J(theta*) $j"$'\n'
    done
  done
  echo "### $POLICY_TASK: final expected return J(θ*) (10 fresh rollouts) and average observed return R̄_n ($SEEDS seeds, $BUDGET episodes)"
  echo "| method, metric | median | [q1, q3] | runs |"; echo "|---|---|---|---|"
  printf "%s" "$rows" | grep -v '^$' | stats
fi
