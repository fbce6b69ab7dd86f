# SPDX-License-Identifier: MIT
"""`python -m spacebvh.reproduce --quick` end to end: every experiment's figure, table and JSON; the store
(rerun runs nothing, removing one result reruns that job only); a real Dask scheduler with two worker
processes gives the local run's results (all but timings); the HTML in headless Chromium."""

from __future__ import annotations

import importlib.util
import json
import os
import shutil
import socket
import subprocess
import sys
import time
from pathlib import Path

import pytest

pytest.importorskip("distributed")
pytest.importorskip("matplotlib")
pytest.importorskip("tqdm")

PYTHON_DIR = Path(__file__).resolve().parents[1]
# An installed package (pip install .) is used as it is; a checkout's python/ only when none has reproduce.
_installed = importlib.util.find_spec("spacebvh")
ON_PATH = _installed is not None and any(
    (Path(p) / "reproduce").is_dir() for p in (_installed.submodule_search_locations or [])
)
if not ON_PATH:
    sys.path.insert(0, str(PYTHON_DIR))

from spacebvh.reproduce.experiments import EXPERIMENTS  # noqa: E402
from spacebvh.reproduce.jobs import find_cli  # noqa: E402
from spacebvh.reproduce.results import deterministic  # noqa: E402

try:
    CLI = find_cli()
except FileNotFoundError:
    CLI = None
pytestmark = pytest.mark.skipif(CLI is None, reason="the spacebvh CLI is not built")


def _env():
    env = dict(os.environ)
    if not ON_PATH:
        env["PYTHONPATH"] = str(PYTHON_DIR) + os.pathsep + env.get("PYTHONPATH", "")
    env["SPACEBVH_CLI"] = CLI
    return env


def reproduce(*args, timeout=900):
    completed = subprocess.run(
        [sys.executable, "-m", "spacebvh.reproduce", "--quick", "--no-progress", *map(str, args)],
        capture_output=True,
        text=True,
        env=_env(),
        timeout=timeout,
    )
    assert completed.returncode == 0, completed.stderr[-4000:]
    return completed


def run_log(out: Path) -> dict:
    return json.loads((out / "run.json").read_text())


