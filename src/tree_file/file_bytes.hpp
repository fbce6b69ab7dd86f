// SPDX-License-Identifier: MIT
// What tree files and scene files share (not installed): little-endian fields whatever the host's byte
// order, and reading or writing a whole file at once with errors that name the path.
#pragma once

#include <bit>
#include <cerrno>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "spacebvh/error.hpp"

namespace spacebvh::tree_file_detail {

constexpr bool kLittleHost = std::endian::native == std::endian::little;
static_assert(kLittleHost || std::endian::native == std::endian::big, "mixed-endian hosts are not supported");

constexpr uint64_t byte_swap(uint64_t x) {
    uint64_t y = 0;
    for (int i = 0; i < 8; ++i) y |= ((x >> (8 * i)) & 0xFF) << (8 * (7 - i));
    return y;
}
constexpr uint32_t byte_swap(uint32_t x) { return uint32_t(byte_swap(uint64_t(x)) >> 32); }

template <class T>
T load_le(const std::byte* p) {
    T value;
    std::memcpy(&value, p, sizeof value);
    if constexpr (!kLittleHost) value = byte_swap(value);
    return value;
}
template <class T>
void store_le(std::byte* p, T value) {
    if constexpr (!kLittleHost) value = byte_swap(value);
    std::memcpy(p, &value, sizeof value);
}
// memcpy of zero bytes is still undefined when a pointer is null, as an empty vector's or string's
// data() may be (a tree without primitives, a builder without settings).
inline void copy_bytes(void* to, const void* from, size_t count) {
    if (count != 0) std::memcpy(to, from, count);
}
inline float load_f32(const std::byte* p) { return std::bit_cast<float>(load_le<uint32_t>(p)); }
inline void store_f32(std::byte* p, float value) { store_le(p, std::bit_cast<uint32_t>(value)); }

constexpr uint64_t pad8(uint64_t n) { return (n + 7) & ~uint64_t(7); }

inline std::string hex(uint64_t value) {
    char text[24];
    std::snprintf(text, sizeof text, "%016llx", static_cast<unsigned long long>(value));
    return text;
}

struct FileCloser {
    void operator()(std::FILE* f) const { std::fclose(f); }
};
using File = std::unique_ptr<std::FILE, FileCloser>;

// `bytes` written to `path` (replaced if present).
inline void write_file(const std::string& path, std::span<const std::byte> bytes) {
    File file(std::fopen(path.c_str(), "wb"));
    if (!file) throw Error(path + ": cannot open for writing (" + std::strerror(errno) + ")");
    const bool written = std::fwrite(bytes.data(), 1, bytes.size(), file.get()) == bytes.size();
    if (!written || std::fclose(file.release()) != 0)
        throw Error(path + ": write failed (" + std::strerror(errno) + ")");
}

// The whole file at `path`, read in one read; `what` names the kind of file in errors.
inline std::vector<std::byte> read_file(const std::string& path, const char* what) {
    std::error_code error;
    if (std::filesystem::is_directory(path, error)) throw Error(path + ": is a directory, not a " + what);
    File file(std::fopen(path.c_str(), "rb"));
    if (!file) throw Error(path + ": cannot open (" + std::strerror(errno) + ")");
    if (std::fseek(file.get(), 0, SEEK_END) != 0) throw Error(path + ": cannot determine the file size");
    const long end = std::ftell(file.get());
    if (end < 0 || std::fseek(file.get(), 0, SEEK_SET) != 0) throw Error(path + ": cannot determine the file size");
    std::vector<std::byte> bytes(static_cast<size_t>(end));
    if (std::fread(bytes.data(), 1, bytes.size(), file.get()) != bytes.size())
        throw Error(path + ": read error (" + std::strerror(errno) + ")");
    return bytes;
}

}  // namespace spacebvh::tree_file_detail
