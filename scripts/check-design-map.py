#!/usr/bin/env python3
# SPDX-License-Identifier: MIT
"""docs/design.md's layout map against the tree: every folder of the library, the CLI and the Python
package has a line in the map, and every folder the map names exists. Part of the test command."""

import pathlib
import re
import sys

ROOT = pathlib.Path(__file__).resolve().parent.parent
# Folders whose every subfolder (with source files) the map must name.
MAPPED_TREES = ["include/spacebvh", "src", "apps", "python/src", "python/spacebvh"]
SOURCE_SUFFIXES = {".cpp", ".hpp", ".inl", ".h", ".py"}


def map_entries() -> set[str]:
    text = (ROOT / "docs/design.md").read_text()
    block = re.search(r"## Data flow.*?```\n(.*?)```", text, re.S)
    if not block:
        sys.exit("check-design-map: no layout block under '## Data flow' in docs/design.md")
    return {m.group(1).rstrip("/") for m in re.finditer(r"^(\S+/)\s", block.group(1), re.M)}


def source_folders() -> set[str]:
    folders = set()
    for top in MAPPED_TREES:
        for path in (ROOT / top).rglob("*"):
            if path.is_file() and path.suffix in SOURCE_SUFFIXES and "__pycache__" not in path.parts:
                folders.add(str(path.parent.relative_to(ROOT)))
    return folders


def main() -> int:
    entries = map_entries()
    unmapped = sorted(source_folders() - entries)
    missing = sorted(e for e in entries if not (ROOT / e).is_dir())
    for folder in unmapped:
        print(f"check-design-map: {folder}/ holds sources but has no line in docs/design.md's map")
    for folder in missing:
        print(f"check-design-map: docs/design.md's map names {folder}/, which does not exist")
    if unmapped or missing:
        return 1
    print(f"check-design-map: docs/design.md's map names all {len(entries)} folders, each present")
    return 0


if __name__ == "__main__":
    sys.exit(main())
