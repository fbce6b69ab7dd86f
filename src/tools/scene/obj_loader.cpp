// SPDX-License-Identifier: MIT
// Wavefront OBJ reader: `v` and `f` records only (everything else is ignored), polygons fan-triangulated
// (v0, vi, vi+1) in file order across all objects and groups.
// Hand-written rather than tinyobjloader: tinyobjloader 2.0rc10 parses malformed numbers as 0 and
// reports no line numbers, and we must reject bad input naming the line.
#include <cstring>
#include <limits>

#include "tools/scene/scene_internal.hpp"

namespace spacebvh::tools::scene_detail {
namespace {

bool is_blank(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\v' || c == '\f'; }

// Splits one line into whitespace-separated tokens.
struct Tokens {
    const char* pos;
    const char* end;
    bool next(std::string_view& token) {
        while (pos < end && is_blank(*pos)) ++pos;
        if (pos == end) return false;
        const char* start = pos;
        while (pos < end && !is_blank(*pos)) ++pos;
        token = std::string_view(start, static_cast<size_t>(pos - start));
        return true;
    }
};

bool parse_integer(std::string_view text, int64_t& value) {
    if (text.empty()) return false;
    auto [ptr, ec] = std::from_chars(text.data(), text.data() + text.size(), value);
    return ec == std::errc() && ptr == text.data() + text.size();
}

// "i", "i/t", "i//n", "i/t/n": returns the text of the first (vertex) index; the others must be
// integers or empty, since we do not use them.
bool split_vertex_reference(std::string_view token, std::string_view& vertex_part) {
    size_t slash = token.find('/');
    vertex_part = token.substr(0, slash);
    if (slash == std::string_view::npos) return true;
    std::string_view rest = token.substr(slash + 1);
    size_t second = rest.find('/');
    std::string_view texcoord = rest.substr(0, second);
    int64_t unused;
    if (!texcoord.empty() && !parse_integer(texcoord, unused)) return false;
    if (second == std::string_view::npos) return !texcoord.empty();
    std::string_view normal = rest.substr(second + 1);
    return parse_integer(normal, unused);
}

}  // namespace

std::vector<Triangle> load_obj(const std::string& path) { return parse_obj(read_file_bytes(path), path); }

std::vector<Triangle> parse_obj(std::string_view data, const std::string& path) {
    std::vector<Vec3> vertices;
    std::vector<uint32_t> corners;  // 3 vertex indices (0-based) per triangle
    // Positive indices may refer forward (to vertices defined later in the file); the largest one is
    // checked once all vertices are known, with its line kept for the message.
    int64_t largest_index = 0;
    size_t largest_index_line = 0;

    std::vector<uint32_t> polygon;
    const char* pos = data.data();
    const char* const end = pos + data.size();
    size_t line = 0;
    while (pos < end) {
        ++line;
        const char* eol = static_cast<const char*>(std::memchr(pos, '\n', static_cast<size_t>(end - pos)));
        if (eol == nullptr) eol = end;
        const char* comment = static_cast<const char*>(std::memchr(pos, '#', static_cast<size_t>(eol - pos)));
        Tokens tokens{pos, comment ? comment : eol};
        pos = eol + (eol < end ? 1 : 0);

        std::string_view keyword;
        if (!tokens.next(keyword)) continue;
        if (keyword == "v") {
            Vec3 p;
            std::string_view token;
            for (int axis = 0; axis < 3; ++axis) {
                if (!tokens.next(token)) fail_at_line(path, line, "vertex needs 3 coordinates");
                NumberStatus status = parse_float(token, p[axis]);
                if (status != NumberStatus::ok)
                    fail_at_line(path, line,
                                 std::string(describe(status)) + " " + quote_token(token) + " in vertex coordinate");
            }
            // Optional w or vertex colour: must still be numbers, or the line is not what we think it is.
            while (tokens.next(token)) {
                float extra;
                if (parse_float(token, extra) != NumberStatus::ok)
                    fail_at_line(path, line, "unexpected " + quote_token(token) + " after vertex coordinates");
            }
            vertices.push_back(p);
        } else if (keyword == "f") {
            polygon.clear();
            std::string_view token;
            while (tokens.next(token)) {
                std::string_view vertex_part;
                int64_t index = 0;
                if (!split_vertex_reference(token, vertex_part) || !parse_integer(vertex_part, index))
                    fail_at_line(path, line, "malformed face vertex " + quote_token(token));
                const int64_t count = static_cast<int64_t>(vertices.size());
                if (index == 0) fail_at_line(path, line, "face vertex index 0 (OBJ indices start at 1)");
                if (index < 0) {
                    // Relative index: -1 is the most recently defined vertex.
                    if (-index > count)
                        fail_at_line(path, line,
                                     "relative vertex index " + std::to_string(index) + " but only " +
                                         std::to_string(count) + " vertices are defined so far");
                    index = count + index + 1;
                }
                if (index > static_cast<int64_t>(std::numeric_limits<uint32_t>::max()))
                    fail_at_line(path, line, "vertex index " + std::to_string(index) + " out of range");
                if (index > largest_index) {
                    largest_index = index;
                    largest_index_line = line;
                }
                polygon.push_back(static_cast<uint32_t>(index - 1));
            }
            if (polygon.size() < 3)
                fail_at_line(path, line,
                             "face has " + std::to_string(polygon.size()) + " vertices, at least 3 are needed");
            for (size_t i = 1; i + 1 < polygon.size(); ++i) {
                corners.push_back(polygon[0]);
                corners.push_back(polygon[i]);
                corners.push_back(polygon[i + 1]);
            }
        }
        // vt, vn, o, g, s, usemtl, mtllib, l, p and the free-form records carry no triangles.
    }

    if (largest_index > static_cast<int64_t>(vertices.size()))
        fail_at_line(path, largest_index_line,
                     "vertex index " + std::to_string(largest_index) + " out of range: the file has " +
                         std::to_string(vertices.size()) + " vertices");
    if (corners.empty()) throw Error(path + ": no triangles (no 'f' records) in " + std::to_string(line) + " lines");
    std::vector<Triangle> triangles(corners.size() / 3);
    for (size_t t = 0; t < triangles.size(); ++t)
        triangles[t] = {vertices[corners[3 * t]], vertices[corners[3 * t + 1]], vertices[corners[3 * t + 2]]};
    return triangles;
}

}  // namespace spacebvh::tools::scene_detail
