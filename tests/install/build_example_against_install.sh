#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# build_example_against_install.sh BUILD_DIR SOURCE_DIR [CMAKE]: installs the build into a fresh
# prefix, then builds and runs, each as an outside CMake project that finds the package with
# find_package(spacebvh) and sets no C++ standard of its own (so the compiler's default, C++17 for
# g++ 12, is all it asks for, and the targets' usage requirements must supply C++20):
#   1. the README's C++ example with the README's two CMake lines, both taken from README.md itself,
#      so that what the README promises is what this test builds;
#   2. examples/minimal, as its CMakeLists.txt says it can be built;
#   3. examples/render, which links spacebvh::tools (scenes, rays, PNG output, Embree when built in).
set -euo pipefail
build=$1; source=$2; cmake=${3:-cmake}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
"$cmake" --install "$build" --prefix "$work/prefix" >/dev/null
launcher=()
command -v ccache >/dev/null && launcher=(-DCMAKE_CXX_COMPILER_LAUNCHER=ccache)

# configure_and_build NAME PROJECT_DIR: a Release build of PROJECT_DIR into $work/NAME. The output of
# a failed step is shown (it names the missing requirement); a passing one stays quiet.
configure_and_build() {
  local name=$1 dir=$2 log="$work/$1.log"
  if ! "$cmake" -S "$dir" -B "$work/$name" -DCMAKE_PREFIX_PATH="$work/prefix" -DCMAKE_BUILD_TYPE=Release \
         "${launcher[@]}" >"$log" 2>&1 ||
     ! "$cmake" --build "$work/$name" >>"$log" 2>&1; then
    cat "$log"
    echo "FAILED: $name does not build against the installed package" >&2
    return 1
  fi
}

# The README's snippets: the first ```cmake block (its "Then in your project:" lines) and the first
# ```cpp block after the "## C++" heading (its example program).
readme="$source/README.md"
cmake_lines=$(awk '/^```cmake$/ {inside = 1; next} inside && /^```$/ {exit} inside' "$readme")
cpp_example=$(awk '/^## C\+\+$/ {section = 1} section && /^```cpp$/ {inside = 1; next}
                   inside && /^```$/ {exit} inside' "$readme")
if ! grep -q 'find_package(spacebvh' <<<"$cmake_lines" || ! grep -q 'target_link_libraries(app ' <<<"$cmake_lines" ||
   ! grep -q 'int main' <<<"$cpp_example"; then
  echo "FAILED: README.md's CMake lines or C++ example not found where this test looks for them" >&2
  exit 1
fi
mkdir "$work/readme"
printf '%s\n' "$cpp_example" >"$work/readme/main.cpp"
{
  echo "cmake_minimum_required(VERSION 3.25)"
  echo "project(readme_example LANGUAGES CXX)"
  echo "add_executable(app main.cpp)"
  printf '%s\n' "$cmake_lines"
} >"$work/readme/CMakeLists.txt"
configure_and_build readme-build "$work/readme"
output=$("$work/readme-build/app")
echo "README example: $output"
# Both programs trace a ray at a unit square one unit away: it must hit at t = 1.
grep -q "t = 1 on triangle" <<<"$output"

configure_and_build minimal "$source/examples/minimal"
output=$("$work/minimal/minimal")
echo "examples/minimal: $output"
grep -q "t = 1 on triangle" <<<"$output"

configure_and_build render "$source/examples/render"
output=$(cd "$work" && "$work/render/render_example" builtin:interior render.png)
echo "examples/render: $output"
test -s "$work/render.png"
