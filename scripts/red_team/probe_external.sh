#!/bin/bash
# Red-team probe of the external task (docs/red_team_external.md): writes a config with COMMAND, runs
# `varbo run` (timeout ${TO:-2} s, budget ${BUDGET:-2}), prints exit code, wall time, trials.csv, the end of
# stderr and any process still carrying this probe's environment mark (and kills it: they are its own).
# probe.sh NAME 'COMMAND' [extra yaml lines]  -> runs varbo run with timeout 2, prints time, exit, statuses, leftovers
V=${V:-$(cd "$(dirname "$0")/../.." && pwd)/build/bin/varbo}
name=$1; cmd=$2; extra=$3
d=${PROBE_DIR:-/tmp/varbo_probes}/$name; rm -rf $d; mkdir -p $d; cd $d
cmdesc=$(printf '%s' "$cmd" | sed 's/\\/\\\\/g; s/"/\\"/g')
cat > cfg.yaml <<EOC
task: {type: external, command: "$cmdesc", dim: 1, timeout: ${TO:-2}${extra}}
budget: ${BUDGET:-2}
algorithm: random
EOC
s=$(date +%s.%N)
VARBO_PROBE_MARK=$name timeout -k 1 ${HANG:-40} $V run cfg.yaml -o out --no-progress > stdout.txt 2> stderr.txt < /dev/null; rc=$?
e=$(date +%s.%N)
sleep 0.3
left=$(for p in $(ls /proc | grep -E '^[0-9]+$'); do grep -qz "^VARBO_PROBE_MARK=$name$" /proc/$p/environ 2>/dev/null && ps -o pid=,pgid=,sid=,stat=,args= -p $p; done)
printf '%-28s rc=%-3s t=%5.1fs size=%s utf8=%s\n' "$name" "$rc" "$(echo "$e - $s" | bc)" "$(stat -c %s out/trials.csv 2>/dev/null)" "$(iconv -f utf-8 -t utf-8 out/trials.csv >/dev/null 2>&1 && echo y || echo n)"
[ -f out/trials.csv ] && cut -c1-300 out/trials.csv | tail -n +2 | sed 's/^/    /'
tail -c 400 stderr.txt | sed 's/^/    err: /' | tail -4
[ -n "$left" ] && { echo "    LEFTOVER:"; echo "$left" | sed 's/^/    /'; echo "$left" | awk '{print $1}' | xargs -r kill -9; }
true
