#!/usr/bin/env bash
# Installs varbo into a scratch prefix, builds the template plugins out of tree against the installed SDK
# (find_package(varbo): an acquisition, a task, an algorithm without a surrogate and a kernel), and runs short studies
# with the installed executable using them: BO with the template acquisition, the template algorithm on the
# template task (stopped and resumed: same trials), and the template task's config errors (exit 2); the core and
# the templates must not depend on SQLite, PostgreSQL or the study library.
set -euo pipefail
cd "$(dirname "$0")/.."
BUILD_DIR=${BUILD_DIR:-build}
PREFIX=${SDK_PREFIX:-$(mktemp -d /tmp/varbo-sdk.XXXXXX)}
WORK=$(mktemp -d /tmp/varbo-sdk-work.XXXXXX)
cmake --install "$BUILD_DIR" --prefix "$PREFIX" > "$WORK/install.log"
# The install ends by writing the plugin index (which library registers which component), so that a study loads
# only the plugins it names even for users who cannot write the installed folder (docs/plugins.md).
INDEX=$(find "$PREFIX" -path '*/varbo/plugins/varbo_plugins.index' | head -n 1)
if [ -z "$INDEX" ] || ! grep -q '^c bo$' "$INDEX"; then cat "$WORK/install.log"; echo "no plugin index installed"; exit 1; fi
# The Python package installed into the prefix's site-packages layout: it imports from there, loads the installed
# libvarbo_core (its RPATH) and finds the installed plugins.
# The interpreter only while the build has the bindings: the cache keeps the entry after -DVARBO_BUILD_PYTHON=OFF.
PYTHON=""
if grep -q '^VARBO_BUILD_PYTHON:BOOL=ON$' "$BUILD_DIR/CMakeCache.txt" &&
   ! grep -q '^VARBO_SANITIZE:BOOL=ON$' "$BUILD_DIR/CMakeCache.txt"; then
  PYTHON=$(sed -n 's/^VARBO_PYTHON_EXECUTABLE:INTERNAL=//p' "$BUILD_DIR/CMakeCache.txt")
