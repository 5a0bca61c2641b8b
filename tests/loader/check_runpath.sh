#!/usr/bin/env bash
# check_runpath.sh FILE...: every RUNPATH/RPATH entry of each ELF file is absolute or $ORIGIN-relative.
# An empty entry (CMake pads an RPATH that install rewrites with ':') or a relative one is searched from the
# current folder by the dynamic loader: a `varbo` run from a folder holding a libfmt.so.9 would load that one.
set -euo pipefail
command -v readelf > /dev/null || { echo "check_runpath.sh: readelf (binutils) not found" >&2; exit 1; }
status=0
for f in "$@"; do
  path=$(readelf -d "$f" | sed -n 's/.*(\(RUNPATH\|RPATH\)).*\[\(.*\)\]$/\2/p')
  [ -n "$path" ] || { echo "$f: no RUNPATH"; status=1; continue; }
  IFS=: read -r -a entries <<< "$path"
  case "$path" in *:) entries+=("");; esac  # `read` drops a trailing empty field
  for e in "${entries[@]}"; do
    case "$e" in
      /*|'$ORIGIN'|'$ORIGIN/'*) ;;
      *) echo "$f: RUNPATH [$path] has the entry '$e', searched from the current folder"; status=1; break ;;
    esac
  done
done
[ "$status" = 0 ] && echo "checked $# files: every RUNPATH entry is absolute or \$ORIGIN-relative"
exit "$status"
