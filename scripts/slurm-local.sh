#!/usr/bin/env bash
# A real single-node Slurm on this machine, used as a cluster user would use one: a 4-task job
# array renders the chunks of a frame (`glint render --chunk auto/4`), `glint merge` joins them,
# and the result must be the single-process render, byte for byte (docs/cluster.md).
#
# Starts munged, slurmctld and slurmd in a private temp dir (key, sockets, state, logs, config),
# stops each by its PID on exit and removes the dir. Needs root; installs the Debian packages
# slurm-wlm and munge when their daemons are missing. Run from the repo root:
#
#   scripts/slurm-local.sh                       # glint from target/release (built if missing)
#   GLINT=/path/to/glint scripts/slurm-local.sh
#
# SLURM_LOCAL_PORT (default 6817) is slurmctld's port, slurmd listens on the next one.
set -euo pipefail

say() { printf 'slurm-local: %s\n' "$*"; }
die() { printf 'slurm-local: error: %s\n' "$*" >&2; exit 1; }

[ -f Cargo.toml ] && [ -f scenes/cornell-box.toml ] || die "run from the glint repo root (no scenes/cornell-box.toml in $PWD)"
[ "$(id -u)" -eq 0 ] || die "needs root (starts munged, slurmctld and slurmd as root)"
repo=$PWD

# --- the glint binary ---------------------------------------------------------------------
if [ -z "${GLINT:-}" ]; then
    GLINT=target/release/glint
    if [ ! -x "$GLINT" ]; then
        say "building $GLINT (cargo build --release -p glint-cli)"
        cargo build --release -p glint-cli
    fi
fi
[ -x "$GLINT" ] || die "no glint binary at $GLINT"
GLINT=$(cd "$(dirname "$GLINT")" && pwd)/$(basename "$GLINT")

# --- packages -----------------------------------------------------------------------------
if ! command -v slurmctld >/dev/null || ! command -v slurmd >/dev/null || ! command -v munged >/dev/null; then
    say "installing slurm-wlm and munge"
    export DEBIAN_FRONTEND=noninteractive
    apt-get update -qq
    apt-get install -y --no-install-recommends slurm-wlm munge >/dev/null
fi
for tool in slurmctld slurmd munged sbatch sinfo scontrol scancel; do
    command -v "$tool" >/dev/null || die "$tool is not installed"
done

