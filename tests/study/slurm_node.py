"""A single-node Slurm for a test: munged, slurmctld and slurmd on this machine with a
config, key, state and logs in a temporary folder and free loopback ports. Stops them
on exit. `start_slurm(folder)` yields the environment to run sbatch/Snakemake in, or
raises SlurmUnavailable with the reason (binaries missing, daemons refusing to start)."""
import contextlib
import os
import shutil
import signal
import socket
import subprocess
import time


class SlurmUnavailable(Exception):
    pass


def _free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _tail(path, n=5):
    try:
        return " | ".join(open(path, errors="replace").read().strip().splitlines()[-n:])
    except OSError:
        return "(no log)"


@contextlib.contextmanager
def start_slurm(folder):
    for exe in ("munged", "slurmctld", "slurmd", "sbatch", "sinfo"):
        if shutil.which(exe) is None and not os.path.exists(f"/usr/sbin/{exe}"):
            raise SlurmUnavailable(f"{exe} not installed (scripts/install-deps installs slurm-wlm and munge)")
    d = str(folder)
    for sub in ("munge", "state", "spool", "log", "run"):
        os.makedirs(os.path.join(d, sub), exist_ok=True)
    key = os.path.join(d, "munge", "munge.key")
    with open(key, "wb") as f:
        f.write(os.urandom(1024))
    os.chmod(key, 0o600)
    sock = os.path.join(d, "munge", "sock")
    host = socket.gethostname().split(".")[0]
    user = subprocess.run(["id", "-un"], capture_output=True, text=True).stdout.strip()
    cpus = os.cpu_count() or 1
    conf = os.path.join(d, "slurm.conf")
    with open(conf, "w") as f:
        f.write("\n".join([
            "ClusterName=burrbenchtest", f"SlurmctldHost={host}(127.0.0.1)",
            f"SlurmctldPort={_free_port()}", f"SlurmdPort={_free_port()}",
            "AuthType=auth/munge", f"AuthInfo=socket={sock}", "CryptoType=crypto/munge",
            f"SlurmUser={user}", f"SlurmdUser={user}",
            f"StateSaveLocation={d}/state", f"SlurmdSpoolDir={d}/spool",
            f"SlurmctldPidFile={d}/run/slurmctld.pid", f"SlurmdPidFile={d}/run/slurmd.pid",
            f"SlurmctldLogFile={d}/log/slurmctld.log", f"SlurmdLogFile={d}/log/slurmd.log",
            # No cgroups: a test machine (container, VM) may not delegate them.
            "ProctrackType=proctrack/linuxproc", "TaskPlugin=task/none", "JobAcctGatherType=jobacct_gather/none",
            "AccountingStorageType=accounting_storage/none", "SchedulerType=sched/builtin",
            "SelectType=select/cons_tres", "SelectTypeParameters=CR_Core", "ReturnToService=2", "MpiDefault=none",
            f"NodeName={host} NodeAddr=127.0.0.1 CPUs={cpus} RealMemory=4000 State=UNKNOWN",
            f"PartitionName=test Nodes={host} Default=YES MaxTime=INFINITE State=UP", ""]))
    env = dict(os.environ, SLURM_CONF=conf)
    procs = []
    try:
        m = subprocess.run(["munged", "--force", f"--key-file={key}", f"--socket={sock}",
                            f"--pid-file={d}/munge/pid", f"--log-file={d}/munge/log", f"--seed-file={d}/munge/seed"],
                           capture_output=True, text=True)
        if m.returncode != 0:
            raise SlurmUnavailable(f"munged refused to start: {m.stderr.strip() or _tail(d + '/munge/log')}")
        for exe, log in (("slurmctld", "ctld.out"), ("slurmd", "d.out")):
            procs.append(subprocess.Popen([exe, "-D"], env=env, stdout=open(os.path.join(d, "log", log), "w"),
                                          stderr=subprocess.STDOUT, start_new_session=True))
            time.sleep(0.5)
        deadline = time.monotonic() + 30
        while True:
            s = subprocess.run(["sinfo", "-h", "-o", "%t"], env=env, capture_output=True, text=True)
            if s.returncode == 0 and s.stdout.strip() in ("idle", "mix", "alloc"):
                break
            dead = [p.args[0] for p in procs if p.poll() is not None]
            if dead or time.monotonic() > deadline:
                raise SlurmUnavailable(
                    f"Slurm did not come up ({', '.join(dead) + ' exited' if dead else 'node not idle in 30 s'}): "
                    f"slurmctld: {_tail(d + '/log/ctld.out')}; slurmd: {_tail(d + '/log/d.out')}")
            time.sleep(0.5)
        yield env
    finally:
        for p in procs:
            if p.poll() is None:
                os.killpg(p.pid, signal.SIGTERM)
        for p in procs:
            try:
                p.wait(timeout=15)
            except subprocess.TimeoutExpired:
                os.killpg(p.pid, signal.SIGKILL)
        subprocess.run(["munged", "-s", f"--socket={sock}"], capture_output=True)
