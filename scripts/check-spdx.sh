#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# Lists the tracked source, header, script and CMake files whose first line (the second after a
# shebang) is not an SPDX licence identifier, and exits 1 when there are any.
# Usage: bash scripts/check-spdx.sh
set -euo pipefail
cd "$(dirname "$0")/.."
missing=0
while IFS= read -r -d '' file; do
    [ -f "$file" ] || continue  # deleted in the work tree
    line=$(head -n 1 -- "$file")
    if [[ $line == '#!'* ]]; then
        line=$(sed -n 2p -- "$file")
    fi
    if [[ $line != *'SPDX-License-Identifier: MIT'* ]] || [[ $line != '//'* && $line != '#'* ]]; then
        echo "$file"
        missing=1
    fi
done < <(git ls-files -z --cached --others --exclude-standard -- \
    '*.cpp' '*.hpp' '*.h' '*.inl' '*.py' '*.pyi' '*.sh' 'CMakeLists.txt' '*/CMakeLists.txt' '*.cmake' '*.cmake.in' \
    '.ci/run')
if [ "$missing" -ne 0 ]; then
    echo "check-spdx: the files above lack '// SPDX-License-Identifier: MIT' (or '# ...') as their first line" >&2
    exit 1
fi
