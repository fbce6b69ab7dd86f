// SPDX-License-Identifier: MIT
// The tree file's checksum as a function (not installed): the tree-file fuzz harness repairs the
// checksum of mutated files with it, so that the checks behind the checksum get exercised too.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>

namespace spacebvh::tree_file_detail {

// The checksum stored in a tree file's last 8 bytes, over the bytes before them.
uint64_t checksum(std::span<const std::byte> covered);

}  // namespace spacebvh::tree_file_detail
