#!/usr/bin/env python3
# SPDX-License-Identifier: MIT
"""The size check of the test command: no source file of ours over 500 lines, no function over 120.

Small files and short functions are what keep the code readable one concern at a time, so the
limits are enforced rather than remembered. Tests are exempt: a test file is a list of cases, not
a design. C++ functions (member functions and lambdas too) are found by Universal Ctags, with their
start and end lines; Python functions by the `ast` module. A lambda counts on its own and as part of
the function that holds it.

Usage: python3 scripts/check-sizes.py   (exits 1 and lists every file and function over its limit)
"""

import ast
import json
import os
import re
import subprocess
import sys

MAX_FILE_LINES = 500
MAX_FUNCTION_LINES = 120
CHECKED_DIRS = ("src", "include", "apps", "python/src", "python/spacebvh", "bench", "fuzz", "examples", "scripts")
CPP_SUFFIXES = (".cpp", ".cc", ".hpp", ".h", ".inl")
PYTHON_SUFFIXES = (".py", ".pyi")
SHELL_SUFFIXES = (".sh",)
# Written by a program, not by us: the type stub comes from the built module (scripts/generate-stubs.sh).
GENERATED_FILES = ("python/spacebvh/_core.pyi",)
# Known to be over a limit, each with the work that ends it; listed, so that nothing new joins them.
KNOWN_OVER: dict[str, str] = {}


def checked_files(root):
    """Tracked and not-ignored untracked files, so build outputs and virtual environments never count."""
    listing = subprocess.run(
        ["git", "ls-files", "-z", "--cached", "--others", "--exclude-standard", "--", *CHECKED_DIRS],
        cwd=root, check=True, capture_output=True, text=True).stdout
    suffixes = CPP_SUFFIXES + PYTHON_SUFFIXES + SHELL_SUFFIXES
    return sorted(path for path in listing.split("\0")
                  if path.endswith(suffixes) and path not in GENERATED_FILES and os.path.isfile(os.path.join(root, path)))


def line_count(path):
    with open(path, encoding="utf-8", errors="replace") as file:
        return sum(1 for _ in file)


def cpp_functions(root, paths):
    """(path, qualified name, first line, last line) of every C++ function definition."""
    if not paths:
        return []
    # --language-force: .inl is no C++ extension to ctags. Kind f is a definition (p would be a
    # declaration); `end` is the line of its closing brace. The default extras keep the tags of file
    # scope: functions in anonymous namespaces, member functions defined in a class, lambdas.
    command = ["ctags", "--output-format=json", "--language-force=C++", "--kinds-C++=f", "--fields=+ne", "-o", "-",
               *paths]
    try:
        output = subprocess.run(command, cwd=root, check=True, capture_output=True, text=True).stdout
    except FileNotFoundError:
        sys.exit("check-sizes: Universal Ctags (ctags) is needed to measure C++ functions")
    functions = []
    for line in output.splitlines():
        tag = json.loads(line)
        if tag.get("_type") != "tag" or "end" not in tag:
            continue
        name = tag["name"] if "scope" not in tag else tag["scope"] + "::" + tag["name"]
        # Ctags names anonymous namespaces and lambdas __anonNNNN.
        name = re.sub(r"__anon\w+$", "(lambda)", name)
        name = re.sub(r"__anon\w+::", "(anonymous)::", name)
        functions.append((tag["path"], name, tag["line"], tag["end"]))
    return functions


def python_functions(root, path):
    with open(os.path.join(root, path), encoding="utf-8") as file:
        tree = ast.parse(file.read(), filename=path)
    functions = []
    for node in ast.walk(tree):
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
            # Decorators are part of the definition a reader has to take in.
            first = min([node.lineno] + [decorator.lineno for decorator in node.decorator_list])
            functions.append((path, node.name, first, node.end_lineno))
    return functions


def main():
    root = os.path.normpath(os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))
    paths = checked_files(root)
    failures = []
    for path in paths:
        lines = line_count(os.path.join(root, path))
        if lines > MAX_FILE_LINES and path in KNOWN_OVER:
            print(f"check-sizes: {path}: {lines} lines, known: {KNOWN_OVER[path]}")
        elif lines > MAX_FILE_LINES:
            failures.append(f"{path}: {lines} lines (file limit {MAX_FILE_LINES})")
    for path in KNOWN_OVER:
        if path in paths and line_count(os.path.join(root, path)) <= MAX_FILE_LINES:
            failures.append(f"{path}: within the limits now; take it off KNOWN_OVER")
    functions = cpp_functions(root, [path for path in paths if path.endswith(CPP_SUFFIXES)])
    for path in paths:
        if path.endswith(PYTHON_SUFFIXES):
            functions += python_functions(root, path)
    for path, name, first, last in sorted(functions):
        lines = last - first + 1
        if lines > MAX_FUNCTION_LINES:
            failures.append(f"{path}:{first}: {name} is {lines} lines (function limit {MAX_FUNCTION_LINES})")
    for failure in failures:
        print(failure)
    if failures:
        print(f"check-sizes: {len(failures)} over the limits above; split them by concern", file=sys.stderr)
        return 1
    print(f"check-sizes: {len(paths)} files, {len(functions)} functions within {MAX_FILE_LINES} and "
          f"{MAX_FUNCTION_LINES} lines")
    return 0


if __name__ == "__main__":
    sys.exit(main())