fi
if [ -n "$PYTHON" ]; then
  PYPKG=$(find "$PREFIX" -path '*/varbo/__init__.py' -printf '%h\n' | head -n 1)
  if [ -z "$PYPKG" ]; then echo "check_sdk: the install under $PREFIX holds no varbo/__init__.py" >&2; exit 1; fi
  (cd "$WORK" && PYTHONPATH="$(dirname "$PYPKG")" "$PYTHON" -c "
import varbo
assert varbo.__file__.startswith('$PREFIX'), varbo.__file__
assert {'bo', 'gp', 'branin'} <= {c['name'] for c in varbo.plugins()}
assert all(c['library'].startswith('$PREFIX') for c in varbo.plugins() if c['builtin'])
print('installed Python package:', varbo.__file__)")
fi
cmake -S plugins/template -B "$WORK/template" -G Ninja -DCMAKE_BUILD_TYPE=Release -DCMAKE_PREFIX_PATH="$PREFIX" > "$WORK/configure.log"
cmake --build "$WORK/template" > "$WORK/build.log"
if grep -q "warning:" "$WORK/build.log"; then cat "$WORK/build.log"; echo "template plugins: compiler warnings"; exit 1; fi
# Built with an install() rule, a plugin's RUNPATH must still hold no empty entry (the current folder): CMake pads
# one for install to rewrite unless the plugin is built with its install RPATH (VarboPlugin.cmake).
tests/loader/check_runpath.sh "$WORK"/template/libvarbo_*.so
# The SDK a plugin builds against is the core only: neither the core nor a template plugin may need SQLite or
# the study library.
CORE_LIB=$(find "$PREFIX" -name libvarbo_core.so | head -n 1)
for lib in "$CORE_LIB" "$WORK"/template/libvarbo_*.so; do
  test -f "$lib"
  if readelf -d "$lib" | grep -E 'NEEDED.*(sqlite|pqxx|libpq|varbo_study|varbo_tools)'; then
    echo "check_sdk: $lib depends on the study machinery" >&2
    exit 1
  fi
done
# Python: varbo.load_plugin() of a third-party library built against the installed SDK; a minimize() started
# afterwards finds its component.
if [ -n "$PYTHON" ]; then
  (cd "$WORK" && PYTHONPATH="$(dirname "$PYPKG")" "$PYTHON" -c "
import varbo
varbo.load_plugin('$WORK/template/libvarbo_template.so')
assert varbo.describe('greedy_mean')['kind'] == 'acquisition'
r = varbo.minimize(lambda p: (p['x'] - 0.3) ** 2, {'algorithm': {'type': 'bo', 'initial_points': 3,
                   'acquisition': {'type': 'greedy_mean'}}}, space={'x': (0, 1)}, budget=6, seed=1)
assert r.evaluations == 6 and [t.phase for t in r.trials][-1] != 'initial', [t.phase for t in r.trials]
print('Python load_plugin + minimize with greedy_mean: ok')")
fi
# The PostgreSQL store is a library of its own, loaded on the first postgresql:// address: the installed
# libvarbo_study needs no libpq, and the installed varbo finds the store beside it (a server that refuses the
# connection is then an error naming the study, exit 2, not a library that cannot be loaded).
STUDY_LIB=$(find "$PREFIX" -name libvarbo_study.so | head -n 1)
if readelf -d "$STUDY_LIB" | grep -E 'NEEDED.*(pqxx|libpq)'; then
  echo "check_sdk: $STUDY_LIB links libpq; the PostgreSQL store should load on demand" >&2
  exit 1
fi
test -f "$(dirname "$STUDY_LIB")/libvarbo_study_postgres.so"
test -f "$(dirname "$STUDY_LIB")/libvarbo_dashboard_http.so"  # `varbo dashboard`'s server, loaded the same way
set +e
"$PREFIX/bin/varbo" status 'postgresql://nobody@127.0.0.1:1/none?study=sdk_check&connect_timeout=3' > "$WORK/pg.out" 2>&1
rc=$?
set -e
if [ "$rc" -ne 2 ] || ! grep -q "study=sdk_check" "$WORK/pg.out" || grep -q "cannot load" "$WORK/pg.out"; then
  cat "$WORK/pg.out"; echo "check_sdk: expected exit 2 naming the unreachable study, got exit $rc"; exit 1
fi
cat "$WORK/pg.out"

export VARBO_PLUGIN_PATH="$WORK/template"
VARBO="$PREFIX/bin/varbo"
for c in greedy_mean bowl one_plus_one periodic; do "$VARBO" plugins --describe "$c"; done

# 1. The template acquisition in BO on a built-in task.
cat > "$WORK/acq.yaml" <<YAML
task: {type: branin}
budget: 8
seed: 3
output: $WORK/acq
algorithm:
  type: bo
  initial_points: 4
  acquisition: {type: greedy_mean, weight: 1.0}
YAML
"$VARBO" run "$WORK/acq.yaml" --no-progress
test "$(wc -l < "$WORK/acq/trials.csv")" -eq 9

# 1b. The template kernel inside a built-in surrogate, composed with a built-in kernel.
cat > "$WORK/kernel.yaml" <<YAML
task: {type: branin}
budget: 8
seed: 3
output: $WORK/kernel
algorithm:
  type: bo
  initial_points: 4
  surrogate: {type: gp, restarts: 2, kernel: {type: sum, terms: [{type: periodic, period_median: 0.8}, se_ard]}}
YAML
"$VARBO" run "$WORK/kernel.yaml" --no-progress
test "$(wc -l < "$WORK/kernel/trials.csv")" -eq 9
# ... and in the vhgp, for f and (with the authors' white noise term) for g.
cat > "$WORK/kernel_vhgp.yaml" <<YAML
task: {type: branin}
budget: 8
seed: 3
output: $WORK/kernel_vhgp
algorithm:
  type: bo
  initial_points: 4
  surrogate: {type: vhgp, restarts: 2, kernel_f: {type: sum, terms: [periodic, se_ard]},
              kernel_g: {type: sum, terms: [periodic, white]}}
YAML
"$VARBO" run "$WORK/kernel_vhgp.yaml" --no-progress
test "$(wc -l < "$WORK/kernel_vhgp/trials.csv")" -eq 9

# 2. The template algorithm on the template task: 12 trials at once, and 5 then resumed to 12, give the same
# trials (an algorithm is rebuilt by replaying its trials, so ask() must depend only on the seed and the trials).
cat > "$WORK/es.yaml" <<YAML
task: {type: bowl, dim: 3, center: [0.3, -0.2, 0.5], noise: student_t, noise_std: 0.001}
budget: 12
seed: 5
algorithm: {type: one_plus_one, sigma: 0.3}
YAML
"$VARBO" run "$WORK/es.yaml" -o "$WORK/es_full" --no-progress
"$VARBO" run "$WORK/es.yaml" -o "$WORK/es_part" --budget 5 --no-progress
"$VARBO" run --resume "$WORK/es_part" --budget 12 --no-progress
trials() { cut -d, -f1-6 "$1/trials.csv"; }   # index, phase, θ (3), cost: not the timings
test "$(trials "$WORK/es_full" | wc -l)" -eq 13
diff <(trials "$WORK/es_full") <(trials "$WORK/es_part")
grep -q '"recommended_theta"' "$WORK/es_full/summary.json"

# 3. Config errors of the template task: at the key (o.node("center").fail), or, for a standard exception
# thrown by the factory, at the component, naming it; both exit 2 and create no run folder.
expect_config_error() {  # YAML_TASK_LINE EXPECTED_TEXT
  printf 'task: %s\nbudget: 3\nalgorithm: one_plus_one\n' "$1" > "$WORK/bad.yaml"
  set +e
  "$VARBO" run "$WORK/bad.yaml" -o "$WORK/bad_run" > "$WORK/bad.out" 2>&1
  local rc=$?
  set -e
  if [ "$rc" -ne 2 ] || ! grep -qF "$2" "$WORK/bad.out" || [ -e "$WORK/bad_run" ]; then
    cat "$WORK/bad.out"; echo "expected exit 2 with '$2' and no run folder, got exit $rc"; exit 1
  fi
  cat "$WORK/bad.out"
}
expect_config_error "{type: bowl, dim: 3, center: [0.1, 0.2]}" \
  "bad.yaml:1:36: key 'task.center': expected 1 or 3 values, got 2"
expect_config_error "{type: bowl, noise: none, noise_std: 0.5}" \
  "bad.yaml:1:7: key 'task': task 'template_task/bowl' (from $WORK/template/libvarbo_template_task.so) could not be created: noise_std is set but noise is 'none'"

if [ -d examples/embedding ]; then
  cmake -S examples/embedding -B "$WORK/embedding" -G Ninja -DCMAKE_PREFIX_PATH="$PREFIX" > "$WORK/embed.log"
  cmake --build "$WORK/embedding" >> "$WORK/embed.log"
  (cd "$WORK" && "$WORK/embedding/varbo_embedding_example")
  # A host built for a newer CPU (AVX2: Eigen's 32-byte alignment unless varbo::core pins it) crashed in ~TrialRecord.
  if grep -qw avx2 /proc/cpuinfo 2>/dev/null; then
    cmake -S examples/embedding -B "$WORK/embedding_avx2" -G Ninja -DCMAKE_PREFIX_PATH="$PREFIX" \
      -DCMAKE_CXX_FLAGS=-march=x86-64-v3 > "$WORK/embed_avx2.log"
    cmake --build "$WORK/embedding_avx2" >> "$WORK/embed_avx2.log"
    rm -f "$WORK"/embedding_example.db*
    (cd "$WORK" && "$WORK/embedding_avx2/varbo_embedding_example")
  fi
fi
echo "SDK check passed (prefix $PREFIX)"
rm -rf "$WORK"
[ -n "${SDK_PREFIX:-}" ] || rm -rf "$PREFIX"
