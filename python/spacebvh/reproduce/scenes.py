# SPDX-License-Identifier: MIT
"""Scene specifications: a file, `builtin:NAME` or `generated:terrain:SIZE`, with load-time transforms
written after '@' (`crytek_sponza.obj@rotate=x:45,y:45,z:45`, `scene.ply@scale=2;translate=0 0 1`),
and their content hashes (the part of a job's key that says which triangles it saw)."""

from __future__ import annotations

import hashlib
import os
import re
from dataclasses import dataclass, field
from pathlib import Path

TRANSFORM_KEYS = ("rotate", "scale", "translate")
# The shared scenes a full run uses (the folder of --scenes-dir, $SPACEBVH_SCENES or ../shared/scenes beside
# the checkout), and Sponza rotated 45/45/45: the classic stress case of the collection's MANIFEST.md.
SHARED_SCENES = ("bunny", "sibenik", "coffee_maker", "crytek_sponza", "living_room_3")
ROTATION = "x:45,y:45,z:45"
# The quick run: two built-in scenes (the rotated one is the "rotated Sponza" case) and a small
# generated one for the experiments whose builders are too slow for 84k triangles in a test.
QUICK_SCENES = ("builtin:interior", "builtin:interior-rotated", "generated:terrain:40")


@dataclass(frozen=True)
class Scene:
    source: str  # a path (absolute), builtin:NAME or generated:...
    transforms: tuple = field(default=())  # ((key, value), ...) in the order given
    manifest: str = ""  # the MANIFEST.md whose camera table gives a file's camera ("": none)

    @property
    def flags(self) -> list[str]:
        flags = []
        for key, value in self.transforms:
            flags.append(f"--{key}")
            flags += value.split() if key == "translate" else [value]
        return flags

    @property
    def base_name(self) -> str:
        if self.source.startswith(("builtin:", "generated:")):
            return self.source.split(":", 1)[1].replace(":", "-")
        return Path(self.source).stem

    @property
    def label(self) -> str:
        """Human name: `crytek_sponza rotated x:45,y:45,z:45`."""
        words = [self.base_name]
        for key, value in self.transforms:
            words.append({"rotate": "rotated", "scale": "scaled", "translate": "moved"}[key] + " " + value)
        return " ".join(words)

    @property
    def slug(self) -> str:
        """File-name form of the label."""
        text = self.base_name
        for key, value in self.transforms:
            text += "-" + key[:3] + "-" + value
        return re.sub(r"[^A-Za-z0-9_.-]+", "", text.replace(":", "").replace(",", "-").replace(" ", "_"))

    @property
    def is_file(self) -> bool:
        return not self.source.startswith(("builtin:", "generated:"))

    @property
    def is_rotated(self) -> bool:
        return any(key == "rotate" for key, _ in self.transforms) or self.source.endswith("-rotated")

    @property
    def camera_flags(self) -> list[str]:
        """What the CLI's camera-taking commands (compare, render) need to find this scene's camera."""
        return ["--manifest", self.manifest] if self.manifest and self.is_file else []

    def to_json(self) -> dict:
        return {"source": self.source, "flags": self.flags, "camera_flags": self.camera_flags, "label": self.label}


def parse_scene(text: str, manifest: str | Path | None = None) -> Scene:
    """`PATH[@key=value[;key=value...]]`; keys: rotate, scale, translate (as the CLI's --rotate etc.).
    `manifest`: the scene collection's MANIFEST.md, whose camera a listed file's primary rays start from."""
    source, _, options = text.partition("@")
    if not source:
        raise ValueError(f"scene '{text}': no file or builtin:NAME before '@'")
    transforms = []
    for item in filter(None, options.split(";")):
        key, equals, value = item.partition("=")
        key = key.strip()
        if not equals or key not in TRANSFORM_KEYS or not value.strip():
            raise ValueError(f"scene '{text}': expected rotate=..., scale=... or translate=... after '@', got '{item}'")
        transforms.append((key, value.strip()))
    if not source.startswith(("builtin:", "generated:")):
        path = Path(source).expanduser()
        if not path.is_file():
            raise FileNotFoundError(f"scene file not found: {source}")
        source = str(path.resolve())
    return Scene(source, tuple(transforms), str(Path(manifest).resolve()) if manifest else "")


def content_hash(scene: Scene, library_version: str) -> str:
    """sha256 of what the scene is: the file's bytes, or for built-in and generated scenes their name
    under this library version (their triangles are the library's or the job code's), plus the
    transforms."""
    digest = hashlib.sha256()
    if scene.is_file:
        with open(scene.source, "rb") as f:
            for block in iter(lambda: f.read(1 << 20), b""):
                digest.update(block)
    else:
        digest.update(scene.source.encode())
        if scene.source.startswith("builtin:"):
            digest.update(library_version.encode())
        else:
            from .jobs import GENERATOR_VERSION

            digest.update(f"generator {GENERATOR_VERSION}".encode())
    for key, value in scene.transforms:
        digest.update(f"\0{key}={value}".encode())
    if scene.camera_flags:  # the camera decides the primary and diffuse rays
        with open(scene.manifest, "rb") as f:
            digest.update(b"\0manifest\0" + f.read())
    return digest.hexdigest()


def shared_scenes_dir(repo: Path, given: str | Path | None = None) -> Path | None:
    """The shared scene folder: `given` (--scenes-dir), else $SPACEBVH_SCENES, else ../shared/scenes beside the
    checkout `repo` (worktrees live directly under one folder with shared/) or shared/scenes inside it. None
    when the chosen folder is absent."""
    chosen = given or os.environ.get("SPACEBVH_SCENES")
    candidates = [Path(chosen)] if chosen else [repo.parent / "shared" / "scenes", repo / "shared" / "scenes"]
    return next((c for c in candidates if c.is_dir()), None)


def scene_manifest(given: str | Path | None = None, scenes_dir: Path | None = None) -> str | None:
    """The MANIFEST.md for scene cameras: `given` (--manifest), else $SPACEBVH_SCENE_MANIFEST, else the one in
    `scenes_dir` when present. Raises FileNotFoundError for a named file that is absent."""
    chosen = given or os.environ.get("SPACEBVH_SCENE_MANIFEST")
    if chosen:
        if not Path(chosen).is_file():
            raise FileNotFoundError(f"scene manifest not found: {chosen}")
        return str(chosen)
    if scenes_dir is not None and (scenes_dir / "MANIFEST.md").is_file():
        return str(scenes_dir / "MANIFEST.md")
    return None


def default_full_scenes(root: Path | None, manifest: str | None) -> tuple[list[Scene], list[str]]:
    """The shared scenes in `root` that are present and crytek_sponza rotated, with `manifest`'s cameras;
    notes for the missing ones."""
    if root is None:
        return [], [
            "no shared scene folder (--scenes-dir, SPACEBVH_SCENES or ../shared/scenes beside the "
            "checkout): no shared scene was run (use --scenes or --quick)"
        ]
    scenes, notes = [], []
    for name in SHARED_SCENES:
        path = root / name / f"{name}.obj"
        if path.is_file():
            scenes.append(parse_scene(str(path), manifest))
            if name == "crytek_sponza":
                scenes.append(parse_scene(f"{path}@rotate={ROTATION}", manifest))
        else:
            notes.append(f"{path} is absent: skipped")
    return scenes, notes
