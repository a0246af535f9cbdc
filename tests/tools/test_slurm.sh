#!/usr/bin/env bash
# make test-slurm: `slamlab slurm` on a real Slurm. Starts a one-node cluster on this machine
# (munged, slurmctld and slurmd from Debian's slurm-wlm and munge, installed when missing, with a
# minimal slurm.conf in a temporary folder: proctrack/linuxproc, task/none, this machine's CPUs
# and memory), then:
#   1. submits the runs of SPECS as a job array of TASKS shards plus the dependent assembling job,
#      and kills one task (SIGKILL) while it computes: the assembling job can then never start;
#   2. resubmits the same way (the cache makes it idempotent): the killed shard computes what it
#      had left, the other shards nothing, and the assembling job writes results and reports;
#   3. compares them byte for byte with a single-process `slamlab run` + `slamlab report`.
# Every daemon it started is stopped by its pid on every exit path. Bounded by TIMEOUT seconds
# per wait.
set -euo pipefail
cd "$(dirname "$0")/../.."
. tests/tools/apt_install.sh

BIN=${BIN:-${CARGO_TARGET_DIR:-$PWD/target}/release/slamlab}
SPECS=(${SPECS:-experiments/smoke.toml experiments/ft-p0.toml})
TASKS=${TASKS:-4}
KILL_TASK=${KILL_TASK:-2}
TIMEOUT=${TIMEOUT:-1800}

