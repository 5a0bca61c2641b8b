#!/usr/bin/env bash
# Set up what is missing, build, and run a study:  ./run.sh [config.yaml] [varbo run options...]
# A study of your own runs in the folder you call this from (its config path, -o and output: are yours); the
# demo runs in the repository (runs/quickstart).
set -euo pipefail
root=$(cd "$(dirname "$0")" && pwd)
"$root/scripts/setup.sh"
build=${BUILD_DIR:-build}
case "$build" in /*) ;; *) build="$root/$build" ;; esac
if [ $# -eq 0 ]; then
  # The demo: re-running it replaces runs/quickstart. A study of your own is never replaced silently.
  cd "$root"
  exec "$build/bin/varbo" run examples/quickstart.yaml --overwrite
fi
config=$1
shift
exec "$build/bin/varbo" run "$config" "$@"
