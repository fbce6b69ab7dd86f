# SPDX-License-Identifier: MIT
"""Runs a peer project's test file (from ../shared/peers) in a pytest subprocess with one of our
routing plugins (a module beside this file) loaded, so that the peer's own tests exercise our drop-in."""

import os
import subprocess
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
# The repository root is two levels up; ../shared sits beside it.
PEERS = HERE.parent.parent.parent / "shared" / "peers"


def run_peer_suite(suite: Path, plugin: str) -> subprocess.CompletedProcess:
    """pytest on ``suite`` with ``-p plugin``, in the suite's folder; prints the output's tail."""
    env = dict(os.environ)
    # The plugin module lives beside this file; the child pytest finds it through PYTHONPATH.
    env["PYTHONPATH"] = str(HERE) + os.pathsep + env.get("PYTHONPATH", "")
    command = [sys.executable, "-m", "pytest", "-q", "-p", plugin, "-p", "no:cacheprovider"]
    command += ["--rootdir", str(suite.parent), str(suite)]
    result = subprocess.run(command, cwd=str(suite.parent), env=env, capture_output=True, text=True, timeout=900)
    print(result.stdout[-6000:])
    print(result.stderr[-3000:])
    return result
