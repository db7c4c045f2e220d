#!/usr/bin/env python3
"""Submits one Snakemake job script to Slurm and prints the Slurm job id (Snakemake's --cluster).

Threads, memory (resources.mem_mb) and run time in minutes (resources.runtime) come from the job's
properties that Snakemake writes into the script. The job runs the script and then writes its
exit code to .snakemake/slurm-status/<Slurm job id> in the working folder, which status.py reads
first. Slurm's output goes to logs/slurm/<rule>-<job id>.log. Account, partition and the like:
sbatch's environment variables (SBATCH_ACCOUNT, SBATCH_PARTITION, ...), or extra arguments in
MOUNTCAL_SLURM_SBATCH_ARGS.
"""
import json
import os
import re
import shlex
import subprocess
import sys


def job_properties(jobscript):
    # The "# properties = {...}" line of Snakemake's job script (snakemake.utils.read_job_properties,
    # read here without importing Snakemake: this may run under another Python).
    with open(jobscript) as f:
        for line in f:
            m = re.match(r"# properties = (.*)", line)
            if m:
                return json.loads(m.group(1))
    sys.exit(f"submit.py: {jobscript}: no '# properties' line (not a Snakemake job script?)")


def main():
    if len(sys.argv) < 2:
        sys.exit("usage: submit.py JOBSCRIPT")
    jobscript = os.path.abspath(sys.argv[-1])
    props = job_properties(jobscript)
    resources = props.get("resources", {})
    threads = int(props.get("threads", 1))
    mem_mb = int(resources.get("mem_mb", 1000))
    runtime_min = int(resources.get("runtime", 30))
    name = props.get("rule") or props.get("groupid") or "job"
    status_dir = os.path.abspath(os.path.join(".snakemake", "slurm-status"))
    log_dir = os.path.abspath(os.path.join("logs", "slurm"))
    os.makedirs(status_dir, exist_ok=True)
    os.makedirs(log_dir, exist_ok=True)
    # The exit code is written by the job itself, before it ends: the one answer that does not
    # depend on Slurm remembering the job.
    wrap = (f"bash {shlex.quote(jobscript)}; rc=$?; "
            f"echo $rc > {shlex.quote(status_dir)}/$SLURM_JOB_ID.tmp && "
            f"mv {shlex.quote(status_dir)}/$SLURM_JOB_ID.tmp {shlex.quote(status_dir)}/$SLURM_JOB_ID; exit $rc")
    cmd = ["sbatch", "--parsable", f"--job-name=smk-{name}", f"--cpus-per-task={threads}", f"--mem={mem_mb}M",
           f"--time={max(runtime_min, 1)}", f"--output={log_dir}/{name}-%j.log"]
    cmd += shlex.split(os.environ.get("MOUNTCAL_SLURM_SBATCH_ARGS", ""))
    cmd.append(f"--wrap={wrap}")
    done = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    if done.returncode != 0:
        sys.exit(f"submit.py: sbatch failed ({done.returncode}): {done.stderr.strip()}")
    # --parsable prints "jobid" or "jobid;cluster".
    print(done.stdout.strip().split(";")[0])


if __name__ == "__main__":
    main()
