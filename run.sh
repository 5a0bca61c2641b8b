#!/usr/bin/env bash
# Set up what is missing, build, and run a study:  ./run.sh [config.yaml] [varbo run options...]
set -euo pipefail
cd "$(dirname "$0")"
./scripts/setup.sh
if [ $# -eq 0 ]; then
  # The demo: re-running it replaces runs/quickstart. A study of your own is never replaced silently.
  exec "${BUILD_DIR:-build}/bin/varbo" run examples/quickstart.yaml --overwrite
fi
config=$1
shift
exec "${BUILD_DIR:-build}/bin/varbo" run "$config" "$@"
