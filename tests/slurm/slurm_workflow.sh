#!/usr/bin/env bash
# The block workflow on a one-node Slurm cluster (issue "The block workflow proven on a Slurm
# cluster"): starts munge, slurmctld and slurmd from Debian's packages (munge, slurm-wlm) in a
# temporary folder, without accounting (as many small clusters run), runs the workflow through the
# shipped profile (workflows/block/profiles/slurm) and through Snakemake's built-in executor
# (--slurm, with the settings Debian's Snakemake 7.21 needs), and compares mounting, pair files and
# strips with a local `--cores 2` run. The daemons are stopped by their PIDs on every exit.
#   tests/slurm/slurm_workflow.sh MOUNTCAL_COMMAND [WORK_DIR]
set -euo pipefail
mountcal="$1"
src="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
work="${2:-$(mktemp -d /tmp/mountcal_slurm.XXXXXX)}"
rm -rf "$work"; mkdir -p "$work"
for tool in munged slurmctld slurmd sbatch scontrol sinfo snakemake; do
  command -v "$tool" > /dev/null || { echo "slurm test: $tool is not installed (scripts/test.sh installs munge, slurm-wlm, snakemake)"; exit 1; }
done

# status.py's answers where Slurm cannot give them, with stand-ins for sacct and scontrol: the
# exit code a job wrote wins; without accounting and after scontrol has forgotten the job, a job
# that wrote no code is failed (never running for ever); an unreachable controller is running.
status="$src/workflows/block/profiles/slurm/status.py"
S="$work/status"; mkdir -p "$S/bin" "$S/.snakemake/slurm-status"
printf '#!/bin/sh\necho "Slurm accounting storage is disabled" >&2; exit 1\n' > "$S/bin/sacct"
printf '#!/bin/sh\necho "slurm_load_jobs error: Invalid job id specified" >&2; exit 1\n' > "$S/bin/scontrol"
chmod +x "$S/bin/"*
expect_status() {  # JOB WANT
  local got; got="$(cd "$S" && PATH="$S/bin:$PATH" python3 "$status" "$1")"
  [ "$got" = "$2" ] || { echo "slurm test: status.py $1 said '$got', expected '$2'"; exit 1; }
}
echo 0 > "$S/.snakemake/slurm-status/11"; expect_status 11 success
echo 137 > "$S/.snakemake/slurm-status/12"; expect_status 12 failed
expect_status 13 failed
printf '#!/bin/sh\necho "JobId=14 JobState=RUNNING Reason=None"\n' > "$S/bin/scontrol"; expect_status 14 running
printf '#!/bin/sh\necho "JobId=15 JobState=TIMEOUT Reason=TimeLimit"\n' > "$S/bin/scontrol"; expect_status 15 failed
printf '#!/bin/sh\necho "JobId=16 JobState=COMPLETED Reason=None"\n' > "$S/bin/scontrol"; expect_status 16 success
printf '#!/bin/sh\necho "OUT_OF_MEMORY"\n' > "$S/bin/sacct"; expect_status 16 failed
printf '#!/bin/sh\nexit 1\n' > "$S/bin/sacct"
printf '#!/bin/sh\necho "slurm_load_jobs error: Unable to contact slurm controller" >&2; exit 1\n' > "$S/bin/scontrol"
expect_status 17 running
echo "slurm test: status.py answers as specified without Slurm"

T="$work/cluster"; mkdir -p "$T/state" "$T/spool" "$T/log"
# The daemons' PIDs, read from their PID files as each starts and kept here: stop() must not
# depend on files that a clean-up could have removed.
pids=()
remember_pid() {  # PID_FILE
  local i
  for i in $(seq 50); do [ -s "$1" ] && break; sleep 0.2; done
  [ -s "$1" ] && pids+=("$(cat "$1")")
}
stop() {
  local p
  for p in "${pids[@]}"; do kill "$p" 2> /dev/null || true; done
  sleep 1
  for p in "${pids[@]}"; do kill -9 "$p" 2> /dev/null || true; done
  pids=()
}
trap stop EXIT

# munge: its own key, socket and PID file.
dd if=/dev/urandom of="$T/munge.key" bs=1024 count=1 status=none
chmod 400 "$T/munge.key"
munged --force --key-file="$T/munge.key" --socket="$T/munge.sock" --pid-file="$T/munged.pid" \
  --log-file="$T/log/munged.log" --seed-file="$T/munged.seed"
remember_pid "$T/munged.pid"

