#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# The Python package's test: `pip install .` into a fresh virtual environment (build/venv), import
# it there, check the Python sources with ruff and the committed type stub against one generated from
# the installed module, then run python/tests with pytest (its summary line is the last line of the
# output). Any of these failing fails the script.
# scripts/test.sh runs it after the C++ suite; run alone it builds the C++ itself (through pip).
set -euo pipefail
cd "$(dirname "$0")/.."
venv="$PWD/build/venv"
rm -rf "$venv" build-pip
mkdir -p build
python3 -m venv "$venv"
# The C++ that scripts/build.sh compiled is compiled again here with the same flags: ccache answers
# it. The build folder sits beside ./build so ccache's base_dir rewriting sees the same relative paths.
if command -v ccache >/dev/null; then
  export CMAKE_CXX_COMPILER_LAUNCHER=ccache CCACHE_BASEDIR="${CCACHE_BASEDIR:-$PWD}"
fi
start=$SECONDS
# The developers' install: -march=native, Embree (EmbreeTracer, Embree's trees) and the command-line
# tool, which the self-contained wheel (pyproject.toml's defaults, scripts/test-wheel.sh) leaves out;
# with the tests' optional packages and the benchmark scripts' peers (the `bench` extra), so that this
# environment runs every script in bench/ too.
developer=(-C cmake.define.SPACEBVH_NATIVE=ON -C cmake.define.SPACEBVH_WITH_EMBREE=ON -C cmake.define.SPACEBVH_BUILD_APPS=ON)
"$venv/bin/python" -m pip install --quiet --disable-pip-version-check -C build-dir=build-pip "${developer[@]}" \
  ".[test,trimesh-tests,open3d-tests,reproduce,bench]"
echo "pip install . took $((SECONDS - start)) s"
rm -rf build-pip
# Outside the repository, so that only the installed package can be imported.
(cd / && "$venv/bin/python" -c "import spacebvh; print('import spacebvh:', spacebvh.__version__, spacebvh.__file__)")
# Lint and format (pyproject.toml [tool.ruff]) of the package, its tests and the benchmark scripts.
"$venv/bin/ruff" check python bench
"$venv/bin/ruff" format --check python bench
# python/spacebvh/_core.pyi is generated from the module: a binding change needs it regenerated.
bash scripts/generate-stubs.sh --check "$venv/bin/python"
# Exit status 5 (no tests collected) fails this script too: an empty run must not read as a pass.
PATH="$venv/bin:$PATH" "$venv/bin/python" -m pytest -ra python/tests
