#!/usr/bin/env bash
# `ghm study` on a real single-node Slurm: starts munge, slurmctld and slurmd on localhost
# (Debian's slurm-wlm and munge; see ../shared/spec/slurm-local.md for what they need
# here), submits examples/studies/tiny.toml as a 2-task array with
# examples/slurm/study.sbatch, and checks that the shards together are the whole study:
# every job complete, each in one task, and the same figures as one run on this machine.
# Usage: tests/slurm/run.sh [GHM_BINARY]   (root; run by .ci/run)
set -euo pipefail
cd "$(dirname "$0")/../.."
ghm=$(realpath "${1:-target/debug/ghm}")
work=$(mktemp -d /tmp/ghm-slurm.XXXXXX)
host=$(hostname)
pids=()
started_munged=
cleanup() {
    for pid in "${pids[@]}"; do kill "$pid" 2>/dev/null || true; done
    pkill -f "slurm(ctl)?d -D -f $work" 2>/dev/null || true
    for _ in $(seq 20); do
        pgrep -f "slurm(ctl)?d -D -f $work" >/dev/null || break
        sleep 0.25
    done
    pkill -9 -f "slurm(ctl)?d -D -f $work" 2>/dev/null || true
    if [ -n "${started_munged:-}" ]; then pkill -x munged 2>/dev/null || true; fi
}
trap cleanup EXIT
fail() {
    echo "slurm test: $*" >&2
    for log in "$work"/*.log; do echo "== $log" >&2; tail -20 "$log" >&2 || true; done
    exit 1
}

mkdir -p "$work/state" "$work/spool" /run/munge
chown munge:munge /run/munge
[ -f /etc/munge/munge.key ] || fail "no munge key (/etc/munge/munge.key): is munge installed?"
cat > "$work/slurm.conf" <<CONF
ClusterName=ghm-test
SlurmctldHost=$host
SlurmUser=root
AuthType=auth/munge
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
ReturnToService=2
StateSaveLocation=$work/state
SlurmdSpoolDir=$work/spool
SlurmctldPidFile=$work/slurmctld.pid
SlurmdPidFile=$work/slurmd.pid
SlurmctldLogFile=$work/slurmctld.log
SlurmdLogFile=$work/slurmd.log
SlurmctldPort=$((20000 + RANDOM % 10000))
SlurmdPort=$((30000 + RANDOM % 10000))
NodeName=$host CPUs=$(nproc) RealMemory=4000 State=UNKNOWN
PartitionName=test Nodes=$host Default=YES MaxTime=INFINITE State=UP
CONF
export SLURM_CONF=$work/slurm.conf

if ! pgrep -x munged >/dev/null || [ ! -S /run/munge/munge.socket.2 ]; then
    su -s /bin/sh munge -c "/usr/sbin/munged --force"
    started_munged=1
fi
for _ in $(seq 40); do
    [ -S /run/munge/munge.socket.2 ] && break
    sleep 0.25
done
[ -S /run/munge/munge.socket.2 ] || fail "munged did not start"
slurmctld -D -f "$work/slurm.conf" >"$work/slurmctld.out" 2>&1 & pids+=($!)
sleep 1
slurmd -D -f "$work/slurm.conf" >"$work/slurmd.out" 2>&1 & pids+=($!)
for _ in $(seq 30); do
    sinfo -h -o %t 2>/dev/null | grep -qx idle && break
    sleep 1
done
sinfo -h -o %t | grep -qx idle || fail "the node did not come up idle: $(sinfo 2>&1)"

out=$work/study
GHM=$ghm sbatch --wait --array=0-1 --cpus-per-task=1 --chdir="$PWD" \
    --output="$work/task-%a.log" examples/slurm/study.sbatch examples/studies/tiny.toml "$out" \
    >"$work/sbatch.out" || fail "the array failed: $(cat "$work/sbatch.out")"
for task in 0 1; do
    grep -q "(shard $task/2)" "$work/task-$task.log" || fail "task $task did not run shard $task/2"
done

# Every job complete, and the same figures as one run of the whole study here.
"$ghm" study examples/studies/tiny.toml --out "$out" >"$work/rerun.out" 2>&1
grep -q "19 jobs: 0 run now, 19 done before" "$work/rerun.out" || fail "jobs left after the array: $(cat "$work/rerun.out")"
"$ghm" study examples/studies/tiny.toml --out "$work/local" >/dev/null 2>&1
figures() { cut -d, -f1-5,8-11 "$1/results.csv"; }
diff <(figures "$out") <(figures "$work/local") || fail "the array's figures differ from one local run"
# Both tasks appended their jobs' times to one timings.csv under one header.
[ "$(grep -c '^job,kind,phase' "$out/timings.csv")" = 1 ] || fail "timings.csv: $(head -3 "$out/timings.csv")"
[ "$(tail -n +2 "$out/timings.csv" | wc -l)" = 19 ] || fail "timings.csv has not one line per job: $(cat "$out/timings.csv")"
"$ghm" report "$out" --out "$work/report" >/dev/null
[ -s "$work/report/lettuce.png" ] || fail "no report"
echo "slurm test: a 2-task array ran the tiny study's 19 jobs, the same figures as one local run"
rm -rf "$work"
