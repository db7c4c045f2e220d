#!/usr/bin/env python3
"""Prints success, failed or running for a Slurm job id (Snakemake's --cluster-status).

Asked in turn: the exit code the job wrote itself (submit.py), then sacct (where Slurm keeps
accounting), then scontrol (which forgets a job MinJobAge seconds after it ends, 300 by default).
A job that none of them knows has ended without writing its exit code — killed for its time
limit or memory, cancelled, or lost with its node — and is failed: never running for ever.
If the controller cannot be reached, the job counts as running until it can.
"""
import os
import subprocess
import sys

RUNNING = {"PENDING", "CONFIGURING", "RUNNING", "COMPLETING", "SUSPENDED", "REQUEUED", "REQUEUE_FED", "REQUEUE_HOLD",
           "RESIZING", "SIGNALING", "STAGE_OUT", "RESV_DEL_HOLD", "SPECIAL_EXIT"}
SUCCESS = {"COMPLETED"}


def verdict(state):
    state = state.split()[0].rstrip("+") if state.strip() else ""
    if not state:
        return None
    if state in SUCCESS:
        return "success"
    if state in RUNNING:
        return "running"
    return "failed"  # FAILED, CANCELLED, TIMEOUT, OUT_OF_MEMORY, NODE_FAIL, BOOT_FAIL, DEADLINE, PREEMPTED


def run(cmd):
    try:
        done = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, timeout=60)
    except (OSError, subprocess.TimeoutExpired) as e:
        return 1, "", str(e)
    return done.returncode, done.stdout, done.stderr


def main():
    job = sys.argv[1]
    code_file = os.path.join(".snakemake", "slurm-status", job)
    if os.path.exists(code_file):
        with open(code_file) as f:
            print("success" if f.read().strip() == "0" else "failed")
        return
    rc, out, _ = run(["sacct", "-j", job, "-X", "-n", "-P", "-o", "State"])
    if rc == 0 and out.strip():
        v = verdict(out.strip().splitlines()[0])
        if v:
            print(v)
            return
    rc, out, err = run(["scontrol", "show", "job", "-o", job])
    if rc == 0:
        for field in out.split():
            if field.startswith("JobState="):
                print(verdict(field[len("JobState="):]) or "running")
                return
    if "Invalid job id" in err or "Invalid job id" in out:
        print("failed")  # forgotten by Slurm without having written its exit code
        return
    print("running")  # the controller did not answer: ask again later


if __name__ == "__main__":
    main()
