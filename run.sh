#!/usr/bin/env bash
# Set up what is missing, build, and run a study:  ./run.sh [config.yaml] [varbo run options...]
set -euo pipefail
cd "$(dirname "$0")"
./scripts/setup.sh
config=${1:-examples/quickstart.yaml}
shift || true
exec "${BUILD_DIR:-build}/bin/varbo" run "$config" "$@"
