# SPDX-License-Identifier: MIT
"""Where a kernel's instructions go, by the function they were inlined from: reads a callgrind profile
taken with --dump-instr=yes of a -g build (bench/work_per_ray.sh's program, for one), charges each
instruction of BINARY to the innermost function of ours (a path under SOURCE_ROOT) that
`addr2line -i` finds inlined at its address, and prints the shares. callgrind_annotate alone charges
inlined intrinsics to the compiler's headers, which says nothing about which part of the kernel runs.

Usage: python3 bench/callgrind_by_function.py PROFILE BINARY [SOURCE_ROOT (default: this checkout's src/)]"""

import collections
import pathlib
import re
import subprocess
import sys


def self_costs(profile: str, binary_name: str) -> collections.Counter:
    """Instructions per address of the object named binary_name (self cost: call lines skipped)."""
    names, cost = {}, collections.Counter()
    obj, address, call_line_next = None, 0, False
    for line in open(profile):
        line = line.rstrip("\n")
        m = re.match(r"^c?ob=\((\d+)\)(?: (.*))?$", line)
        if m:
            if m.group(2):
                names[m.group(1)] = m.group(2)
            if line.startswith("ob="):
                obj = names.get(m.group(1))
            continue
        if line.startswith("calls="):
            call_line_next = True  # the next cost line is the call's inclusive cost
            continue
        if not line or line[0] not in "0123456789+-*":
            continue
        fields = line.split()
        if fields[0].startswith("0x"):
            address = int(fields[0], 16)
        elif fields[0][0] in "+-":
            address += int(fields[0])
        if call_line_next:
            call_line_next = False
            continue
        if obj and obj.endswith(binary_name) and len(fields) >= 3:
            cost[address] += int(fields[2])
    return cost


def inline_chains(binary: str, addresses) -> dict:
    """address -> [(function, file:line), ...], innermost first."""
    lines = subprocess.run(
        ["addr2line", "-e", binary, "-i", "-f", "-C", "-a", *map(hex, addresses)],
        capture_output=True,
        text=True,
        check=True,
    ).stdout.splitlines()
    chains, current, i = {}, None, 0
    while i < len(lines):
        if lines[i].startswith("0x"):
            current = int(lines[i], 16)
            chains[current] = []
            i += 1
        else:
            chains[current].append((lines[i], lines[i + 1] if i + 1 < len(lines) else ""))
            i += 2
    return chains


def main() -> int:
    if len(sys.argv) < 3:
        print(__doc__)
        return 2
    profile, binary = sys.argv[1], sys.argv[2]
    root = sys.argv[3] if len(sys.argv) > 3 else str(pathlib.Path(__file__).resolve().parents[1] / "src")
    cost = self_costs(profile, pathlib.Path(binary).name)
    total = sum(cost.values())
    if not total:
        print(f"no instructions of {binary} in {profile}")
        return 1
    chains = inline_chains(binary, list(cost))
    by_function = collections.Counter()
    for address, instructions in cost.items():
        chain = chains.get(address, [])
        ours = [function for function, location in chain if location.startswith(root)]
        name = (ours[0] if ours else chain[-1][0] if chain else "?").split("(")[0]
        by_function[name] += instructions
    print(f"{total} instructions of {binary}")
    for name, instructions in by_function.most_common(30):
        print(f"{100.0 * instructions / total:6.2f} %  {name}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
