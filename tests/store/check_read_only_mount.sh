#!/usr/bin/env bash
# A study on a read-only mount can be read (status, export, select, verify) and refuses changes with a clear
# error; a -wal without its -shm there is named, not silently skipped. Needs root and a private mount namespace
# (unshare -m): skipped (exit 77) where that is not available. Usage: check_read_only_mount.sh VARBO EXAMPLES_DIR
set -uo pipefail
varbo=$1 examples=$2
if [ "$(id -u)" != 0 ] || ! unshare -m true 2>/dev/null; then
  echo "skipped: needs root and unshare -m"; exit 77
fi
work=$(mktemp -d); trap 'rm -rf "$work"' EXIT
mkdir -p "$work/src" "$work/ro"
"$varbo" run "$examples/quickstart.yaml" -o "$work/src/run" >/dev/null 2>&1 || { echo "FAIL: the study did not run"; exit 1; }
cp -a "$work/src/run" "$work/src/walrun"
# A -wal holding a change, without its -shm (copied from a live connection's files).
python3 - "$work/src/walrun/study.db" <<'PY' || { echo "FAIL: could not make the -wal case"; exit 1; }
import os, shutil, sqlite3, sys
db = sys.argv[1]
c = sqlite3.connect(db); c.execute("PRAGMA wal_autocheckpoint=0"); c.execute("INSERT INTO meta VALUES('probe','1')"); c.commit()
shutil.copy(db + "-wal", db + "-wal.keep"); c.close()
os.replace(db + "-wal.keep", db + "-wal")
if os.path.exists(db + "-shm"): os.remove(db + "-shm")
PY
exec unshare -m bash -s "$varbo" "$work" <<'INNER'
varbo=$1 work=$2 fail=0
mount --bind "$work/src" "$work/ro" && mount -o remount,bind,ro "$work/ro" || { echo "skipped: cannot mount"; exit 77; }
db=$work/ro/run/study.db
expect() {  # expect NAME EXIT_CODE PATTERN -- command...
  local name=$1 code=$2 pattern=$3; shift 4
  out=$("$@" 2>&1); rc=$?
  if [ "$rc" != "$code" ] || ! grep -q -- "$pattern" <<<"$out"; then
    echo "FAIL: $name: exit $rc (expected $code), output:"; echo "$out" | head -5; fail=1
  else echo "ok: $name"; fi
}
expect status 0 "30 complete" -- "$varbo" status "$db"
expect export 0 "^29,complete" -- "$varbo" export "$db" --csv
expect select 0 "kappa" -- "$varbo" select "$work/ro/run" --kappa 1
expect verify 0 "every serial trial reproduced" -- "$varbo" study verify "$db"
expect suggest 2 "read-only file system: it can be read" -- "$varbo" suggest "$db"
expect observe 2 "read-only file system" -- "$varbo" observe "$db" 0 1.5
expect wal 2 "newest changes are in .*-wal" -- "$varbo" status "$work/ro/walrun/study.db"
[ -z "$(ls "$work/src/run" | grep -e '-shm$' -e '-wal$')" ] || { echo "FAIL: files appeared next to the study"; fail=1; }
exit $fail
INNER