@pytest.fixture(scope="session")
def local_run(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("local") / "report"
    reproduce("--out", out)
    return out


def job_files(out: Path) -> dict[str, Path]:
    """The stored job results (the store's scene_info/ cache of scene facts is not a job)."""
    return {
        p.relative_to(out / "jobs").as_posix(): p
        for p in (out / "jobs").glob("*/*.json")
        if p.parent.name != "scene_info"
    }


def test_every_experiment_has_figure_table_and_json(local_run):
    log = run_log(local_run)
    assert log["jobs_failed"] == []
    assert len(log["jobs_run"]) == log["jobs_total"] > 0
    for experiment in EXPERIMENTS:
        for path in (
            f"figures/{experiment.id}.svg",
            f"figures/{experiment.id}.png",
            f"tables/{experiment.id}.csv",
            f"results/{experiment.id}.json",
        ):
            assert (local_run / path).stat().st_size > 0, path
        result = json.loads((local_run / "results" / f"{experiment.id}.json").read_text())
        assert result["table"]["rows"], experiment.id
        assert result["verdict"] in ("confirmed", "partly confirmed", "not confirmed"), experiment.id
        assert result["claim"] and result["summary"]
        assert result["wrong_answers"] == 0, experiment.id
        assert result["jobs"] and all((local_run / "jobs" / j).is_file() for j in result["jobs"])
    env = json.loads((local_run / "environment.json").read_text())
    assert env["machine"]["cores"] and env["library_version"] and "--quick" in env["command"]
    html = (local_run / "index.html").read_text()
    assert "http://" not in html and "https://" not in html  # nothing to fetch: opens from the file system
    assert 'href="jobs/' not in html  # the store is not part of the report: nothing links into it
    assert env["store"] == "jobs"
    for experiment in EXPERIMENTS:
        assert f'src="figures/{experiment.id}.svg"' in html


def test_rerun_with_the_store_runs_no_job(local_run, tmp_path):
    out = tmp_path / "report"
    shutil.copytree(local_run, out)
    reproduce("--out", out)
    log = run_log(out)
    assert log["jobs_run"] == [] and len(log["jobs_cached"]) == log["jobs_total"]


def test_removing_one_result_reruns_only_that_job(local_run, tmp_path):
    out = tmp_path / "report"
    shutil.copytree(local_run, out)
    victim = sorted((out / "jobs" / "overlap").glob("*.json"))[0]
    victim.unlink()
    reproduce("--out", out, "--experiments", "overlap,presplit")
    log = run_log(out)
    assert len(log["jobs_run"]) == 1 and log["jobs_run"][0].startswith("overlap/")
    assert victim.is_file()
    assert log["jobs_total"] == len(log["jobs_cached"]) + 1


def test_report_only_and_jobs_only_split_the_halves(local_run, tmp_path):
    out = tmp_path / "report"
    reproduce("--out", out, "--store", local_run / "jobs", "--report-only", "--experiments", "optimum")
    assert (out / "index.html").is_file() and (out / "figures" / "optimum.svg").is_file()
    assert run_log(out)["jobs_run"] == []
    empty = tmp_path / "empty"
    reproduce("--out", empty, "--jobs-only", "--experiments", "optimum")
    assert not (empty / "index.html").exists() and len(run_log(empty)["jobs_run"]) == run_log(empty)["jobs_total"]


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _dask(*args):
    dask = shutil.which("dask") or shutil.which("dask", path=os.path.dirname(sys.executable))
    command = [dask, *args] if dask else [sys.executable, "-m", f"distributed.cli.dask_{args[0]}", *args[1:]]
    env = dict(os.environ)
    env.pop("PYTHONPATH", None)  # the workers get the job code from the client, not from this checkout
    return subprocess.Popen(command, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, cwd="/")


def test_a_dask_cluster_gives_the_local_results(local_run, tmp_path):
    port = _free_port()
    address = f"tcp://127.0.0.1:{port}"
    processes = [_dask("scheduler", "--host", "127.0.0.1", "--port", str(port), "--dashboard-address", ":0")]
    try:
        deadline = time.time() + 60
        while True:  # the scheduler listens before workers connect
            try:
                socket.create_connection(("127.0.0.1", port), timeout=1).close()
                break
            except OSError:
                assert time.time() < deadline and processes[0].poll() is None, "dask scheduler did not start"
                time.sleep(0.3)
        for _ in range(2):
            processes.append(
                _dask(
                    "worker",
                    address,
                    "--nthreads",
                    "1",
                    "--host",
                    "127.0.0.1",
                    "--dashboard-address",
                    ":0",
                    "--no-nanny",
                )
            )
        from distributed import Client

        with Client(address, timeout=60) as client:
            client.wait_for_workers(2, timeout=120)
            assert len(client.scheduler_info()["workers"]) == 2
        out = tmp_path / "report"
        reproduce("--out", out, "--scheduler", address)
        assert run_log(out)["jobs_failed"] == []
    finally:
        for p in reversed(processes):
            p.terminate()
        for p in processes:
            try:
                p.wait(timeout=30)
            except subprocess.TimeoutExpired:
                p.kill()
    local, remote = job_files(local_run), job_files(out)
    assert local.keys() == remote.keys()  # the same keys: the same inputs
    for name in local:
        mine = json.loads(local[name].read_text())
        theirs = json.loads(remote[name].read_text())
        assert deterministic(mine["result"]["outputs"]) == deterministic(theirs["result"]["outputs"]), name
    hosts = {json.loads(p.read_text())["result"]["host"] for p in remote.values()}
    assert hosts  # every job says where it ran


# ---- the report in headless Chromium, through the DevTools protocol over a pipe (no extra package) ----


class DevTools:
    """Chromium with --remote-debugging-pipe: commands go to its fd 3, replies and events come from its fd 4,
    each a JSON message ended by a NUL byte."""

    def __init__(self, browser: str, profile: Path):
        import threading

        to_chrome_r, self._to_chrome = os.pipe()
        self._from_chrome, from_chrome_w = os.pipe()

        def fds():  # in the child: the pipe ends on fds 3 and 4, kept open across exec
            read_end, write_end = os.dup(to_chrome_r), os.dup(from_chrome_w)  # above both targets' old users
            os.dup2(read_end, 3)
            os.dup2(write_end, 4)
            os.set_inheritable(3, True)
            os.set_inheritable(4, True)

        self.process = subprocess.Popen(
            [
                browser,
                "--headless=new",
                "--no-sandbox",
                "--disable-gpu",
                "--remote-debugging-pipe",
                "--no-first-run",
                "--no-default-browser-check",
                f"--user-data-dir={profile}",
                "about:blank",
            ],
            preexec_fn=fds,
            close_fds=False,
            stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL,
        )
        os.close(to_chrome_r)
        os.close(from_chrome_w)
        self.events, self.replies, self._next = [], {}, 0
        self._lock = threading.Condition()
        threading.Thread(target=self._read, daemon=True).start()

    def _read(self):
        buffer = b""
        while True:
            chunk = os.read(self._from_chrome, 1 << 16)
            if not chunk:
                return
            buffer += chunk
            *messages, buffer = buffer.split(b"\0")
            with self._lock:
                for raw in messages:
                    message = json.loads(raw)
                    if "id" in message:
                        self.replies[message["id"]] = message
                    else:
                        self.events.append(message)
                self._lock.notify_all()

    def send(self, method, params=None, session=None, timeout=60):
        self._next += 1
        message = {"id": self._next, "method": method, "params": params or {}}
        if session:
            message["sessionId"] = session
        os.write(self._to_chrome, json.dumps(message).encode() + b"\0")
        with self._lock:
            assert self._lock.wait_for(lambda: self._next in self.replies, timeout), f"no reply to {method}"
            reply = self.replies.pop(self._next)
        assert "error" not in reply, reply
        return reply["result"]

    def wait_event(self, method, timeout=60):
        with self._lock:
            assert self._lock.wait_for(lambda: any(e["method"] == method for e in self.events), timeout), method

    def close(self):
        try:
            self.send("Browser.close", timeout=10)
        except (AssertionError, OSError):
            pass
        try:
            self.process.wait(timeout=20)
        except subprocess.TimeoutExpired:
            self.process.kill()


def test_report_loads_in_headless_chromium(local_run, tmp_path):
    browser = shutil.which("chromium") or shutil.which("chromium-browser") or shutil.which("google-chrome")
    if browser is None:
        pytest.skip("chromium is not installed (scripts/install-test-tools.sh)")
    chrome = DevTools(browser, tmp_path / "profile")
    try:
        target = chrome.send("Target.createTarget", {"url": "about:blank"})["targetId"]
        session = chrome.send("Target.attachToTarget", {"targetId": target, "flatten": True})["sessionId"]
        for domain in ("Runtime", "Log", "Page", "Network"):
            chrome.send(f"{domain}.enable", session=session)
        chrome.send(
            "Emulation.setDeviceMetricsOverride",
            {"width": 1280, "height": 1600, "deviceScaleFactor": 1, "mobile": False},
            session=session,
        )
        chrome.send("Page.navigate", {"url": (local_run / "index.html").as_uri()}, session=session)
        chrome.wait_event("Page.loadEventFired")
        time.sleep(0.5)  # late console messages
        broken = chrome.send(
            "Runtime.evaluate",
            {
                "expression": "JSON.stringify([document.images.length, Array.from(document.images)"
                ".filter(i => !(i.complete && i.naturalWidth > 0)).map(i => i.src)])",
                "returnByValue": True,
            },
            session=session,
        )["result"]["value"]
        count, missing = json.loads(broken)
        shot = chrome.send("Page.captureScreenshot", {"format": "png"}, session=session)["data"]
    finally:
        chrome.close()
    import base64

    screenshot = tmp_path / "report.png"
    screenshot.write_bytes(base64.b64decode(shot))
    assert screenshot.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and screenshot.stat().st_size > 10000
    assert count >= len(EXPERIMENTS) and missing == []
    errors = [
        e
        for e in chrome.events
        if (e["method"] == "Runtime.consoleAPICalled" and e["params"]["type"] in ("error", "assert"))
        or e["method"] == "Runtime.exceptionThrown"
        or (e["method"] == "Log.entryAdded" and e["params"]["entry"]["level"] == "error")
        or e["method"] == "Network.loadingFailed"
    ]
    assert errors == []
    requested = [e["params"]["request"]["url"] for e in chrome.events if e["method"] == "Network.requestWillBeSent"]
    assert requested and all(url.startswith(("file:", "data:")) for url in requested), requested
