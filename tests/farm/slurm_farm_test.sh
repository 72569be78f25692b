#!/usr/bin/env bash
# A real Slurm scheduler rendering a sequence (issue 16, docs/farm.md): starts munged, slurmctld
# and slurmd on this machine (one node, no systemd, everything in a temp folder), submits 12
# frames as an array job of 4 tasks of 3 frames (examples/farm/slurm_render.sh), cancels one
# task in the middle of a frame (scancel: SIGTERM) and SIGKILLs another's nimbus (no handler
# runs), requeues both, waits, and checks that every
# frame exists, is a valid EXR of the right size, that no temp file is left, that the requeued
# task rendered exactly the frames its first run had not finished, and that every frame is
# bit-identical to the same frame rendered locally. The daemons are shut down on every exit.
#
#   slurm_farm_test.sh NIMBUS_BINARY SCRATCH_DIR
#
# Exit 0 pass, 1 fail, 77 skip (only where the daemons cannot start: the reason is printed).
set -uo pipefail
nimbus="$(realpath "$1")"
scratch="$2"
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
scene="$root/examples/scenes/cumulus.toml"
# Single scattering (no diffusion grid): the test is about the scheduler, and a frame of about
# 2 s on one CPU (5.4 s with the grid) still leaves time to cancel a task in the middle of one.
size=(--set camera.width=320 --set camera.height=180 --set 'render.multiple_scattering="none"')
started=$(date +%s.%N)

fail() {
    echo "FAIL: $*"
    exit 1
}
skip() {
    echo "SKIP: $*"
    exit 77
}
for b in munged slurmctld slurmd sbatch squeue scontrol scancel idiff oiiotool; do
    command -v "$b" >/dev/null ||
        skip "$b not found: examples/install_deps.sh installs slurm-wlm, munge and openimageio-tools"
done

rm -rf "$scratch"
mkdir -p "$scratch"
T="$(mktemp -d "$scratch/slurm.XXXXXX")"
chmod 711 "$T" # munged wants its socket's folder reachable by everyone
mkdir -p "$T/state" "$T/spool" "$T/log" "$T/out" "$T/local"
export SLURM_CONF="$T/slurm.conf"

cleanup() {
    scontrol shutdown >/dev/null 2>&1
    for f in slurmctld.pid slurmd.pid; do
        [ -f "$T/$f" ] && kill "$(cat "$T/$f")" 2>/dev/null
    done
    munged -s -S "$T/munge.sock" >/dev/null 2>&1
    sleep 1
    for f in slurmctld.pid slurmd.pid munged.pid; do
        [ -f "$T/$f" ] && kill -9 "$(cat "$T/$f")" 2>/dev/null
    done
    return 0
}
trap cleanup EXIT

