#!/usr/bin/env bash
# A real single-node Slurm cluster runs README's Slurm recipe (deploy/slurm/submit.sh) on
# glossy-room at draft: the merged bundle must equal a whole bake byte for byte, and a unit
# cancelled with `scancel` mid-run, resubmitted, must leave the finished units' shards alone.
# The cluster lives in a temporary folder (munge key and socket, slurm.conf, state, logs): munged,
# slurmctld and slurmd run as root and are stopped on exit; the one node has this machine's CPUs.
# A job that can never start (squeue reason PartitionConfig: it asks more than the node has)
# fails the run at once, and jobs still queued after GLINT_SLURM_TIMEOUT seconds (default 300)
# fail it too, each printed with its squeue reason.
# usage: .ci/slurm.sh BIN_DIR
set -euo pipefail
bin=$(cd "$1" && pwd)
cd "$(dirname "$0")/.."
repo=$PWD

as_root() { if [ "$(id -u)" = 0 ]; then "$@"; else sudo "$@"; fi; }

if ! command -v slurmctld >/dev/null || ! command -v slurmd >/dev/null || ! command -v munged >/dev/null; then
  export DEBIAN_FRONTEND=noninteractive
  as_root apt-get update -q
  as_root apt-get install -y -q slurm-wlm munge
fi

timeout=${GLINT_SLURM_TIMEOUT:-300}
started=$(date +%s)
tmp=$(mktemp -d)
chmod 755 "$tmp"
cleanup() {
  local rc=$?
  for pid in "$tmp"/slurmd.pid "$tmp"/slurmctld.pid "$tmp"/munged.pid; do
    [ -s "$pid" ] && as_root kill "$(cat "$pid")" 2>/dev/null || true
  done
  sleep 1
  if [ "$rc" != 0 ]; then
    for log in slurmctld.log slurmd.log; do
      [ -s "$tmp/$log" ] && { echo "--- $log (last lines)" >&2; tail -n 20 "$tmp/$log" >&2; }
    done
  fi
  as_root rm -rf "$tmp"
}
trap cleanup EXIT

# munge: its own key and socket, so a munged already on the machine is left alone.
mkdir -p "$tmp/munge" "$tmp/state" "$tmp/spool"
as_root mungekey --create --keyfile="$tmp/munge/munge.key"
as_root munged --force --key-file="$tmp/munge/munge.key" --socket="$tmp/munge/socket" \
  --pid-file="$tmp/munged.pid" --log-file="$tmp/munged.log" --seed-file="$tmp/munge/seed"

host=$(hostname -s)
cpus=$(nproc)
mem_mb=$(( $(awk '/^MemTotal:/ { print $2 }' /proc/meminfo) * 9 / 10 / 1024 ))
export SLURM_CONF="$tmp/slurm.conf"
cat >"$SLURM_CONF" <<EOF
ClusterName=glint-ci
SlurmctldHost=$host(127.0.0.1)
SlurmUser=root
SlurmctldPort=${GLINT_SLURMCTLD_PORT:-6817}
SlurmdPort=${GLINT_SLURMD_PORT:-6818}
AuthType=auth/munge
AuthInfo=socket=$tmp/munge/socket
CredType=cred/munge
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
SchedulerType=sched/backfill
SelectType=select/cons_tres
SelectTypeParameters=CR_CPU_Memory
MpiDefault=none
ReturnToService=2
StateSaveLocation=$tmp/state
SlurmdSpoolDir=$tmp/spool
SlurmctldPidFile=$tmp/slurmctld.pid
SlurmdPidFile=$tmp/slurmd.pid
SlurmctldLogFile=$tmp/slurmctld.log
SlurmdLogFile=$tmp/slurmd.log
AccountingStorageType=accounting_storage/none
JobAcctGatherType=jobacct_gather/none
JobCompType=jobcomp/none
NodeName=$host NodeAddr=127.0.0.1 CPUs=$cpus RealMemory=$mem_mb State=UNKNOWN
PartitionName=ci Nodes=$host Default=YES MaxTime=INFINITE State=UP
EOF
as_root slurmctld -i
as_root slurmd
for _ in $(seq 30); do
  sinfo -h -N -o '%T' 2>/dev/null | grep -q '^idle' && break
  sleep 1
done
sinfo -h -N -o '%T' | grep -q '^idle' || { echo "slurm: the node did not come up idle: $(sinfo -N 2>&1)" >&2; exit 1; }
echo "slurm: node $host up ($cpus CPUs, $mem_mb MB), $(( $(date +%s) - started )) s"

export PATH="$bin:$PATH"
scene=$repo/scenes/glossy-room/scene.json
work=$tmp/work
mkdir -p "$work"
cd "$work"

# Waits until the queue is empty. Fails at once on a job that can never start (no node is that
# large, or a dependency failed), else after GLINT_SLURM_TIMEOUT seconds, naming the jobs left.
wait_jobs() {
  local deadline=$(( $(date +%s) + timeout )) stuck
  while [ -n "$(squeue -h -o %i)" ]; do
    stuck=$(squeue -h -t PENDING -o '%r' | grep -E -m1 'PartitionConfig|PartitionNodeLimit|DependencyNeverSatisfied|BadConstraints' || true)
    if [ -n "$stuck" ] || [ "$(date +%s)" -ge "$deadline" ]; then
      if [ -n "$stuck" ]; then
        echo "slurm: a job can never start (squeue reason $stuck); the queue:" >&2
      else
        echo "slurm: jobs still queued after ${timeout} s; the queue:" >&2
      fi
      squeue -o '%.12i %.12j %.9T %.6C %.8m %r' >&2
      exit 1
    fi
    sleep 2
  done
}

