"""Runs one program with a timeout and measures its wall time and peak resident memory.

The peak comes from a small launcher (a fresh `python3 -I -S`) that starts the program and
reads its rusage. Linux keeps a process's peak RSS across exec, and a child forked from this
script starts with all of this script's memory mapped: measured directly, every program would
weigh at least what the benchmark script weighs when it starts it (up to 340 MB, for a run of
145 MB). Forked from the launcher, a program starts with the launcher's ~10 MB at most.
"""
import dataclasses
import os
import signal
import subprocess
import sys
import tempfile
import time

POLL_S = 0.02
TERM_GRACE_S = 5.0


@dataclasses.dataclass
class RunResult:
    returncode: int = None  # exit code, or -N when killed by signal N; None if never started
    wall_s: float = None  # from start to exit, seconds
    peak_rss_kb: int = None  # ru_maxrss of the program (and any children it waited for), KiB
    timed_out: bool = False
    error: str = ""  # why it could not be started

    @property
    def ok(self):
        return self.returncode == 0 and not self.timed_out


# argv: RESULT_FILE PROGRAM ARGS... Runs PROGRAM, writes its ru_maxrss (KiB) and wall time (s)
# to RESULT_FILE, or "error: ..." when it cannot be started (exit 127), and ends as PROGRAM did
# (its exit code, or killed by the same signal).
_LAUNCHER = """
import os, sys, time
result, argv = sys.argv[1], sys.argv[2:]
start = time.monotonic()
try:
    pid = os.posix_spawnp(argv[0], argv, os.environ)
except OSError as e:
    with open(result, "w") as f:
        f.write("error: " + (e.strerror or str(e)))
    os._exit(127)
_, status, rusage = os.wait4(pid, 0)
wall = time.monotonic() - start
with open(result, "w") as f:
    f.write(f"{rusage.ru_maxrss} {wall!r}")
if os.WIFSIGNALED(status):
    os.kill(os.getpid(), os.WTERMSIG(status))
os._exit(os.waitstatus_to_exitcode(status))
"""


def _reap(pid, deadline):
    """Polls the child until it exits or the deadline passes. Returns (status, rusage) or None."""
    while True:
        done, status, rusage = os.wait4(pid, os.WNOHANG)
        if done:
            return status, rusage
        if deadline is not None and time.monotonic() >= deadline:
            return None
        time.sleep(POLL_S)


def _kill_group(pid):
    """Ends the session the child leads (the child and anything it started), then reaps it."""
    for sig, grace in ((signal.SIGTERM, TERM_GRACE_S), (signal.SIGKILL, None)):
        try:
            os.killpg(pid, sig)
        except ProcessLookupError:
            pass
        reaped = _reap(pid, None if grace is None else time.monotonic() + grace)
        if reaped:
            return reaped
    raise AssertionError("unreachable")


def run_measured(cmd, *, timeout_s, stdout_path, stderr_path, cwd=None, env=None):
    """Runs cmd (a list) in its own session; stdin is /dev/null, outputs go to the two files."""
    result = RunResult()
    with tempfile.TemporaryDirectory(prefix="proc-") as tmp:
        measured = os.path.join(tmp, "rusage")
        launcher = [sys.executable, "-I", "-S", "-c", _LAUNCHER, measured, *cmd]
        _run_launched(launcher, result, cwd, env, timeout_s, stdout_path, stderr_path)
        try:
            with open(measured) as f:
                text = f.read()
        except OSError:
            text = ""  # killed before it could write (a timeout)
    if text.startswith("error: "):
        result.error = f"cannot start {cmd[0]}: {text[len('error: '):]}"
        result.returncode = result.wall_s = None
    elif text:  # the program's own figures, without the launcher's start-up
        rss_kb, wall_s = text.split()
        result.peak_rss_kb, result.wall_s = int(rss_kb), float(wall_s)
    return result


def _run_launched(launcher, result, cwd, env, timeout_s, stdout_path, stderr_path):
    """Runs the launcher in its own session; fills result's wall time, exit code, timeout."""
    with open(stdout_path, "wb") as out, open(stderr_path, "wb") as err:
        start = time.monotonic()
        try:
            proc = subprocess.Popen(launcher, cwd=cwd, env=env, stdin=subprocess.DEVNULL,
                                    stdout=out, stderr=err, start_new_session=True)
        except OSError as e:
            result.error = f"cannot start {launcher[0]}: {e.strerror or e}"
            return
        try:
            reaped = _reap(proc.pid, start + timeout_s)
        except BaseException:  # interrupted (Ctrl-C, SIGTERM): do not leave the child running
            _kill_group(proc.pid)
            proc.returncode = -1
            raise
        if reaped is None:
            result.timed_out = True
            reaped = _kill_group(proc.pid)
        result.wall_s = time.monotonic() - start
    status, _ = reaped
    result.returncode = os.waitstatus_to_exitcode(status)
    proc.returncode = result.returncode  # reaped here, so Popen must not wait for it again


def tail(path, lines=5):
    """The last lines of a text file, for error notes."""
    try:
        with open(path, "rb") as f:
            f.seek(0, os.SEEK_END)
            f.seek(max(0, f.tell() - 8192))
            text = f.read().decode("utf-8", "replace")
    except OSError:
        return ""
    return "\n".join(text.strip().splitlines()[-lines:])
