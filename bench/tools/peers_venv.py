"""The Python virtual environment of the benchmark's peers (KISS-ICP, OpenKarto's matcher).

Created on first use with `python3 -m venv` (default build/bench-venv, git-ignored) and filled
with `pip install` of the pinned package a peer needs. Nothing in the build or the tests needs
it; when it cannot be made (no network, no venv module), the peer is not run and the reason is
reported."""
import os
import subprocess
import sys

PACKAGES = {  # module -> pip requirement (the versions the benchmark was measured with)
    "kiss_icp": "kiss-icp==1.3.0",
    "karto_scanmatcher": "karto-scanmatcher==1.0.0",
}
PIP_TIMEOUT_S = 300


class VenvError(Exception):
    pass


def python_of(venv_dir):
    return os.path.join(venv_dir, "bin", "python")


def has_module(python, module):
    try:
        return subprocess.run([python, "-c", f"import {module}"], capture_output=True,
                              timeout=120).returncode == 0
    except (OSError, subprocess.TimeoutExpired):
        return False


def _run(cmd, what):
    try:
        out = subprocess.run(cmd, capture_output=True, text=True, timeout=PIP_TIMEOUT_S)
    except OSError as e:
        raise VenvError(f"{what}: {e}") from None
    except subprocess.TimeoutExpired:
        raise VenvError(f"{what}: timed out after {PIP_TIMEOUT_S} s") from None
    if out.returncode != 0:
        last = (out.stderr.strip() or out.stdout.strip()).splitlines()[-1:] or ["?"]
        raise VenvError(f"{what} failed: {last[0][:200]}")


def ensure(venv_dir, module, log=lambda m: None):
    """The venv's python with module importable, installing it on first use; raises VenvError."""
    python = python_of(venv_dir)
    if not os.path.isfile(python):
        log(f"creating the peers' virtual environment {venv_dir}")
        _run([sys.executable, "-m", "venv", venv_dir], f"python3 -m venv {venv_dir}")
    if not has_module(python, module):
        requirement = PACKAGES[module]
        log(f"pip install {requirement} into {venv_dir}")
        _run([python, "-m", "pip", "install", "--quiet", "--disable-pip-version-check",
              "--retries", "1", "--timeout", "20", requirement], f"pip install {requirement}")
        if not has_module(python, module):
            raise VenvError(f"{requirement} installed but `import {module}` fails")
    return python
