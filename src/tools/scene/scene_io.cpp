// SPDX-License-Identifier: MIT
// File reading and error formatting shared by the loaders.
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <memory>

#include "tools/scene/scene_internal.hpp"

namespace spacebvh::tools::scene_detail {

std::string read_file_bytes(const std::string& path) {
    std::error_code ec;
    if (std::filesystem::is_directory(path, ec)) throw Error("cannot read scene file '" + path + "': is a directory");
    std::unique_ptr<std::FILE, int (*)(std::FILE*)> file(std::fopen(path.c_str(), "rb"), &std::fclose);
    if (!file) throw Error("cannot open scene file '" + path + "': " + std::strerror(errno));
    // Read in chunks rather than trusting a size query: works for pipes and files that change size.
    std::string bytes;
    char chunk[1 << 16];
    uintmax_t expected = std::filesystem::file_size(path, ec);
    if (!ec) bytes.reserve(static_cast<size_t>(expected));
    for (;;) {
        size_t got = std::fread(chunk, 1, sizeof chunk, file.get());
        bytes.append(chunk, got);
        if (got < sizeof chunk) break;
    }
    if (std::ferror(file.get())) throw Error("cannot read scene file '" + path + "': read error");
    return bytes;
}

void fail_at_line(const std::string& path, size_t line, const std::string& what) {
    throw Error(path + ":" + std::to_string(line) + ": " + what);
}

void fail_at(const std::string& path, const std::string& where, const std::string& what) {
    throw Error(path + ": " + where + ": " + what);
}

std::string quote_token(std::string_view token) {
    constexpr size_t kMaxShown = 40;
    std::string shown;
    for (char c : token.substr(0, kMaxShown)) {
        unsigned char u = static_cast<unsigned char>(c);
        if (u >= 32 && u < 127) {
            shown += c;
        } else {
            char hex[8];
            std::snprintf(hex, sizeof hex, "\\x%02x", u);
            shown += hex;
        }
    }
    if (token.size() > kMaxShown) shown += "...";
    return "'" + shown + "'";
}

}  // namespace spacebvh::tools::scene_detail
