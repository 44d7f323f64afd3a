"""Runs one program with a timeout and measures its wall time and peak resident memory."""
import dataclasses
import os
import signal
import subprocess
import time

POLL_S = 0.02
TERM_GRACE_S = 5.0


@dataclasses.dataclass
class RunResult:
    returncode: int = None  # exit code, or -N when killed by signal N; None if never started
    wall_s: float = None  # from start to exit, seconds
    peak_rss_kb: int = None  # ru_maxrss of the process (and any children it waited for), KiB
    timed_out: bool = False
    error: str = ""  # why it could not be started

    @property
    def ok(self):
        return self.returncode == 0 and not self.timed_out


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
    with open(stdout_path, "wb") as out, open(stderr_path, "wb") as err:
        start = time.monotonic()
        try:
            proc = subprocess.Popen(cmd, cwd=cwd, env=env, stdin=subprocess.DEVNULL, stdout=out,
                                    stderr=err, start_new_session=True)
        except OSError as e:
            result.error = f"cannot start {cmd[0]}: {e.strerror or e}"
            return result
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
    status, rusage = reaped
    result.returncode = os.waitstatus_to_exitcode(status)
    proc.returncode = result.returncode  # reaped here, so Popen must not wait for it again
    result.peak_rss_kb = rusage.ru_maxrss
    return result


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
