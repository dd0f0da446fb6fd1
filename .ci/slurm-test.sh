#!/usr/bin/env bash
# A sharded sweep through a real single-node Slurm on localhost: `formica slurm --submit` writes
# and submits a 2-task job array, each task runs one shard of experiments/smoke.toml into its own
# store, `formica merge` joins them, and the merged rows must equal a direct run's (wall-clock
# times aside).
#
# Installs Debian's slurmctld, slurmd, slurm-client and munge if missing (needs root), starts
# munged, slurmctld and slurmd by hand (no systemd) with a minimal slurm.conf in a temporary
# folder, and stops exactly the daemons it started. Usage: .ci/slurm-test.sh [path/to/formica]
set -euo pipefail
cd "$(dirname "$0")/.."
ROOT=$(pwd)
FORMICA=${1:-$ROOT/target/release/formica}
[ -x "$FORMICA" ] || { echo "slurm-test: $FORMICA not built" >&2; exit 1; }

need_install=0
for c in slurmctld slurmd sbatch squeue munged; do
    command -v "$c" >/dev/null 2>&1 || [ -x "/usr/sbin/$c" ] || need_install=1
done
if [ "$need_install" = 1 ]; then
    if [ "$(id -u)" != 0 ]; then
        echo "slurm-test: Slurm is not installed and this is not root" >&2
        exit 1
    fi
    echo "slurm-test: installing slurmctld slurmd slurm-client munge"
    export DEBIAN_FRONTEND=noninteractive
    # Keep the packages from starting their services (this script starts its own).
    made_policy=0
    if [ ! -e /usr/sbin/policy-rc.d ]; then
        printf '#!/bin/sh\nexit 101\n' > /usr/sbin/policy-rc.d
        chmod 755 /usr/sbin/policy-rc.d
        made_policy=1
    fi
    apt-get update -qq
    apt-get install -y -qq --no-install-recommends slurmctld slurmd slurm-client munge >/dev/null
    if [ "$made_policy" = 1 ]; then rm -f /usr/sbin/policy-rc.d; fi
fi
export PATH="$PATH:/usr/sbin:/sbin"