# --- the private dir, and cleanup ---------------------------------------------------------
tmp=$(mktemp -d /tmp/glint-slurm.XXXXXX)
chmod 700 "$tmp"
pids=()
jobid=
cleanup() {
    local status=$?
    set +e
    if [ -n "$jobid" ]; then
        scancel "$jobid" 2>/dev/null
        for _ in $(seq 100); do
            [ -z "$(squeue -h -j "$jobid" -o '%i' 2>/dev/null)" ] && break
            sleep 0.1
        done
    fi
    # Newest first: slurmd, slurmctld, munged.
    local i pid
    for ((i = ${#pids[@]} - 1; i >= 0; i--)); do
        pid=${pids[i]}
        kill -TERM "$pid" 2>/dev/null || continue
        for _ in $(seq 50); do
            kill -0 "$pid" 2>/dev/null || break
            sleep 0.1
        done
        kill -KILL "$pid" 2>/dev/null
        wait "$pid" 2>/dev/null
    done
    if [ "$status" -ne 0 ]; then
        for log in "$tmp"/work/slurm-*.out "$tmp"/*.log; do
            [ -f "$log" ] || continue
            printf -- '--- last lines of %s\n' "$(basename "$log")" >&2
            tail -n 15 "$log" >&2
        done
    fi
    rm -rf "$tmp"
    exit "$status"
}
trap cleanup EXIT
trap 'exit 130' INT
trap 'exit 143' TERM

# Wait up to $1 tenths of a second for the command after it to succeed.
wait_for() {
    local tenths=$1
    shift
    for _ in $(seq "$tenths"); do
        "$@" >/dev/null 2>&1 && return 0
        sleep 0.1
    done
    return 1
}

# A daemon that has exited is reported with its log.
check_alive() {
    kill -0 "$2" 2>/dev/null || die "$1 (pid $2) exited at start; see its log below"
}

# --- munge --------------------------------------------------------------------------------
key=$tmp/munge.key
if command -v mungekey >/dev/null; then
    mungekey --create --keyfile="$key"
else
    dd if=/dev/urandom of="$key" bs=1 count=1024 status=none
fi
chmod 400 "$key"
munged --foreground --force --socket="$tmp/munge.socket" --key-file="$key" \
    --pid-file="$tmp/munged.pid" --log-file="$tmp/munged.log" --seed-file="$tmp/munged.seed" \
    2>>"$tmp/munged.log" &
pids+=($!)
wait_for 100 test -S "$tmp/munge.socket" || { check_alive munged "${pids[0]}"; die "munged made no socket in 10 s"; }
if command -v munge >/dev/null && command -v unmunge >/dev/null; then
    munge --socket="$tmp/munge.socket" -n | unmunge --socket="$tmp/munge.socket" >/dev/null ||
        die "munged does not decode its own credential"
fi
say "munged pid ${pids[0]}"

# --- slurm.conf ---------------------------------------------------------------------------
node=$(hostname -s)
cpus=$(nproc)
mem=$(free -m | awk '/^Mem:/ { print $2 }')
port=${SLURM_LOCAL_PORT:-6817}
for p in "$port" "$((port + 1))"; do
    if command -v ss >/dev/null && [ -n "$(ss -Htln "sport = :$p")" ]; then
        die "port $p is taken (another Slurm?); set SLURM_LOCAL_PORT to a free pair"
    fi
done
conf=$tmp/slurm.conf
mkdir -p "$tmp/state" "$tmp/spool"
cat >"$conf" <<EOF
ClusterName=glint-local
SlurmctldHost=$node(127.0.0.1)
SlurmctldPort=$port
SlurmdPort=$((port + 1))
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
AuthInfo=socket=$tmp/munge.socket
CredType=cred/munge
StateSaveLocation=$tmp/state
SlurmdSpoolDir=$tmp/spool
SlurmctldPidFile=$tmp/slurmctld.pid
SlurmdPidFile=$tmp/slurmd.pid
SlurmctldLogFile=$tmp/slurmctld.log
SlurmdLogFile=$tmp/slurmd.log
SlurmctldDebug=info
SlurmdDebug=info
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
SelectType=select/cons_tres
SelectTypeParameters=CR_CPU
MpiDefault=none
SwitchType=switch/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
JobCompType=jobcomp/filetxt
JobCompLoc=$tmp/jobcomp.txt
ReturnToService=2
MinJobAge=600
NodeName=$node NodeAddr=127.0.0.1 CPUs=$cpus RealMemory=$mem State=UNKNOWN
PartitionName=local Nodes=$node Default=YES MaxTime=INFINITE State=UP
EOF
export SLURM_CONF=$conf

# --- slurmctld and slurmd -----------------------------------------------------------------
slurmctld -D -f "$conf" 2>>"$tmp/slurmctld.log" &
pids+=($!)
wait_for 150 scontrol ping || { check_alive slurmctld "${pids[1]}"; die "slurmctld does not answer scontrol ping in 15 s"; }
say "slurmctld pid ${pids[1]} on port $port"
slurmd -D -f "$conf" -N "$node" 2>>"$tmp/slurmd.log" &
pids+=($!)
node_idle() { [ "$(sinfo -h -N -n "$node" -o '%t')" = idle ]; }
wait_for 300 node_idle || {
    check_alive slurmd "${pids[2]}"
    die "node $node is not idle after 30 s: $(sinfo -N -n "$node" -o '%N %t %E' 2>&1 | tail -n 1)"
}
say "slurmd pid ${pids[2]}; $(sinfo -h -N -n "$node" -o 'node %N %t, %c CPUs, %m MB')"

# --- the job array ------------------------------------------------------------------------
# The folder a user would submit from: the scene by the same relative path as in the docs.
work=$tmp/work
mkdir -p "$work"
ln -s "$repo/scenes" "$work/scenes"
cd "$work"
args=(scenes/cornell-box.toml --mode path --passes 8 --width 160 --height 120)
cat >chunks.sh <<EOF
#!/bin/sh
#SBATCH --job-name=glint-chunks
#SBATCH --array=0-3
#SBATCH --cpus-per-task=1
#SBATCH --output=slurm-%A_%a.out
set -e
mkdir -p parts
echo "task \$SLURM_ARRAY_TASK_ID on \$(hostname -s)"
'$GLINT' render ${args[*]} --chunk auto/4 -o parts/part_\$SLURM_ARRAY_TASK_ID.exr
echo "task \$SLURM_ARRAY_TASK_ID done"
EOF
jobid=$(sbatch --parsable chunks.sh)
jobid=${jobid%%;*}
say "submitted array job $jobid (4 tasks)"
# Every task ends (and leaves its state in the controller) before this returns.
array_done() { [ -z "$(squeue -h -j "$jobid" -o '%i' 2>/dev/null)" ]; }
wait_for 3000 array_done || die "job $jobid not done after 300 s: $(squeue -j "$jobid" 2>&1)"

# The tasks' states, from slurmctld's job completion log (JobCompType=jobcomp/filetxt, what
# `sacct -c` reads; Slurm 22.05's `sacct -c` drops the array ids, so the log is read here).
states=$(sed -nE 's/^JobId=[0-9]+ .*JobState=([A-Z_]+) .*ArrayJobId='"$jobid"' ArrayTaskId=([0-9]+) .* ExitCode=([0-9:]+) *$/'"$jobid"'_\2 \1 \3/p' \
    "$tmp/jobcomp.txt" | sort)
say "task states (job completion log):"
printf '%s\n' "$states" | sed 's/^/  /'
[ "$(printf '%s\n' "$states" | grep -c ' COMPLETED 0:0$')" -eq 4 ] || die "not every one of the 4 tasks COMPLETED with exit 0:0"
for t in 0 1 2 3; do
    out=slurm-${jobid}_$t.out
    [ -f "$out" ] && grep -q "task $t done" "$out" || die "task $t did not finish: $(cat "$out" 2>/dev/null)"
    [ -f "parts/part_$t.exr" ] || die "task $t wrote no parts/part_$t.exr"
done
jobid=

# --- merge, single render, compare --------------------------------------------------------
say "glint merge parts/part_0.exr parts/part_1.exr parts/part_2.exr parts/part_3.exr -o final.png"
"$GLINT" merge parts/part_0.exr parts/part_1.exr parts/part_2.exr parts/part_3.exr -o final.png 2>&1
say "glint render ${args[*]} -o single.png"
"$GLINT" render "${args[@]}" -o single.png 2>&1
cmp final.png single.png || die "final.png and single.png differ"
say "final.png and single.png: identical"
