#!/bin/bash
# Red-team probe of signals: starts `varbo run` (or `varbo worker` with mode=worker) on COMMAND, sends the
# signals after DELAY s, then prints the exit code, the study state and any process left with the probe mark.
# sigprobe.sh NAME SIG DELAY 'COMMAND' [threads] [mode: run|worker]
V=${V:-$(cd "$(dirname "$0")/../.." && pwd)/build/bin/varbo}
name=$1; sig=$2; delay=$3; cmd=$4; thr=${5:-1}; mode=${6:-run}
d=${PROBE_DIR:-/tmp/varbo_probes}/$name; rm -rf $d; mkdir -p $d; cd $d
cmdesc=$(printf '%s' "$cmd" | sed 's/\\/\\\\/g; s/"/\\"/g')
cat > cfg.yaml <<EOC
task: {type: external, command: "$cmdesc", dim: 1, timeout: 60}
budget: 4
algorithm: random
threads: $thr
heartbeat_timeout: 5
EOC
s=$(date +%s.%N)
if [ $mode = run ]; then
  VARBO_PROBE_MARK=$name setsid $V run cfg.yaml -o out --no-progress > stdout.txt 2> stderr.txt < /dev/null & pid=$!
else
  $V study create s.db cfg.yaml >/dev/null 2>&1
  VARBO_PROBE_MARK=$name setsid $V worker s.db --command "$cmd" --timeout 60 > stdout.txt 2> stderr.txt < /dev/null & pid=$!
fi
sleep $delay; for sg in $sig; do kill -$sg $pid; sleep ${GAP:-0.3}; done
for i in $(seq 1 200); do kill -0 $pid 2>/dev/null || break; sleep 0.1; done
wait $pid; rc=$?
e=$(date +%s.%N)
sleep 0.5
left=$(for p in $(ls /proc | grep -E '^[0-9]+$'); do grep -qz "^VARBO_PROBE_MARK=$name$" /proc/$p/environ 2>/dev/null && ps -o pid=,pgid=,sid=,stat=,args= -p $p; done)
printf '%-28s rc=%-3s t=%5.1fs\n' "$name" "$rc" "$(echo "$e - $s" | bc)"
if [ $mode = run ]; then [ -f out/trials.csv ] && cut -c1-200 out/trials.csv | sed 's/^/    /'; st=out/study.db; else st=s.db; fi
$V status $st 2>&1 | grep -v "plugin lib" | head -12 | sed 's/^/    st: /'
sqlite3 $st "select id,state,substr(error,1,100) from trials" 2>/dev/null | sed 's/^/    db: /'
tail -n 3 stderr.txt | cut -c1-250 | sed 's/^/    err: /'
[ -n "$left" ] && { echo "    LEFTOVER:"; echo "$left" | sed 's/^/    /'; echo "$left" | awk '{print $1}' | xargs -r kill -9; }
true