WORK=$(mktemp -d -t formica-slurm-XXXXXX)
chmod 755 "$WORK"
PIDS=()
cleanup() {
    set +e
    # Stop only what this script started (newest first), and reap it.
    for ((i = ${#PIDS[@]} - 1; i >= 0; i--)); do
        kill "${PIDS[$i]}" 2>/dev/null
        wait "${PIDS[$i]}" 2>/dev/null
    done
    rm -rf "$WORK"
}
trap cleanup EXIT

fail() {
    echo "slurm-test: FAILED: $*" >&2
    for f in slurmctld.log slurmd.log munged.log slurmctld.out slurmd.out munged.out; do
        [ -f "$WORK/$f" ] && { echo "--- $f" >&2; tail -n 30 "$WORK/$f" >&2; }
    done
    for f in "$WORK/sh ards"/slurm-*.out; do
        [ -f "$f" ] && { echo "--- $f" >&2; cat "$f" >&2; }
    done
    exit 1
}

# munge: its own key and socket in $WORK, so a system munged (if any) is left alone.
mkdir -p "$WORK/munge"
KEY=$WORK/munge/munge.key
dd if=/dev/urandom of="$KEY" bs=1024 count=1 status=none
chmod 700 "$WORK/munge"
chmod 400 "$KEY"
SOCKET=$WORK/munge/munge.socket
# The daemons run in the foreground as children of this script, so it can stop and reap them.
munged --foreground --force --key-file="$KEY" --socket="$SOCKET" --pid-file="$WORK/munged.pid" \
    --log-file="$WORK/munged.log" --seed-file="$WORK/munge/munged.seed" >"$WORK/munged.out" 2>&1 &
PIDS+=($!)
for _ in $(seq 1 50); do
    [ -S "$SOCKET" ] && break
    sleep 0.2
done
[ -S "$SOCKET" ] || fail "munged did not start"

HOST=$(hostname -s)
CPUS=2
cat > "$WORK/slurm.conf" <<EOF
ClusterName=formica-ci
SlurmctldHost=$HOST(127.0.0.1)
SlurmctldPort=16817
SlurmdPort=16818
AuthType=auth/munge
AuthInfo=socket=$SOCKET
CredType=cred/munge
SlurmUser=root
SlurmdUser=root
StateSaveLocation=$WORK/state
SlurmdSpoolDir=$WORK/spool
SlurmctldPidFile=$WORK/slurmctld.pid
SlurmdPidFile=$WORK/slurmd.pid
SlurmctldLogFile=$WORK/slurmctld.log
SlurmdLogFile=$WORK/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
MpiDefault=none
SchedulerType=sched/builtin
SelectType=select/cons_tres
SelectTypeParameters=CR_CPU
ReturnToService=2
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
SlurmctldTimeout=30
SlurmdTimeout=30
NodeName=$HOST NodeAddr=127.0.0.1 CPUs=$CPUS RealMemory=500 State=UNKNOWN
PartitionName=ci Nodes=$HOST Default=YES MaxTime=INFINITE State=UP
EOF
mkdir -p "$WORK/state" "$WORK/spool"
export SLURM_CONF=$WORK/slurm.conf

slurmctld -D -i -f "$SLURM_CONF" >"$WORK/slurmctld.out" 2>&1 &
PIDS+=($!)
slurmd -D -f "$SLURM_CONF" >"$WORK/slurmd.out" 2>&1 &
PIDS+=($!)

# Wait (bounded) for the node to be idle.
for _ in $(seq 1 60); do
    state=$(sinfo -h -N -o '%T' 2>/dev/null | head -n 1 || true)
    [ "$state" = idle ] && break
    sleep 1
done
[ "$state" = idle ] || fail "the node is not idle (state: ${state:-none})"

SWEEP=$ROOT/experiments/smoke.toml
"$FORMICA" slurm "$SWEEP" --array 2 --cpus 1 --time 00:10:00 --db-dir "$WORK/sh ards" \
    --script "$WORK/smoke.slurm" --submit > "$WORK/submit.out" || fail "formica slurm --submit"
cat "$WORK/submit.out"
JOB=$(sed -n 's/^submitted job \([0-9]*\).*/\1/p' "$WORK/submit.out")
[ -n "$JOB" ] || fail "no job id"

# Wait (bounded) for the array to leave the queue.
for _ in $(seq 1 240); do
    [ -z "$(squeue -h -j "$JOB" 2>/dev/null)" ] && break
    sleep 1
done
[ -z "$(squeue -h -j "$JOB" 2>/dev/null)" ] || fail "job $JOB still queued after 240 s"

# The shards' folder has a space in its name: the #SBATCH --output line must hold it whole.
ls "$WORK/sh ards"/shard-0.db "$WORK/sh ards"/shard-1.db >/dev/null || fail "missing shard stores"
ls "$WORK/sh ards"/slurm-*.out >/dev/null || fail "no slurm-*.out in the shards' folder"
"$FORMICA" merge "$WORK/all.db" "$WORK/sh ards"/shard-0.db "$WORK/sh ards"/shard-1.db
"$FORMICA" sweep "$SWEEP" --db "$WORK/direct.db" --quiet >/dev/null
strip() { "$FORMICA" export "$1" --csv - | sed 's/,[^,]*$//'; }
rows=$(strip "$WORK/all.db" | tail -n +2 | wc -l)
want=$("$FORMICA" sweep "$SWEEP" --dry-run | tail -n 1 | sed -n 's/.*= \([0-9]*\) trials.*/\1/p')
[ "$rows" = "$want" ] || fail "merged store has $rows rows, expected $want"
[ "$(strip "$WORK/all.db")" = "$(strip "$WORK/direct.db")" ] || fail "merged rows differ from a direct run"
echo "slurm-test: OK: $rows trials over 2 Slurm array tasks, merged rows = a direct run's"
