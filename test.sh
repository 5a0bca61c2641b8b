#!/usr/bin/env bash
# Set up what is missing, build, and run the test suite (ctest). Long studies are excluded unless asked:
#   ./test.sh            # the default suite (label unit)
#   ./test.sh -L long    # extra arguments go to ctest
set -euo pipefail
cd "$(dirname "$0")"
./scripts/setup.sh
if [ $# -eq 0 ]; then set -- -LE long; fi
exec ctest --test-dir "${BUILD_DIR:-build}" --output-on-failure -j "$(nproc)" "$@"
