#!/usr/bin/env bash
# A throwaway PostgreSQL server for the test suite (ctest fixture pg_server, docs/studies.md "Tests").
#   pg_server.sh start STATE_DIR   initdb in a fresh temporary folder, a unix socket only (no TCP), start;
#                                  writes STATE_DIR/url (base URL, append &study=NAME) and STATE_DIR/datadir
#   pg_server.sh stop STATE_DIR    stops the server and removes its folder
#   pg_server.sh restart STATE_DIR [SECONDS]   stops the server, waits SECONDS (default 0), starts it again on the
#                                  same data and socket (an outage, for the tests that clients ride it out)
# The server refuses to run as root: as root, initdb/pg_ctl run as `nobody` on a folder chowned to it.
# Authentication: trust for role varbo (the superuser), scram-sha-256 for role varbo_pw (password 'right'), so
# that tests can check wrong-credential errors.
# VARBO_PG_FSYNC=on starts a server that flushes its WAL at each commit as a real one does (the tests and the
# default skip the flush: fsync=off); for measuring what a commit costs (docs/studies.md, "Where the time goes").
set -euo pipefail
action=${1:?usage: pg_server.sh start|stop|restart STATE_DIR}
state=${2:?usage: pg_server.sh start|stop|restart STATE_DIR}
# The newest version whose server is installed: postgresql-client-N alone makes /usr/lib/postgresql/N/bin too.
bindir=$(ls -d /usr/lib/postgresql/*/bin 2>/dev/null | sort -V | while read -r d; do
  if [ -x "$d/initdb" ] && [ -x "$d/pg_ctl" ]; then echo "$d"; fi
done | tail -1) || true
[ -n "$bindir" ] && [ -x "$bindir/initdb" ] || { echo "pg_server.sh: PostgreSQL server binaries not found (apt-get install postgresql)" >&2; exit 1; }

as_server() {  # run a server command as an unprivileged user when we are root
  if [ "$(id -u)" = 0 ]; then runuser -u nobody -- "$@"; else "$@"; fi
}

stop() {
  [ -f "$state/datadir" ] || return 0
  local dir
  dir=$(cat "$state/datadir")
  if [ -d "$dir/data" ]; then as_server "$bindir/pg_ctl" -D "$dir/data" -m immediate -w stop >/dev/null 2>&1 || true; fi
  rm -rf "$dir"
  rm -f "$state/datadir" "$state/url"
}

launch() {  # start the server of folder $1 (data in $1/data, socket in $1)
  as_server "$bindir/pg_ctl" -D "$1/data" -l "$1/server.log" -w -t 60 \
    -o "-c listen_addresses='' -c unix_socket_directories='$1' -c fsync=${VARBO_PG_FSYNC:-off} -c max_connections=100" start >/dev/null ||
    { cat "$1/server.log" >&2; exit 1; }
}

case "$action" in
  restart)
    dir=$(cat "$state/datadir")
    as_server "$bindir/pg_ctl" -D "$dir/data" -m fast -w stop >/dev/null
    sleep "${3:-0}"
    launch "$dir"
    ;;
  start)
    mkdir -p "$state"
    stop  # a server left by an interrupted run
    dir=$(mktemp -d /tmp/varbo-pg.XXXXXX)  # short: a unix socket path holds at most 107 bytes
    echo "$dir" > "$state/datadir"
    [ "$(id -u)" = 0 ] && chown nobody "$dir"
    chmod 700 "$dir"
    as_server "$bindir/initdb" -D "$dir/data" -U varbo --auth=trust -E UTF8 --no-sync >"$dir/initdb.log" 2>&1 ||
      { cat "$dir/initdb.log" >&2; exit 1; }
    {
      echo "local all varbo_pw scram-sha-256"
      echo "local all all trust"
    } > "$dir/data/pg_hba.conf"
    launch "$dir"
    chmod 711 "$dir"  # clients (root or not) reach the socket
    as_server "$bindir/psql" -h "$dir" -U varbo -d postgres -qAt -v ON_ERROR_STOP=1 \
      -c "CREATE DATABASE varbo_test" -c "CREATE ROLE varbo_pw LOGIN PASSWORD 'right'" \
      -c "CREATE ROLE varbo_reader LOGIN" >/dev/null
    echo "postgresql://varbo@/varbo_test?host=$dir" > "$state/url"
    echo "PostgreSQL test server on $dir: $(cat "$state/url")"
    ;;
  stop) stop ;;
  *) echo "usage: pg_server.sh start|stop|restart STATE_DIR [SECONDS]" >&2; exit 2 ;;
esac
