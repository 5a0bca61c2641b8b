#!/bin/sh
# Benchmark table of docs/rssgd.md (issue 5): RSSGD on the gantry transport task.
#   1. learn with κ = 0 for 30 trials from the hand-made policy (examples/rssgd_transport.yaml)
#   2. offline re-selection for the energy-averse weighting (energy weight ×10) with κ = 0 and κ = 2
#   3. 5 risk-averse (κ = 2) RSSGD steps from the κ = 2 selection
#   4. 50 fresh rollouts of each policy under the new weighting: mean and std of the cost
# Usage: bench/rssgd/table.sh [BUILD_DIR] [extra rescore options, e.g. --critic '{type: gp}']
set -eu
here=$(cd "$(dirname "$0")" && pwd)
root=$(cd "$here/../.." && pwd)
build=${1:-$root/build}
[ $# -gt 0 ] && shift
varbo="$build/bin/varbo"
out=$(mktemp -d "${TMPDIR:-/tmp}/varbo_rssgd_bench.XXXXXX")
"$varbo" -q run "$root/examples/rssgd_transport.yaml" --output "$out/learn" 2>/dev/null | sed -n '/summary/,$p'
"$varbo" -q rescore "$out/learn" --weights energy=0.02 --kappa 0,2 --continue 5 --rollouts 50 --threads 1 "$@"
echo "(run folders in $out)"
