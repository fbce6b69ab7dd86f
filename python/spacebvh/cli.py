# SPDX-License-Identifier: MIT
"""The ``spacebvh`` command-line tool that ``pip install`` puts beside the package."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import sysconfig
from collections.abc import Sequence

__all__ = ["executable", "run"]


def executable() -> str:
    """The path of the ``spacebvh`` command installed with this package.

    Looks in the scripts directory of the running interpreter's environment first (where the wheel
    installs it, whether or not that directory is on PATH), then on PATH. Raises FileNotFoundError
    when neither has it (e.g. a package laid out by a plain CMake build).
    """
    name = "spacebvh.exe" if os.name == "nt" else "spacebvh"
    candidates = [sysconfig.get_path("scripts"), os.path.dirname(sys.executable)]
    for folder in candidates:
        if folder:
            path = os.path.join(folder, name)
            if os.path.isfile(path) and os.access(path, os.X_OK):
                return path
    found = shutil.which(name)
    if found:
        return found
    raise FileNotFoundError("the spacebvh command is not installed beside this package (pip install . installs it)")


def run(args: Sequence[str], check: bool = True, capture_output: bool = True) -> subprocess.CompletedProcess:
    """Runs ``spacebvh ARGS...`` and returns the completed process (text output).

    With ``check`` (the default) a non-zero exit raises subprocess.CalledProcessError, whose
    ``stderr`` holds the tool's message.
    """
    return subprocess.run([executable(), *args], check=check, capture_output=capture_output, text=True)