free_port() { python3 -c 'import socket; s = socket.socket(); s.bind(("127.0.0.1", 0)); print(s.getsockname()[1])'; }
cat > "$T/slurm.conf" <<CONF
ClusterName=mountcal-test
SlurmctldHost=localhost(127.0.0.1)
SlurmctldPort=$(free_port)
SlurmdPort=$(free_port)
SlurmUser=$(id -un)
SlurmdUser=$(id -un)
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
SchedulerType=sched/backfill
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
ReturnToService=2
MpiDefault=none
MailProg=/bin/true
NodeName=localhost NodeAddr=127.0.0.1 CPUs=2 RealMemory=8000 State=UNKNOWN
PartitionName=debug Nodes=localhost Default=YES MaxTime=INFINITE State=UP
CONF
export SLURM_CONF="$T/slurm.conf"
slurmctld -f "$SLURM_CONF"
remember_pid "$T/slurmctld.pid"
slurmd -f "$SLURM_CONF" -N localhost
remember_pid "$T/slurmd.pid"
for i in $(seq 60); do
  state="$(sinfo -h -o %T 2> /dev/null || true)"
  [ "$state" = "idle" ] && break
  sleep 1
done
[ "$state" = "idle" ] || { echo "slurm test: the node did not come up (state '$state')"; tail -20 "$T/log/"*.log; exit 1; }

# The swath QC rules are left out (qc=false): plain per-pair shell rules like match, tested with
# the local executor in tests/test_block.cpp; here they would add 8 Slurm jobs per run to CI.
# A small block (4 strips: 4 crossings, 6 overlapping pairs, so every rule runs as a Slurm job
# and two jobs of a rule run at once), simulated once; three runs of the workflow on copies of
# it. Each Slurm job starts Snakemake again for its one rule (about 3 s of CPU): 12 jobs here,
# 32 with the 8-strip block.
"$mountcal" simulate --preset block-4 --no-ties --out "$work/block" > /dev/null
run_workflow() {  # NAME SNAKEMAKE_ARGS...
  local name="$1"; shift
  mkdir -p "$work/$name"
  cp -r "$work/block" "$work/$name/block"
  (cd "$work/$name" && export CI="${CI:-}" && USER="${USER:-$(id -un)}" snakemake -s "$src/workflows/block/Snakefile" \
     --config job=block/job.json out=block/workflow mountcal="$mountcal" qc=false "$@" > snakemake.log 2>&1) ||
    { echo "slurm test: the $name run failed"; tail -40 "$work/$name/snakemake.log"; tail -20 "$T/log/slurmctld.log"; exit 1; }
}
start=$SECONDS
run_workflow local --cores 2
echo "slurm test: local run $((SECONDS - start)) s"; start=$SECONDS
# CI=true is Snakemake 7's own setting for tests: its generic cluster executor (the profile's)
# then checks the jobs every second instead of every 10 s (snakemake/executors/__init__.py,
# sleep()); what the profile answers is the same. The built-in executor checks at
# --max-status-checks-per-second either way.
CI=true run_workflow profile --profile "$src/workflows/block/profiles/slurm"
echo "slurm test: profile run $((SECONDS - start)) s"; start=$SECONDS
run_workflow builtin --slurm --jobs 100 --max-status-checks-per-second 1 --default-resources slurm_partition=debug runtime=10 mem_mb=1000
echo "slurm test: built-in executor run $((SECONDS - start)) s"

# The same outputs, to the byte: result (mounting, σ), pair files, strips.
fail=0
for name in profile builtin; do
  (cd "$work/local/block/workflow" && find . -type f | sort) > "$work/local.files"
  (cd "$work/$name/block/workflow" && find . -type f | sort) > "$work/$name.files"
  if ! cmp -s "$work/local.files" "$work/$name.files"; then
    echo "slurm test: $name wrote other files than the local run:"; diff "$work/local.files" "$work/$name.files" | head; fail=1
  fi
  python3 - "$work/local/block/workflow/result.json" "$work/$name/block/workflow/result.json" "$name" <<'PY' || fail=1
import json, sys
a, b = (json.load(open(p)) for p in sys.argv[1:3])
if a["mounting"] != b["mounting"]:
    sys.exit(f"slurm test: {sys.argv[3]}: mounting {b['mounting']} differs from the local run's {a['mounting']}")
PY
  for f in $(cat "$work/local.files"); do
    case "$f" in ./result.json) continue ;; esac
    cmp -s "$work/local/block/workflow/$f" "$work/$name/block/workflow/$f" || { echo "slurm test: $name: $f differs"; fail=1; }
  done
  if [ "$name" = profile ]; then  # each rule instance ran as a Slurm job: its log is there
    n=$(find "$work/$name/logs/slurm" -name '*.log' 2> /dev/null | wc -l || true)
    [ "$n" -eq "$(grep -c . "$work/local.files")" ] || { echo "slurm test: $name: $n Slurm job logs for $(grep -c . "$work/local.files") outputs"; fail=1; }
  fi
done
[ "$fail" = 0 ] && echo "slurm test: the profile and the built-in executor equal the local run (mounting, pair files, strips)"
stop
# Nothing of the cluster may outlive the test.
if pgrep -f "$T/slurm.conf" > /dev/null || pgrep -f "$T/munge.key" > /dev/null; then
  echo "slurm test: a daemon is still running after stop:"; pgrep -af "$T/"; fail=1
fi
[ "$fail" = 0 ] && rm -rf "$work"
exit "$fail"