# Fails unless every log of the run is free of errors and the merge wrote MERGED.
check_run() {
  local log
  for log in glint-unit-*.log glint-merge-*.log; do
    if grep -q '^error' "$log"; then echo "slurm: $log:" >&2; cat "$log" >&2; exit 1; fi
  done
  [ -e "$1/manifest.json" ] || { echo "slurm: the merge job wrote no $1" >&2; cat glint-merge-*.log >&2; exit 1; }
  glint-bundle verify "$1" >/dev/null
}

# Fails unless every unit's log says glint ran N threads, the CPUs Slurm granted.
check_threads() {
  local n=$1 log
  for log in glint-unit-*.log; do
    grep -q "threads: $n (SLURM_CPUS_PER_TASK)" "$log" \
      || { echo "slurm: $log: glint did not run the $n CPUs granted:" >&2; cat "$log" >&2; exit 1; }
  done
}

# README's recipe as written: each unit gets its default 2 CPUs.
t0=$(date +%s)
bash "$repo/deploy/slurm/submit.sh" "$scene" "$work/shards" "$work/merged.glint" draft
wait_jobs
check_run merged.glint
check_threads 2
echo "slurm: submit.sh to merged bundle $(( $(date +%s) - t0 )) s"
t0=$(date +%s)
glint-bake "$scene" --quality draft --bundle whole.glint >/dev/null 2>whole.log
echo "slurm: whole draft bake $(( $(date +%s) - t0 )) s"
python3 "$repo/.ci/same-assets.py" whole.glint/manifest.json merged.glint/manifest.json \
  "slurm: glossy-room baked by Slurm job arrays and merged"

# Resubmission: cancel the slowest unit mid-run; resubmitted, only it bakes, and the finished
# units' shards keep every file's inode and mtime. 1 CPU a unit (first by GLINT_CPUS, then by an
# sbatch option after `--`, which must win over submit.sh's own) lets two units share the node.
rm -rf shards merged.glint glint-*.log
slow=radiance.MirrorPanel
idx=$(( $(glint-bake "$scene" --quality draft --plan --wave 2 | grep -n -x "$slow" | cut -d: -f1) - 1 ))
out=$(GLINT_CPUS=1 bash "$repo/deploy/slurm/submit.sh" "$scene" "$work/shards" "$work/merged.glint" draft)
echo "$out"
wave2=$(echo "$out" | sed -n 's/^wave 2: .* job \([0-9]*\).*/\1/p')
merge=$(echo "$out" | sed -n 's/^merge: job \([0-9]*\).*/\1/p')
deadline=$(( $(date +%s) + timeout ))
until [ -n "$(squeue -h -t RUNNING -j "${wave2}_$idx" 2>/dev/null)" ]; do
  [ "$(date +%s)" -lt "$deadline" ] || { echo "slurm: $slow (job ${wave2}_$idx) never ran:" >&2; squeue >&2; exit 1; }
  sleep 1
done
sleep 5
scancel "${wave2}_$idx"
sleep 2
scancel "$merge"
wait_jobs
if [ -e "shards/$slow.glint/unit.json" ]; then
  echo "slurm: $slow finished before it was cancelled; nothing was interrupted" >&2
  exit 1
fi
snapshot() { find shards -name .lock -prune -o -type f ! -path "shards/$slow.glint/*" -printf '%i %T@ %p\n' | sort -k3; }
snapshot >before.txt
units=$(glint-bake "$scene" --quality draft --plan | awk 'NR > 2 { print $1 }' | wc -l)
[ "$(grep -c '/unit.json$' before.txt)" = $((units - 1)) ] \
  || { echo "slurm: expected $((units - 1)) finished units before resubmitting:" >&2; cat before.txt >&2; exit 1; }
rm -f glint-*.log
t0=$(date +%s)
bash "$repo/deploy/slurm/submit.sh" "$scene" "$work/shards" "$work/merged.glint" draft -- --cpus-per-task=1
wait_jobs
check_run merged.glint
check_threads 1
snapshot >after.txt
diff before.txt after.txt >&2 || { echo "slurm: resubmitting rewrote finished units' shards" >&2; exit 1; }
fresh=$(grep -L 'up to date' glint-unit-*.log | xargs -r grep -h -o 'unit [a-zA-Z0-9_.]*' | sort -u | tr '\n' ' ')
[ "$fresh" = "unit $slow " ] || { echo "slurm: resubmitting baked '$fresh', expected only $slow" >&2; exit 1; }
python3 "$repo/.ci/same-assets.py" whole.glint/manifest.json merged.glint/manifest.json \
  "slurm: $slow cancelled mid-run and resubmitted ($(( $(date +%s) - t0 )) s), $((units - 1)) finished units left alone"
echo "slurm: done in $(( $(date +%s) - started )) s"
