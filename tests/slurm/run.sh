#!/usr/bin/env bash
# A real single-node Slurm (Debian's slurm-wlm and munge, no systemd, no cgroups) runs the
# documented batch script docs/slurm/study.sbatch as written, from the repository root,
# with a small study; its rows must be bit-identical to the unsharded study's. Then one
# task is resubmitted alone and must stay its own shard. Needs root; installs the packages
# when missing; stops every daemon it started.
#   tests/slurm/run.sh BINDIR   (BINDIR holds the fpkbench binary, e.g. target/release)
set -euo pipefail
cd "$(dirname "$0")/../.."
bindir=$(cd "$1" && pwd)
export PATH="$bindir:$PATH"
command -v fpkbench > /dev/null

if ! command -v slurmctld > /dev/null || ! command -v munged > /dev/null; then
  apt-get update -qq
  DEBIAN_FRONTEND=noninteractive apt-get install -y -qq slurm-wlm munge > /dev/null
fi

work=$(mktemp -d)
pids=()
cleanup() {
  scancel --user=root > /dev/null 2>&1 || true
  for p in "${pids[@]}"; do kill "$p" 2> /dev/null || true; done
  pkill -x slurmd 2> /dev/null || true
  pkill -x slurmctld 2> /dev/null || true
  pkill -x munged 2> /dev/null || true
  rm -rf "$work" fpk-study-*.log
}
trap cleanup EXIT

# munge: a fresh key, the daemon as its own user.
mkdir -p /etc/munge /var/lib/munge /var/log/munge /run/munge
dd if=/dev/urandom of=/etc/munge/munge.key bs=1024 count=1 status=none
chown -R munge:munge /etc/munge /var/lib/munge /var/log/munge /run/munge
chmod 0700 /etc/munge && chmod 0400 /etc/munge/munge.key
runuser -u munge -- /usr/sbin/munged
munge -n | unmunge > /dev/null

# slurm: one node, this machine's CPUs, no accounting, no cgroups.
cpus=$(nproc)
mem=$(($(awk '/MemTotal/ {print $2}' /proc/meminfo) / 1024 - 512))
mkdir -p /etc/slurm /var/spool/slurmctld /var/spool/slurmd /var/log/slurm
cat > /etc/slurm/slurm.conf <<CONF
ClusterName=fpkbench-ci
SlurmctldHost=localhost
SlurmUser=root
AuthType=auth/munge
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
StateSaveLocation=/var/spool/slurmctld
SlurmdSpoolDir=/var/spool/slurmd
SlurmctldPidFile=/run/slurmctld.pid
SlurmdPidFile=/run/slurmd.pid
SlurmctldLogFile=/var/log/slurm/slurmctld.log
SlurmdLogFile=/var/log/slurm/slurmd.log
ReturnToService=2
MpiDefault=none
NodeName=localhost CPUs=$cpus RealMemory=$mem State=UNKNOWN
PartitionName=ci Nodes=localhost Default=YES MaxTime=INFINITE State=UP
CONF
slurmctld -i
slurmd -N localhost
for _ in $(seq 60); do
  sinfo -h -o %t 2> /dev/null | grep -Eq '^(idle|mix|alloc)' && break
  sleep 1
done
sinfo -h -o '%P %t %c'

# The study: sdof_duffing, 2 record lengths x 3 seeds = 6 items, weak and increments.
study="$work/slurm-study.toml"
cat > "$study" <<TOML
scenario = "$PWD/scenarios/sdof_duffing.toml"
seeds = 3
seed = 7
record_lengths = [40.0, 80.0]
methods = ["weak", "increments"]
TOML
name=$(basename "$study" .toml)
export SCRATCH="$work/scratch"

# The documented script, as written, from the repository root.
sbatch --wait docs/slurm/study.sbatch "$study"
slurm_out="$SCRATCH/study-$name"
test -f "$slurm_out/summary.json" || { echo "slurm: no summary in $slurm_out"; exit 1; }
test "$(ls "$slurm_out"/items/*.jsonl | wc -l)" = 6

# The same study unsharded; merge refuses any row that differs between the two.
fpkbench study "$study" --out "$work/unsharded" > /dev/null
fpkbench study merge "$slurm_out" "$work/unsharded" --out "$work/merged" > /dev/null
cmp <(cat "$slurm_out"/items/*.jsonl | sed -E 's/"(simulate_s|identify_s|item_s)":[^,}]*//g' | grep -v complete) \
    <(cat "$work/unsharded"/items/*.jsonl | sed -E 's/"(simulate_s|identify_s|item_s)":[^,}]*//g' | grep -v complete)

# A task resubmitted alone: remove shard 1's items, resubmit --array=1; shard 1 of 4 is
# redone, and only it.
shard1=$(fpkbench study "$study" --shard 1/4 --out "$work/empty" --dry-run 2> /dev/null | awk '{print $1}')
for k in $shard1; do rm "$slurm_out/items/$k.jsonl"; done
before=$(ls "$slurm_out"/items | wc -l)
sbatch --wait --array=1 docs/slurm/study.sbatch "$study"
after=$(ls "$slurm_out"/items | wc -l)
test "$after" = 6 || { echo "slurm: $before items before the resubmission, $after after (want 6)"; exit 1; }
grep -h "shard 1/4" fpk-study-*_1.log > /dev/null
echo "slurm: the documented sbatch script ran as written; 6 items identical to the unsharded study; a resubmitted task stayed shard 1/4"
