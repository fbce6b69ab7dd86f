// SPDX-License-Identifier: MIT
// The readers of outside data, each behind one entry that takes raw bytes: the libFuzzer harnesses
// (fuzz_main.cpp) and the regression test (tests/test_fuzz_regressions.cpp) feed them the same way.
#pragma once

#include <cstdint>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "spacebvh/geometry.hpp"

namespace spacebvh::fuzz {

// obj, ply, gltf (.gltf and GLB bytes), gltf_instances (the same bytes as an instanced scene, built and
// traced), ray_file, hit_file, tree_file, scene_file (a scene tree file, loaded and traced), builder_spec.
const std::vector<std::string>& target_names();

// Feeds `bytes` to the reader named `target` and uses what it returns (a loaded tree is traced by
// every kernel; a parsed builder row is validated). Returns on success, throws spacebvh::Error for a clean rejection;
// anything else (another exception, a crash, a sanitizer report, a hang) is a bug in the reader.
// tree_file and scene_file: byte 0 is a mode; when its low bit is set, the file size field and the checksum of the
// remaining bytes are repaired first, so that the checks behind the checksum are reached.
void feed(std::string_view target, std::span<const uint8_t> bytes);

// The geometry the tree_file target validates trees against (and the seeds are built over): a few
// dozen triangles, some overlapping, some degenerate.
const std::vector<Triangle>& fuzz_geometry();

}  // namespace spacebvh::fuzz
