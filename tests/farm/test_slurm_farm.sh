#!/usr/bin/env bash
# A real Slurm in a temp folder: munged, slurmctld and slurmd on this machine (one node, 2 CPUs,
# no systemd, free ports), a 12-frame render submitted as an array job of 4 chunked tasks (3 frames
# each) through examples/farm/submit.sh. One task's nimbus is SIGKILLed mid-frame, another is
# cancelled mid-frame (scancel: SIGTERM); both are requeued (scontrol requeue) and their reruns
# must skip the frame they finished and render exactly the missing ones (--resume). Every frame must be a complete EXR of the right size, bit-identical
# to the same frames rendered locally, with no temp file left. Daemons are stopped on any exit.
#   test_slurm_farm.sh NIMBUS_BINARY SOURCE_DIR
# Exit 0 pass, 1 fail, 77 skip (Slurm or munge not installed, or the daemons cannot start here).
set -uo pipefail
nimbus=$(readlink -f "$1")
src=$(readlink -f "$2")
SKIP=77
say() { echo "farm-test: $*"; }
fail() { say "FAIL: $*"; exit 1; }
skip() { say "SKIP: $*"; exit $SKIP; }

for b in munged slurmctld slurmd sbatch scontrol scancel squeue sacct idiff oiiotool python3; do
  command -v "$b" >/dev/null 2>&1 || [ -x "/usr/sbin/$b" ] ||
    skip "$b is not installed (examples/install_deps.sh installs slurm-wlm, munge, openimageio-tools)"
done
export PATH="$PATH:/usr/sbin"

