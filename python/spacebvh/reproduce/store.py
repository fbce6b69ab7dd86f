# SPDX-License-Identifier: MIT
"""The result store: one JSON file per finished job, named by the job's key (a hash of everything that
decides its result), so a rerun skips finished jobs and deleting one file reruns only that job."""

from __future__ import annotations

import hashlib
import json
import os
from pathlib import Path


def job_key(inputs: dict) -> str:
    """sha256 of the inputs in canonical JSON (sorted keys, no whitespace)."""
    return hashlib.sha256(json.dumps(inputs, sort_keys=True, separators=(",", ":")).encode()).hexdigest()


class Store:
    def __init__(self, root: Path):
        self.root = Path(root)

    def path(self, experiment: str, slug: str, key: str) -> Path:
        return self.root / experiment / f"{slug}-{key[:16]}.json"

    def load(self, experiment: str, slug: str, key: str) -> dict | None:
        path = self.path(experiment, slug, key)
        try:
            with open(path) as f:
                stored = json.load(f)
        except (FileNotFoundError, json.JSONDecodeError):
            return None  # absent, or cut short by an interrupted write: the job runs again
        return stored if stored.get("key") == key and "error" not in stored.get("result", {}) else None

    def save(self, experiment: str, slug: str, key: str, inputs: dict, result: dict) -> Path:
        path = self.path(experiment, slug, key)
        path.parent.mkdir(parents=True, exist_ok=True)
        temporary = path.with_suffix(".tmp")
        with open(temporary, "w") as f:
            json.dump({"key": key, "inputs": inputs, "result": result}, f, indent=1, sort_keys=True)
        os.replace(temporary, path)  # a reader never sees half a file
        return path