# two free TCP ports on the loopback for slurmctld and slurmd
read -r port1 port2 < <(python3 -c '
import socket
s = [socket.socket() for _ in range(2)]
for x in s: x.bind(("127.0.0.1", 0))
print(*[x.getsockname()[1] for x in s])')
host="$(hostname -s)"

dd if=/dev/urandom of="$T/munge.key" bs=1024 count=1 2>/dev/null
chmod 400 "$T/munge.key"
munged --force -S "$T/munge.sock" --key-file="$T/munge.key" --log-file="$T/log/munged.log" \
    --pid-file="$T/munged.pid" --seed-file="$T/munged.seed" ||
    skip "munged does not start here: $(tail -2 "$T/log/munged.log" 2>/dev/null)"

cat >"$SLURM_CONF" <<EOF
ClusterName=nimbustest
SlurmctldHost=$host
SlurmctldPort=$port1
SlurmdPort=$port2
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
AuthInfo=socket=$T/munge.sock
CredType=cred/munge
StateSaveLocation=$T/state
SlurmdSpoolDir=$T/spool
SlurmctldPidFile=$T/slurmctld.pid
SlurmdPidFile=$T/slurmd.pid
SlurmctldLogFile=$T/log/slurmctld.log
SlurmdLogFile=$T/log/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
SelectType=select/cons_tres
SelectTypeParameters=CR_CPU
MpiDefault=none
ReturnToService=2
JobRequeue=1
KillWait=10
NodeName=$host CPUs=2 State=UNKNOWN
PartitionName=render Nodes=$host Default=YES MaxTime=INFINITE State=UP
EOF
slurmctld -i || skip "slurmctld does not start here: $(tail -3 "$T/log/slurmctld.log" 2>/dev/null)"
slurmd || skip "slurmd does not start here: $(tail -3 "$T/log/slurmd.log" 2>/dev/null)"
ready=0
for _ in $(seq 1 60); do
    if sinfo -h -o "%t" 2>/dev/null | grep -q idle; then
        ready=1
        break
    fi
    sleep 0.5
done
[ "$ready" = 1 ] || skip "the Slurm node did not come up idle within 30 s: $(tail -3 "$T/log/slurmd.log")"
up=$(date +%s.%N)
echo "daemons up in $(python3 -c "print(round($up - $started, 2))") s (slurmctld port $port1, slurmd $port2)"

# 12 frames, 4 tasks of 3, one CPU each (two run at once on this 2-CPU node)
jid=$(NIMBUS="$nimbus" sbatch --parsable --array=0-3 --cpus-per-task=1 \
    -o "$T/log/task_%a.log" --export=ALL "$root/examples/farm/slurm_render.sh" \
    "$scene" 1 12 3 "${size[@]}" -o "$T/out/f.####.exr") || fail "sbatch refused the job"
echo "submitted array job $jid"

# cancel task 1 (frames 4-6) once it has finished one frame and is rendering the next
victim="${jid}_1"
log1="$T/log/task_1.log"
deadline=$((SECONDS + 180))
while ! grep -q "^frame [0-9]*: .* -> " "$log1" 2>/dev/null; do
    [ $SECONDS -lt $deadline ] || fail "task 1 finished no frame within 180 s: $(tail -5 "$log1" 2>/dev/null)"
    sleep 0.1
done
scancel "$victim" || fail "scancel $victim"
echo "cancelled $victim after: $(grep -c "^frame [0-9]*: .* -> " "$log1") frame(s) done"
for _ in $(seq 1 100); do
    st=$(squeue -h -j "$victim" -o %T 2>/dev/null)
    [ -z "$st" ] && break
    sleep 0.2
done
done_before=$(grep "^frame [0-9]*: .* -> " "$log1" | sed 's/^frame \([0-9]*\):.*/\1/' | sort -n | tr '\n' ' ')
grep -q "interrupted\|CANCELLED" "$log1" || fail "task 1's log shows no interruption: $(tail -5 "$log1")"
# nothing under a final name but whole frames, no temp file left by the interrupted one
for f in 4 5 6; do
    out=$(printf "%s/out/f.%04d.exr" "$T" "$f")
    if [ -e "$out" ] && ! echo " $done_before " | grep -q " $f "; then
        fail "frame $f exists although task 1 was cancelled before finishing it"
    fi
done
# (task 1's frames only: another task may be writing one of its own at this moment)
leftover=$(find "$T/out" -name '.f.000[456].exr*tmp*' | head -3)
[ -z "$leftover" ] || fail "the cancelled task left temp files: $leftover"

scontrol requeue "$victim" || fail "scontrol requeue $victim"
# a requeued job waits for a begin time (about two minutes) unless told otherwise; not at once
# either: slurmd refuses a job credential that is not newer, in whole seconds, than the
# revocation of the cancelled run's ("Job credential revoked")
scontrol update JobId="$victim" StartTime=now+3 >/dev/null 2>&1

# SIGKILL task 2's nimbus (frames 7-9) once it has finished a frame and started the next: no
# handler runs (the OOM killer, a crash). The task fails (ExitCode 0:9); nothing it leaves may
# pass for a frame; it is requeued like task 1.
victim2="${jid}_2"
log2="$T/log/task_2.log"
deadline=$((SECONDS + 180))
until [ -n "$(awk '/ -> /{d=1} d && /^frame [0-9]+\/[0-9]+ /{print; exit}' "$log2" 2>/dev/null)" ]; do
    [ $SECONDS -lt $deadline ] || fail "task 2 started no second frame within 180 s: $(tail -5 "$log2" 2>/dev/null)"
    sleep 0.05
done
pid2=$(pgrep -f -- "--frames 7-9 .*$T/out/") || fail "no nimbus process of task 2"
kill -KILL $pid2
for _ in $(seq 1 100); do
    [ -z "$(squeue -h -j "$victim2" 2>/dev/null)" ] && break
    sleep 0.2
done
st2=$(scontrol -o show job "$victim2" | grep -oE 'JobState=[A-Z_]+|ExitCode=[0-9:]+' | tr '\n' ' ')
echo "task 2 SIGKILLed: $st2"
[[ $st2 == *JobState=FAILED*ExitCode=0:9* ]] || fail "task 2 after SIGKILL: $st2"
done_before2=$(grep "^frame [0-9]*: .* -> " "$log2" | sed 's/^frame \([0-9]*\):.*/\1/' | sort -n | tr '\n' ' ')
for f in 7 8 9; do
    out=$(printf "%s/out/f.%04d.exr" "$T" "$f")
    if [ -e "$out" ] && ! echo " $done_before2 " | grep -q " $f "; then
        fail "frame $f exists although task 2 was killed before finishing it"
    fi
done
# whatever else is there must not pass for a frame: only hidden temp names, none ending in .exr
odd=$(find "$T/out" -mindepth 1 \( ! -name '.*' -o -name '*.exr' \) ! -name 'f.[0-9][0-9][0-9][0-9].exr')
[ -z "$odd" ] || fail "the SIGKILL left files that could pass for frames: $odd"
scontrol requeue "$victim2" || fail "scontrol requeue $victim2"
scontrol update JobId="$victim2" StartTime=now+3 >/dev/null 2>&1
deadline=$((SECONDS + 240))
while [ -n "$(squeue -h -j "$jid" 2>/dev/null)" ]; do
    [ $SECONDS -lt $deadline ] || fail "the array job did not finish within 240 s: $(squeue -j "$jid")"
    sleep 0.5
done
finished=$(date +%s.%N)

# every frame: there, valid, right size, nothing else in the folder
count=$(find "$T/out" -maxdepth 1 -type f | wc -l)
[ "$count" = 12 ] || fail "expected 12 files in the output folder, found $count: $(ls -a "$T/out")"
for f in $(seq 1 12); do
    out=$(printf "%s/out/f.%04d.exr" "$T" "$f")
    [ -f "$out" ] || fail "frame $f missing: $(cat "$T"/log/task_*.log | tail -20)"
    res=$(oiiotool --info "$out" 2>&1 | head -1)
    echo "$res" | grep -q "320 x  *180" || fail "frame $f is not a 320x180 EXR: $res"
done
for k in 0 2 3; do
    ! grep -qi "error" "$T/log/task_$k.log" || fail "task $k: $(grep -i error "$T/log/task_$k.log")"
done

# the requeued run rendered exactly the frames its first run had not finished
restart=$(awk '/restart 1\)/{p=1} p' "$log1")
[ -n "$restart" ] || fail "task 1 did not run again after the requeue: $(tail -5 "$log1")"
skipped=$(echo "$restart" | grep "skipped (--resume)" | sed 's/^frame \([0-9]*\):.*/\1/' | sort -n | tr '\n' ' ')
rendered=$(echo "$restart" | grep "^frame [0-9]*: .* -> " | sed 's/^frame \([0-9]*\):.*/\1/' | sort -n | tr '\n' ' ')
[ "$skipped" = "$done_before" ] || fail "the requeued task skipped '$skipped', its first run had finished '$done_before'"
expected=""
for f in 4 5 6; do echo " $done_before " | grep -q " $f " || expected="$expected$f "; done
[ "$rendered" = "$expected" ] || fail "the requeued task rendered '$rendered', expected '$expected'"
echo "task 1: first run finished '$done_before', the requeued run skipped '$skipped' and rendered '$rendered'"
restart2=$(awk '/restart 1\)/{p=1} p' "$log2")
[ -n "$restart2" ] || fail "task 2 did not run again after the requeue: $(tail -5 "$log2")"
skipped2=$(echo "$restart2" | grep "skipped (--resume)" | sed 's/^frame \([0-9]*\):.*/\1/' | sort -n | tr '\n' ' ')
rendered2=$(echo "$restart2" | grep "^frame [0-9]*: .* -> " | sed 's/^frame \([0-9]*\):.*/\1/' | sort -n | tr '\n' ' ')
[ "$skipped2" = "$done_before2" ] || fail "the requeued task 2 skipped '$skipped2', its killed run had finished '$done_before2'"
expected2=""
for f in 7 8 9; do echo " $done_before2 " | grep -q " $f " || expected2="$expected2$f "; done
[ "$rendered2" = "$expected2" ] || fail "the requeued task 2 rendered '$rendered2', expected '$expected2'"
echo "task 2: killed run finished '$done_before2', the requeued run skipped '$skipped2' and rendered '$rendered2'"

# bit-identical to the same frames rendered locally in one process
"$nimbus" render "$scene" --frames 1-12 "${size[@]}" -o "$T/local/f.####.exr" -q ||
    fail "the local render failed"
for f in $(seq 1 12); do
    a=$(printf "%s/out/f.%04d.exr" "$T" "$f")
    b=$(printf "%s/local/f.%04d.exr" "$T" "$f")
    idiff -fail 0 -warn 0 "$a" "$b" >"$T/idiff.txt" 2>&1 || fail "frame $f differs from the local render: $(cat "$T/idiff.txt")"
done
echo "12 frames from Slurm bit-identical to the local render (idiff -fail 0)"
echo "farm run: submit to last frame $(python3 -c "print(round($finished - $up, 1))") s; whole test $(python3 -c "import time; print(round(time.time() - $started, 1))") s"
echo "PASS"
exit 0
