# SPDX-License-Identifier: MIT
"""`python -m spacebvh.reproduce` finds the `spacebvh` command the package installed the way
spacebvh.cli.executable() does: beside the interpreter, also when that folder is not on PATH
(`venv/bin/python -m spacebvh.reproduce` from a virtual environment that is not activated)."""

from __future__ import annotations

import os
import subprocess
import sys
import sysconfig
from pathlib import Path

import pytest

import spacebvh.cli


def _installed_command() -> str:
    try:
        path = spacebvh.cli.executable()
    except FileNotFoundError:
        pytest.skip("the spacebvh command is not installed beside the package (a build-tree layout)")
    beside = {os.path.realpath(p) for p in (sysconfig.get_path("scripts"), os.path.dirname(sys.executable)) if p}
    if os.path.realpath(os.path.dirname(path)) not in beside:
        pytest.skip("the spacebvh command is found on PATH only, not beside the interpreter")
    return path


def _without_the_command_on_path(tmp_path: Path) -> dict:
    """The environment minus any way to the command but the interpreter's own folder: PATH names an empty
    folder, and neither SPACEBVH_CLI nor a checkout's PYTHONPATH is set."""
    env = {k: v for k, v in os.environ.items() if k not in ("SPACEBVH_CLI", "PYTHONPATH")}
    env["PATH"] = str(tmp_path / "empty")
    (tmp_path / "empty").mkdir(exist_ok=True)
    return env


def test_find_cli_uses_the_command_installed_beside_the_interpreter(tmp_path):
    expected = _installed_command()
    code = "from spacebvh.reproduce.jobs import find_cli; print(find_cli())"
    done = subprocess.run(
        [sys.executable, "-c", code],
        env=_without_the_command_on_path(tmp_path),
        cwd=tmp_path,
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == expected


def test_reproduce_runs_from_an_environment_that_is_not_activated(tmp_path):
    pytest.importorskip("matplotlib")
    _installed_command()
    out = tmp_path / "report"
    done = subprocess.run(
        [
            sys.executable,
            "-m",
            "spacebvh.reproduce",
            "--quick",
            "--report-only",
            "--no-progress",
            "--experiments",
            "optimum",
            "--out",
            str(out),
        ],
        env=_without_the_command_on_path(tmp_path),
        cwd=tmp_path,
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert done.returncode == 0, done.stderr[-4000:]
    assert "spacebvh CLI not found" not in done.stderr
    assert (out / "index.html").is_file()