need=()
command -v slurmctld >/dev/null || need+=(slurm-wlm)
command -v munged >/dev/null || need+=(munge)
[ ${#need[@]} -eq 0 ] || apt_install "test-slurm (a one-node Slurm cluster)" "${need[@]}"
[ -x "$BIN" ] || { echo "test-slurm: $BIN is missing (make build)" >&2; exit 1; }

work=$(mktemp -d /tmp/slamlab-slurm.XXXXXX)
chmod 755 "$work"
pids=()
status=1
cleanup() {
  local pid
  for pid in "${pids[@]}"; do kill "$pid" 2>/dev/null || true; done
  for pid in "${pids[@]}"; do
    for _ in $(seq 50); do kill -0 "$pid" 2>/dev/null || break; sleep 0.2; done
    kill -9 "$pid" 2>/dev/null || true
  done
  if [ "$status" -ne 0 ]; then
    echo "test-slurm: FAILED; the cluster's logs:" >&2
    tail -n 30 "$work"/*.log "$work"/*.out "$work"/slurm/logs/* 2>/dev/null >&2 || true
  fi
  rm -rf "$work"
}
trap cleanup EXIT
trap 'exit 130' INT TERM

say() { echo "test-slurm: $*" >&2; }
# wait_for SECONDS WHAT COMMAND...: polls COMMAND every second until it succeeds
wait_for() {
  local limit=$1 what=$2; shift 2
  local start=$SECONDS
  until "$@"; do
    if [ $((SECONDS - start)) -ge "$limit" ]; then say "timed out after ${limit} s waiting for $what"; return 1; fi
    sleep 1
  done
}

# --- a one-node cluster -------------------------------------------------------------------------
host=$(hostname -s)
cpus=$(nproc)
mem_mb=$(awk '/MemTotal/ {print int($2 / 1024 * 0.9)}' /proc/meminfo)
# free ports (another Slurm on this machine keeps its own)
port=$(python3 -c 'import socket; s=socket.socket(); s.bind(("127.0.0.1", 0)); print(s.getsockname()[1])')
mkdir -p "$work/munge" "$work/state" "$work/spool"
chmod 700 "$work/munge"
head -c 1024 /dev/urandom > "$work/munge/munge.key"
chmod 400 "$work/munge/munge.key"
munged --foreground --force --key-file="$work/munge/munge.key" --socket="$work/munge/munge.socket" \
  --pid-file="$work/munge/munged.pid" --log-file="$work/munged.log" --seed-file="$work/munge/munged.seed" \
  >"$work/munged.out" 2>&1 &
pids+=($!)
wait_for 30 munged test -S "$work/munge/munge.socket"

export SLURM_CONF=$work/slurm.conf
cat > "$SLURM_CONF" <<CONF
ClusterName=slamlabtest
SlurmctldHost=$host
SlurmctldPort=$port
SlurmdPort=$((port + 1))
AuthType=auth/munge
AuthInfo=socket=$work/munge/munge.socket
CredType=cred/munge
SlurmUser=root
SlurmdUser=root
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
SelectType=select/cons_tres
SelectTypeParameters=CR_CPU
SchedulerType=sched/backfill
MpiDefault=none
ReturnToService=2
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
JobCompType=jobcomp/none
MailProg=/bin/true
StateSaveLocation=$work/state
SlurmdSpoolDir=$work/spool
SlurmctldPidFile=$work/slurmctld.pid
SlurmdPidFile=$work/slurmd.pid
SlurmctldLogFile=$work/slurmctld.log
SlurmdLogFile=$work/slurmd.log
NodeName=$host CPUs=$cpus RealMemory=$mem_mb State=UNKNOWN
PartitionName=test Nodes=$host Default=YES MaxTime=INFINITE State=UP
CONF
slurmctld -D -i -f "$SLURM_CONF" >"$work/slurmctld.out" 2>&1 &
pids+=($!)
slurmd -D -f "$SLURM_CONF" >"$work/slurmd.out" 2>&1 &
pids+=($!)
node_up() { sinfo -h -n "$host" -o %T 2>/dev/null | grep -Eq '^(idle|mixed|allocated)'; }
wait_for 60 "the node to come up" node_up
say "a one-node cluster is up ($host: $cpus CPUs, $mem_mb MB; Slurm $(sinfo -V | awk '{print $2}'))"

# --- the single-process reference ---------------------------------------------------------------
say "single-process run of ${SPECS[*]}"
"$BIN" run --quiet --results "$work/single/results" --cache "$work/single/cache" "${SPECS[@]}"
"$BIN" report --results "$work/single/results" --out "$work/single/reports" 2>/dev/null

# --- the cluster run ----------------------------------------------------------------------------
cluster=(--results "$work/cluster/results" --cache "$work/cluster/cache" --reports "$work/cluster/reports"
  --out "$work/slurm" --tasks "$TASKS" --cpus 1 --mem 1G --time 30)
state() { squeue -h -j "$1" -o %T 2>/dev/null | head -n 1; }
gone() { [ -z "$(squeue -h -j "$1" 2>/dev/null)" ]; }

say "round 1: submit $TASKS shards and kill task $KILL_TASK while it computes"
ids=$("$BIN" slurm "${SPECS[@]}" "${cluster[@]}" --submit)
read -r runs1 assemble1 <<<"$ids"
running() { [ "$(state "${runs1}_$KILL_TASK")" = RUNNING ]; }
wait_for "$TIMEOUT" "task $KILL_TASK to start" running
sleep 1  # early enough that even a fast machine has not finished the shard
scancel --signal=KILL --full "${runs1}_$KILL_TASK"
# the other tasks finish; the assembling job's dependency can now never be met
others_done() { ! squeue -h -j "$runs1" -o %i 2>/dev/null | grep -q .; }
wait_for "$TIMEOUT" "round 1's other tasks" others_done
if [ -n "$(ls "$work/cluster/results" 2>/dev/null)" ]; then say "round 1 wrote results although a task was killed"; exit 1; fi
scancel "$assemble1" 2>/dev/null || true
wait_for 60 "the cancelled assembling job to leave the queue" gone "$assemble1"

say "round 2: resubmit the same way"
ids=$("$BIN" slurm "${SPECS[@]}" "${cluster[@]}" --submit)
read -r runs2 assemble2 <<<"$ids"
wait_for "$TIMEOUT" "round 2" gone "$assemble2"
wait_for 60 "round 2's tasks" gone "$runs2"

# what each task of round 2 computed: the killed one its leftovers, the others nothing
for i in $(seq "$TASKS"); do
  log="$work/slurm/logs/runs-${runs2}_$i.out"
  line=$(grep -h "^shard $i/$TASKS:" "$log" || true)
  [ -n "$line" ] || { say "task $i of round 2 printed no summary:"; cat "$log" >&2; exit 1; }
  computed=$(sed -E 's/.*: ([0-9]+) computed.*/\1/' <<<"$line")
  say "round 2, $line"
  if [ "$i" -eq "$KILL_TASK" ] && [ "$computed" -eq 0 ]; then say "task $KILL_TASK had finished before it was killed: nothing was resumed (use larger SPECS)"; exit 1; fi
  if [ "$i" -ne "$KILL_TASK" ] && [ "$computed" -ne 0 ]; then say "task $i recomputed runs that round 1 had cached"; exit 1; fi
done
assembled="$work/slurm/logs/assemble-$assemble2.out"
if grep -Eq "\(([1-9][0-9]*) computed" "$assembled"; then say "the assembling job computed runs the shards should have:"; cat "$assembled" >&2; exit 1; fi

# --- byte for byte ------------------------------------------------------------------------------
# timings.* hold wall times (machine- and load-dependent by design), and checksums.b3 their hash;
# everything else must match
for f in "$work"/single/results/*/checksums.b3 "$work"/cluster/results/*/checksums.b3; do
  grep -v 'timings\.' "$f" > "$f.without-timings"
done
if ! diff -r -x 'timings.*' -x checksums.b3 "$work/single/results" "$work/cluster/results" >&2; then say "the results differ"; exit 1; fi
if ! diff -r "$work/single/reports" "$work/cluster/reports" >&2; then say "the reports differ"; exit 1; fi
say "OK: $(find "$work/cluster/results" -name runs.parquet | wc -l) studies from $TASKS shards (one killed and resumed) are byte-identical to a single-process run, results and reports"
status=0
