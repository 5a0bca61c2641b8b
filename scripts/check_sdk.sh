#!/usr/bin/env bash
# Installs varbo into a scratch prefix, builds the template plugin out of tree against the installed SDK
# (find_package(varbo)), and runs a short study with the installed executable using that plugin.
set -euo pipefail
cd "$(dirname "$0")/.."
BUILD_DIR=${BUILD_DIR:-build}
PREFIX=${SDK_PREFIX:-$(mktemp -d /tmp/varbo-sdk.XXXXXX)}
WORK=$(mktemp -d /tmp/varbo-sdk-work.XXXXXX)
cmake --install "$BUILD_DIR" --prefix "$PREFIX" > "$WORK/install.log"
cmake -S plugins/template -B "$WORK/template" -G Ninja -DCMAKE_BUILD_TYPE=Release -DCMAKE_PREFIX_PATH="$PREFIX" > "$WORK/configure.log"
cmake --build "$WORK/template" > "$WORK/build.log"
# The SDK a plugin builds against is the core only: neither the core nor a template plugin may need SQLite or
# the study library.
CORE_LIB=$(find "$PREFIX" -name libvarbo_core.so | head -n 1)
for lib in "$CORE_LIB" "$WORK"/template/libvarbo_*.so; do
  test -f "$lib"
  if readelf -d "$lib" | grep -E 'NEEDED.*(sqlite|varbo_study|varbo_tools)'; then
    echo "check_sdk: $lib depends on the study machinery" >&2
    exit 1
  fi
done
export VARBO_PLUGIN_PATH="$WORK/template"
"$PREFIX/bin/varbo" plugins --describe greedy_mean
cat > "$WORK/study.yaml" <<YAML
task: {type: branin}
budget: 8
seed: 3
output: $WORK/run
algorithm:
  type: bo
  initial_points: 4
  acquisition: {type: greedy_mean, weight: 1.0}
YAML
"$PREFIX/bin/varbo" run "$WORK/study.yaml" --no-progress
test "$(wc -l < "$WORK/run/trials.csv")" -eq 9
if [ -d examples/embedding ]; then
  cmake -S examples/embedding -B "$WORK/embedding" -G Ninja -DCMAKE_PREFIX_PATH="$PREFIX" > "$WORK/embed.log"
  cmake --build "$WORK/embedding" >> "$WORK/embed.log"
  (cd "$WORK" && "$WORK/embedding/varbo_embedding_example")
fi
echo "SDK check passed (prefix $PREFIX)"
rm -rf "$WORK"
[ -n "${SDK_PREFIX:-}" ] || rm -rf "$PREFIX"
