#!/usr/bin/python3
"""Snakemake's cluster-status hook for the Slurm profile: prints running, success or
failed for a job id sbatch returned. Without it Snakemake only learns of a job's end from
the job itself, so a job Slurm kills before it starts (a bad --output path, a node
failure, a time limit) would be waited for forever."""
import subprocess
import sys

RUNNING = {"PENDING", "CONFIGURING", "RUNNING", "COMPLETING", "SUSPENDED", "REQUEUED", "RESIZING", "STAGE_OUT",
           "SIGNALING", "REQUEUE_HOLD", "REQUEUE_FED"}


def state(job):
    p = subprocess.run(["scontrol", "show", "job", "-o", job], capture_output=True, text=True)
    if p.returncode == 0:
        for token in p.stdout.split():
            if token.startswith("JobState="):
                return token.split("=", 1)[1]
    p = subprocess.run(["sacct", "-n", "-X", "-P", "-j", job, "-o", "State"], capture_output=True, text=True)
    if p.returncode == 0 and p.stdout.strip():
        return p.stdout.split()[0].rstrip("+")
    return None


s = state(sys.argv[1].split(";")[0])
# A job Slurm no longer knows is reported failed: Snakemake then says so, rather than hang.
print("running" if s in RUNNING else "success" if s == "COMPLETED" else "failed")
