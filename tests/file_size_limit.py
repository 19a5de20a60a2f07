"""A full disk without a mount: burrbench run under a file-size limit (RLIMIT_FSIZE), so
the kernel refuses any write past `limit_bytes` in any file (EFBIG). SIGXFSZ is left at
its default, which kills: burrbench must ignore it itself and report the error."""
import os
import resource
import signal
import subprocess

BURRBENCH = os.environ.get("BURRBENCH", "")


def run_with_file_size_limit(args, limit_bytes, timeout=300):
    """`burrbench ARGS` with every file it writes limited to `limit_bytes`."""

    def limit():
        signal.signal(signal.SIGXFSZ, signal.SIG_DFL)
        resource.setrlimit(resource.RLIMIT_FSIZE, (limit_bytes, limit_bytes))

    return subprocess.run([BURRBENCH, *map(str, args)], capture_output=True, text=True, timeout=timeout,
                          preexec_fn=limit)


def burrbench_lines(stderr):
    """The lines burrbench itself printed (a refusal or an error), not its progress."""
    return [line for line in stderr.splitlines() if line.startswith("burrbench:")]