t0=$(date +%s.%N)
T=$(mktemp -d /tmp/nimbus-farm.XXXXXX)
chmod 755 "$T"
pids=()
cleanup() {
  local rc=$?
  if [ -f "$T/slurm.conf" ]; then
    if [ -n "${job:-}" ]; then
      SLURM_CONF="$T/slurm.conf" timeout 10 scancel "$job" >/dev/null 2>&1 || true
      for _ in $(seq 30); do
        [ -z "$(SLURM_CONF="$T/slurm.conf" timeout 5 squeue -h -j "$job" 2>/dev/null)" ] && break
        sleep 0.5
      done
    fi
  fi
  for p in "${pids[@]}"; do kill -TERM "$p" 2>/dev/null || true; done
  for p in "${pids[@]}"; do
    for _ in $(seq 50); do kill -0 "$p" 2>/dev/null || break; sleep 0.1; done
    kill -KILL "$p" 2>/dev/null || true
    wait "$p" 2>/dev/null || true
  done
  # a backstop: a nimbus of this test's job still running (its command line names $T)
  for p in $(pgrep -f -- "render .*$T/out/" 2>/dev/null); do kill -KILL "$p" 2>/dev/null || true; done
  if [ $rc -ne 0 ] && [ $rc -ne $SKIP ]; then
    for f in "$T"/log/*.log "$T"/*.log; do
      [ -f "$f" ] && { echo "---- $f (tail)"; tail -n 25 "$f"; }
    done
  fi
  [ -n "${NIMBUS_FARM_KEEP:-}" ] && say "kept $T" || rm -rf "$T"
  exit $rc
}
trap cleanup EXIT
trap 'exit 1' INT TERM HUP

# free TCP ports for slurmctld and slurmd
read -r pctl pd < <(python3 -c '
import socket
s=[socket.socket() for _ in range(2)]
for x in s: x.bind(("127.0.0.1",0))
print(*[x.getsockname()[1] for x in s])')
host=$(hostname -s)
user=$(id -un)
mkdir -p "$T/state" "$T/spool" "$T/log" "$T/out" "$T/ref" "$T/munge"
chmod 700 "$T/munge"

# munge: its own key, socket and logs
dd if=/dev/urandom of="$T/munge/key" bs=1024 count=1 status=none
chmod 400 "$T/munge/key"
munged -F --key-file="$T/munge/key" --socket="$T/munge/sock" --pid-file="$T/munge/pid" \
  --log-file="$T/munge/log" --seed-file="$T/munge/seed" --force >"$T/munged.log" 2>&1 &
pids+=($!)
for _ in $(seq 50); do [ -S "$T/munge/sock" ] && break; sleep 0.1; done
[ -S "$T/munge/sock" ] || skip "munged did not start: $(tail -n 3 "$T/munged.log" "$T/munge/log" 2>/dev/null | tr '\n' ' ')"

cat >"$T/slurm.conf" <<CONF
ClusterName=nimbusfarmtest
SlurmctldHost=$host(127.0.0.1)
SlurmctldPort=$pctl
SlurmdPort=$pd
SlurmUser=$user
SlurmdUser=$user
AuthType=auth/munge
CredType=cred/munge
AuthInfo=socket=$T/munge/sock
StateSaveLocation=$T/state
SlurmdSpoolDir=$T/spool
SlurmctldPidFile=$T/slurmctld.pid
SlurmdPidFile=$T/slurmd.pid
SlurmctldLogFile=$T/slurmctld.log
SlurmdLogFile=$T/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
SwitchType=switch/none
MpiDefault=none
SelectType=select/cons_tres
SelectTypeParameters=CR_CPU
SchedulerType=sched/builtin
AccountingStorageType=accounting_storage/none
JobAcctGatherType=jobacct_gather/none
JobCompType=jobcomp/none
ReturnToService=2
KillWait=5
MinJobAge=600
SlurmctldTimeout=30
SlurmdTimeout=30
NodeName=$host NodeAddr=127.0.0.1 CPUs=2 RealMemory=1000 State=UNKNOWN
PartitionName=farm Nodes=$host Default=YES MaxTime=30 State=UP
CONF
export SLURM_CONF="$T/slurm.conf"
touch "$T/plugstack.conf"   # none: Debian's /etc/slurm/plugstack.conf.d is not ours
echo "PlugStackConfig=$T/plugstack.conf" >>"$T/slurm.conf"

slurmctld -D -c -f "$SLURM_CONF" >>"$T/slurmctld.out" 2>&1 &
pids+=($!)
slurmd -D -f "$SLURM_CONF" -N "$host" >>"$T/slurmd.out" 2>&1 &
pids+=($!)
ready=0
for _ in $(seq 100); do
  if timeout 5 sinfo -h -N -o '%t' 2>/dev/null | grep -qE '^(idle|mix|alloc)'; then ready=1; break; fi
  for p in "${pids[@]}"; do kill -0 "$p" 2>/dev/null || break 2; done
  sleep 0.2
done
if [ $ready -ne 1 ]; then
  why=$(cat "$T/slurmctld.out" "$T/slurmd.out" 2>/dev/null; tail -n 5 "$T/slurmctld.log" "$T/slurmd.log" 2>/dev/null)
  skip "slurmctld/slurmd did not bring the node up within 20 s: $(echo "$why" | grep -iE 'error|fatal' | head -n 5 | tr '\n' ' ')"
fi
say "Slurm up (ports $pctl, $pd) after $(python3 -c "print(f'{$(date +%s.%N)-$t0:.1f}')") s"

scene="$src/examples/scenes/cumulus.toml"
size=(--set camera.width=96 --set camera.height=54)

# reference: the same 12 frames in one local process, all cores
"$nimbus" render "$scene" --frames 1-12 "${size[@]}" -q -o "$T/ref/f.####.exr" ||
  fail "local reference render failed"

# the array job: 4 tasks of 3 frames, 1 CPU each (2 at a time on this node)
sub=$(cd "$T/log" && NIMBUS="$nimbus" NIMBUS_THREADS=1 \
  SBATCH_OPTS="--output=$T/log/%A_%a.log --time=10" \
  timeout 30 "$src/examples/farm/submit.sh" "$scene" "$T/out/f.####.exr" 1 12 3 "${size[@]}") ||
  fail "sbatch failed: $sub"
job=$(echo "$sub" | grep -oE '[0-9]+$')
[ -n "$job" ] || fail "no job id in: $sub"
say "submitted job $job: $sub"

# Two interruptions, each mid-frame, each followed by a requeue of that array task:
#  task 1 (frames 4-6): its nimbus SIGKILLed during frame 5 (what the OOM killer or a crash does);
#  task 2 (frames 7-9): scancel during frame 8 (Slurm's SIGTERM, as for preemption or a user).
logof() { echo "$T/log/${job}_$1.log"; }
waitSecondFrame() { # task, its second frame
  local log deadline=$((SECONDS + 120))
  log=$(logof "$1")
  until grep -q "frame 2/3" "$log" 2>/dev/null; do
    [ $SECONDS -lt $deadline ] || fail "task $1 did not reach its second frame in 120 s"
    sleep 0.05
  done
  sleep 0.05
  ! grep -q "^frame $2: .* -> " "$log" || fail "task $1 finished frame $2 before the kill: frames too fast"
}
waitEnded() { # task
  local st deadline=$((SECONDS + 60))
  while st=$(timeout 5 squeue -h -j "${job}_$1" -o '%T' 2>/dev/null) && [ -n "$st" ]; do
    [ $SECONDS -lt $deadline ] || fail "task $1 still $st 60 s after the kill"
    sleep 0.2
  done
  timeout 5 scontrol -o show job "${job}_$1" | grep -oE 'JobState=[A-Z_]+|ExitCode=[0-9:]+' | tr '\n' ' '
}
# Requeue a task: back to pending. Slurm delays a requeued job by about two minutes; it is
# made eligible 3 s from now instead, not at once: slurmd refuses to launch a job whose
# credential is not newer (in whole seconds) than the revocation of its killed run's.
requeue() {
  timeout 10 scontrol requeue "${job}_$1" || fail "scontrol requeue ${job}_$1 failed"
  timeout 10 scontrol update JobId="${job}_$1" StartTime=now+3 ||
    fail "scontrol update StartTime failed"
}

waitSecondFrame 1 5
pid=$(pgrep -f -- "render $scene --frames 4-6 .*$T/out/") || fail "no nimbus process for task 1"
kill -KILL $pid
st=$(waitEnded 1)
say "task 1 SIGKILLed (pid $pid) during frame 5: $st"
[[ $st == *JobState=FAILED*ExitCode=0:9* ]] || fail "task 1 after SIGKILL: $st"
[ -e "$T/out/f.0004.exr" ] || fail "frame 4 (finished before the kill) is missing"
for f in 5 6; do [ ! -e "$T/out/f.000$f.exr" ] || fail "frame $f exists after a kill during frame 5"; done
# whatever else the kill left must not pass for a frame: hidden, and not ending in .exr
odd=$(find "$T/out" -mindepth 1 ! -name 'f.000[1-4].exr' \( ! -name '.*' -o -name '*.exr' \))
[ -z "$odd" ] || fail "the SIGKILL left files a compositor could take for frames: $odd"
requeue 1

waitSecondFrame 2 8
timeout 10 scancel "${job}_2" || fail "scancel ${job}_2 failed"
st=$(waitEnded 2)
say "task 2 cancelled (scancel) during frame 8: $st"
[[ $st == *JobState=CANCELLED* ]] || fail "task 2 after scancel: $st"
grep -q "nimbus: interrupted during frame 8; no output written for it" "$(logof 2)" ||
  fail "task 2 did not stop as an interruption (exit 130) during frame 8"
[ -e "$T/out/f.0007.exr" ] || fail "frame 7 (finished before scancel) is missing"
for f in 8 9; do [ ! -e "$T/out/f.000$f.exr" ] || fail "frame $f exists after scancel during frame 8"; done
requeue 2
say "requeued tasks 1 and 2"

# wait for all tasks (bounded)
deadline=$((SECONDS + 240))
while [ -n "$(timeout 5 squeue -h -j "$job" -o '%i' 2>/dev/null)" ]; do
  [ $SECONDS -lt $deadline ] || fail "job $job not finished within 240 s"
  sleep 0.5
done
for i in 0 1 2 3; do
  st=$(timeout 5 scontrol -o show job "${job}_$i" | grep -oE 'JobState=[A-Z_]+|ExitCode=[0-9:]+' | tr '\n' ' ')
  [[ $st == "JobState=COMPLETED ExitCode=0:0 " ]] || fail "task $i: $st"
done

# the requeued runs: the frame finished before the kill skipped, exactly the missing ones rendered
for spec in "1 4 5 6" "2 7 8 9"; do
  read -r i done1 m1 m2 <<<"$spec"
  log=$(logof "$i")
  grep -q "restart 1" "$log" || fail "no second run (SLURM_RESTART_COUNT=1) in task $i's log"
  grep -q "^frame $done1: .* exists, skipped (--resume)" "$log" || fail "task $i's rerun did not skip frame $done1"
  for f in $done1 $m1 $m2; do
    [ "$(grep -c "^frame $f: .* -> " "$log")" -eq 1 ] || fail "frame $f not rendered exactly once (task $i)"
  done
done

# every frame: a complete EXR of 96x54, bit-identical to the local render; no temp files
for f in $(seq -f '%04g' 1 12); do
  out="$T/out/f.$f.exr"
  [ -f "$out" ] || fail "frame $f missing"
  res=$(oiiotool --info "$out" 2>&1) || fail "frame $f does not open: $res"
  [[ $res == *"96 x   54"* || $res == *"96 x 54"* ]] || fail "frame $f has the wrong size: $res"
  idiff -fail 0 -warn 0 "$T/ref/f.$f.exr" "$out" >/dev/null ||
    fail "frame $f differs from the local render: $(idiff -fail 0 "$T/ref/f.$f.exr" "$out" | tail -n 3)"
done
extra=$(find "$T/out" -mindepth 1 ! -name 'f.[0-9][0-9][0-9][0-9].exr')
[ -z "$extra" ] || fail "files left beside the frames: $extra"
say "PASS: 12 frames, 4 tasks of 3, task 1 SIGKILLed and task 2 cancelled mid-frame, both requeued; bit-identical;" \
  "wall $(python3 -c "print(f'{$(date +%s.%N)-$t0:.1f}')") s"
exit 0
