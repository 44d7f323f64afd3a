#!/usr/bin/env python3
"""bench/tools/proc.py measures the program, not the benchmark script that starts it: a small
program started from a script holding 300 MB weighs a few MB, a program that allocates 60 MB
weighs at least that; exit codes, deaths by signal, a program that cannot start and a
timeout are reported as before."""
import os
import sys
import tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
sys.path.insert(0, os.path.join(ROOT, "bench", "tools"))
import proc  # noqa: E402

MB = 1024  # KiB


def check(condition, message):
    if not condition:
        print("FAIL: " + message)
        sys.exit(1)


def main():
    ballast = bytearray(300 * 1024 * 1024)
    for i in range(0, len(ballast), 4096):  # resident, not just reserved
        ballast[i] = 1
    with tempfile.TemporaryDirectory() as tmp:
        out, err = os.path.join(tmp, "out"), os.path.join(tmp, "err")

        def run(cmd, timeout_s=60):
            return proc.run_measured(cmd, timeout_s=timeout_s, stdout_path=out, stderr_path=err)

        small = run(["true"])
        check(small.ok and small.peak_rss_kb is not None, f"true runs: {small}")
        check(small.peak_rss_kb < 50 * MB,
              f"true weighs {small.peak_rss_kb} KiB, not the 300 MB of the script starting it")
        allocate = "b = bytearray(60 * 1024 * 1024)\nfor i in range(0, len(b), 4096): b[i] = 1"
        big = run([sys.executable, "-c", allocate])
        check(big.ok and big.peak_rss_kb >= 60 * MB, f"60 MB allocated, measured {big.peak_rss_kb} KiB")
        check(big.peak_rss_kb < 200 * MB, f"60 MB allocated, measured {big.peak_rss_kb} KiB")
        code = run(["sh", "-c", "echo hello; exit 3"])
        check(code.returncode == 3 and not code.ok, f"exit code 3: {code}")
        with open(out) as f:
            check(f.read() == "hello\n", "the program's stdout goes to stdout_path")
        killed = run(["sh", "-c", "kill -9 $$"])
        check(killed.returncode == -9, f"killed by signal 9: {killed}")
        missing = run([os.path.join(tmp, "no-such-program")])
        check(missing.returncode is None and "cannot start" in missing.error and
              "No such file" in missing.error, f"a program that cannot start: {missing}")
        slow = run(["sleep", "30"], timeout_s=0.5)
        check(slow.timed_out and not slow.ok and slow.wall_s < 10, f"a timeout: {slow}")
    print("ok")


if __name__ == "__main__":
    main()
