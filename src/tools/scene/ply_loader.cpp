// SPDX-License-Identifier: MIT
// PLY reader (Turk 1994; format as documented by Paul Bourke, "PLY - Polygon File Format"):
// ascii, binary_little_endian and binary_big_endian. Uses vertex x/y/z and the face list
// `vertex_indices` (or `vertex_index`); every other element and property is read and skipped.
// Faces are fan-triangulated (v0, vi, vi+1) in file order.
#include <bit>
#include <cstdio>
#include <cstring>
#include <limits>

#include "tools/scene/scene_internal.hpp"

namespace spacebvh::tools::scene_detail {
namespace {

enum class Type { int8, uint8, int16, uint16, int32, uint32, float32, float64 };

size_t type_size(Type type) {
    switch (type) {
        case Type::int8:
        case Type::uint8:
            return 1;
        case Type::int16:
        case Type::uint16:
            return 2;
        case Type::int32:
        case Type::uint32:
        case Type::float32:
            return 4;
        case Type::float64:
            return 8;
    }
    return 0;
}

bool is_integer_type(Type type) { return type != Type::float32 && type != Type::float64; }

// Both the original names and the sized aliases that some writers emit.
std::optional<Type> parse_type(std::string_view name) {
    if (name == "char" || name == "int8") return Type::int8;
    if (name == "uchar" || name == "uint8") return Type::uint8;
    if (name == "short" || name == "int16") return Type::int16;
    if (name == "ushort" || name == "uint16") return Type::uint16;
    if (name == "int" || name == "int32") return Type::int32;
    if (name == "uint" || name == "uint32") return Type::uint32;
    if (name == "float" || name == "float32") return Type::float32;
    if (name == "double" || name == "float64") return Type::float64;
    return std::nullopt;
}

struct Property {
    std::string name;
    bool is_list = false;
    Type count_type = Type::uint8;  // lists only
    Type value_type = Type::float32;
};

struct Element {
    std::string name;
    uint64_t count = 0;
    std::vector<Property> properties;
    size_t header_line = 0;
};

enum class Format { ascii, binary_little_endian, binary_big_endian };

struct Header {
    Format format = Format::ascii;
    std::vector<Element> elements;
    size_t body_offset = 0;  // first byte after "end_header\n"
    size_t body_line = 0;    // line number of the first body line (ascii)
};

std::vector<std::string_view> split_words(std::string_view line) {
    std::vector<std::string_view> words;
    size_t pos = 0;
    while (pos < line.size()) {
        while (pos < line.size() && (line[pos] == ' ' || line[pos] == '\t' || line[pos] == '\r')) ++pos;
        size_t start = pos;
        while (pos < line.size() && line[pos] != ' ' && line[pos] != '\t' && line[pos] != '\r') ++pos;
        if (pos > start) words.push_back(line.substr(start, pos - start));
    }
    return words;
}

Header parse_header(const std::string& path, std::string_view data) {
    Header header;
    size_t pos = 0;
    size_t line = 0;
    bool have_format = false;
    for (;;) {
        size_t eol = data.find('\n', pos);
        if (eol == std::string_view::npos) fail_at_line(path, line + 1, "PLY header is not terminated by 'end_header'");
        ++line;
        std::string_view text(data.data() + pos, eol - pos);
        pos = eol + 1;
        std::vector<std::string_view> words = split_words(text);
        if (line == 1) {
            if (words.size() != 1 || words[0] != "ply") fail_at_line(path, line, "not a PLY file (no 'ply' magic)");
            continue;
        }
        if (words.empty()) continue;
        const std::string_view keyword = words[0];
        if (keyword == "comment" || keyword == "obj_info") continue;
        if (keyword == "end_header") break;
        if (keyword == "format") {
            if (words.size() != 3) fail_at_line(path, line, "expected 'format <kind> 1.0'");
            if (words[1] == "ascii")
                header.format = Format::ascii;
            else if (words[1] == "binary_little_endian")
                header.format = Format::binary_little_endian;
            else if (words[1] == "binary_big_endian")
                header.format = Format::binary_big_endian;
            else
                fail_at_line(path, line, "unknown PLY format " + quote_token(words[1]));
            if (words[2] != "1.0") fail_at_line(path, line, "unsupported PLY version " + quote_token(words[2]));
            have_format = true;
        } else if (keyword == "element") {
            if (words.size() != 3) fail_at_line(path, line, "expected 'element <name> <count>'");
            Element element;
            element.name = std::string(words[1]);
            element.header_line = line;
            auto [ptr, ec] = std::from_chars(words[2].data(), words[2].data() + words[2].size(), element.count);
            if (ec != std::errc() || ptr != words[2].data() + words[2].size())
                fail_at_line(path, line, "bad element count " + quote_token(words[2]));
            header.elements.push_back(std::move(element));
        } else if (keyword == "property") {
            if (header.elements.empty()) fail_at_line(path, line, "property before any element");
            Property property;
            if (words.size() == 5 && words[1] == "list") {
                auto count_type = parse_type(words[2]);
                auto value_type = parse_type(words[3]);
                if (!count_type || !value_type)
                    fail_at_line(path, line, "unknown list type " + quote_token(count_type ? words[3] : words[2]));
                if (!is_integer_type(*count_type)) fail_at_line(path, line, "list count type must be an integer type");
                property.is_list = true;
                property.count_type = *count_type;
                property.value_type = *value_type;
                property.name = std::string(words[4]);
            } else if (words.size() == 3) {
                auto type = parse_type(words[1]);
                if (!type) fail_at_line(path, line, "unknown property type " + quote_token(words[1]));
                property.value_type = *type;
                property.name = std::string(words[2]);
            } else {
                fail_at_line(path, line, "expected 'property <type> <name>' or 'property list <type> <type> <name>'");
            }
            header.elements.back().properties.push_back(std::move(property));
        } else {
            fail_at_line(path, line, "unknown PLY header keyword " + quote_token(keyword));
        }
    }
    if (!have_format) fail_at_line(path, line, "PLY header has no 'format' line");
    for (const Element& element : header.elements)
        if (element.properties.empty() && element.count > 0)
            fail_at_line(path, element.header_line, "element '" + element.name + "' has no properties");
    header.body_offset = pos;
    header.body_line = line + 1;
    return header;
}

// Reads body values one at a time, in either encoding, and says where it is for error messages.
class BodyReader {
public:
    BodyReader(const std::string& path, std::string_view data, const Header& header)
        : path_(path), data_(data), format_(header.format), pos_(header.body_offset), line_(header.body_line) {}

    void start_element(const Element& element, uint64_t index) {
        if (!is_binary()) skip_space();  // so that the element's line is the line it starts on
        element_ = &element;
        index_ = index;
        element_offset_ = pos_;
        element_line_ = line_;
    }

    size_t remaining() const { return data_.size() - pos_; }
    bool is_binary() const { return format_ != Format::ascii; }

    [[noreturn]] void fail(const std::string& what) const {
        std::string where = "element '" + element_->name + "' #" + std::to_string(index_);
        if (is_binary()) fail_at(path_, where + " (byte offset " + std::to_string(element_offset_) + ")", what);
        fail_at_line(path_, element_line_, where + ": " + what);
    }

    // Any value as a double (exact for every PLY type).
    double read(Type type) {
        if (is_binary()) return read_binary(type);
        std::string_view token = next_token();
        if (type == Type::float32) {
            float value;
            NumberStatus status = parse_float(token, value);
            if (status == NumberStatus::not_finite) return static_cast<double>(value);  // caller decides
            if (status != NumberStatus::ok) fail(std::string(describe(status)) + " " + quote_token(token));
            return value;
        }
        double value = 0;
        const char* first = token.data() + (!token.empty() && token[0] == '+' ? 1 : 0);
        auto [ptr, ec] = std::from_chars(first, token.data() + token.size(), value);
        if (ec != std::errc() || ptr != token.data() + token.size() || token.empty())
            fail("malformed number " + quote_token(token));
        if (is_integer_type(type) && value != std::floor(value))
            fail("non-integer " + quote_token(token) + " for an integer property");
        return value;
    }

    // A coordinate as float32 (binary float32 is taken bit for bit; ascii text is rounded once).
    float read_coordinate(Type type) {
        double value = read(type);
        float result = static_cast<float>(value);
        if (!std::isfinite(result)) fail("NaN or infinite (or out of float range) vertex coordinate");
        return result;
    }

private:
    void skip_space() {
        for (; pos_ < data_.size(); ++pos_) {
            const char c = data_[pos_];
            if (c == '\n')
                ++line_;
            else if (c != ' ' && c != '\t' && c != '\r')
                break;
        }
    }

    std::string_view next_token() {
        const char* data = data_.data();
        skip_space();
        if (pos_ >= data_.size()) fail("unexpected end of file (truncated?)");
        size_t start = pos_;
        while (pos_ < data_.size() && data[pos_] != ' ' && data[pos_] != '\t' && data[pos_] != '\r' &&
               data[pos_] != '\n')
            ++pos_;
        return std::string_view(data + start, pos_ - start);
    }

    double read_binary(Type type) {
        size_t size = type_size(type);
        if (remaining() < size) fail("unexpected end of file (truncated?)");
        unsigned char bytes[8];
        std::memcpy(bytes, data_.data() + pos_, size);
        pos_ += size;
        const bool file_is_little = format_ == Format::binary_little_endian;
        if (file_is_little != (std::endian::native == std::endian::little))
            for (size_t i = 0; i < size / 2; ++i) std::swap(bytes[i], bytes[size - 1 - i]);
        switch (type) {
            case Type::int8:
                return static_cast<int8_t>(bytes[0]);
            case Type::uint8:
                return bytes[0];
            case Type::int16: {
                int16_t v;
                std::memcpy(&v, bytes, 2);
                return v;
            }
            case Type::uint16: {
                uint16_t v;
                std::memcpy(&v, bytes, 2);
                return v;
            }
            case Type::int32: {
                int32_t v;
                std::memcpy(&v, bytes, 4);
                return v;
            }
            case Type::uint32: {
                uint32_t v;
                std::memcpy(&v, bytes, 4);
                return v;
            }
            case Type::float32: {
                float v;
                std::memcpy(&v, bytes, 4);
                return v;
            }
            case Type::float64: {
                double v;
                std::memcpy(&v, bytes, 8);
                return v;
            }
        }
        return 0;
    }

    const std::string& path_;
    std::string_view data_;
    Format format_;
    size_t pos_;
    size_t line_;
    const Element* element_ = nullptr;
    uint64_t index_ = 0;
    size_t element_offset_ = 0;
    size_t element_line_ = 0;
};

// The fewest bytes one element can take: absurd header counts are rejected before anything is allocated.
// Ascii values take at least one character plus a separator (the last one may end the file).
uint64_t min_element_bytes(const Element& element, bool binary) {
    uint64_t bytes = 0;
    for (const Property& property : element.properties)
        bytes += binary ? type_size(property.is_list ? property.count_type : property.value_type) : 2;
    return bytes;
}

std::string format_value(double value) {
    char buffer[32];
    std::snprintf(buffer, sizeof buffer, "%.17g", value);
    return buffer;
}

int find_property(const Element& element, std::initializer_list<std::string_view> names) {
    for (size_t i = 0; i < element.properties.size(); ++i)
        for (std::string_view name : names)
            if (element.properties[i].name == name) return static_cast<int>(i);
    return -1;
}

}  // namespace

std::vector<Triangle> load_ply(const std::string& path) { return parse_ply(read_file_bytes(path), path); }

std::vector<Triangle> parse_ply(std::string_view data, const std::string& path) {
    const Header header = parse_header(path, data);
    BodyReader reader(path, data, header);

    std::vector<Vec3> vertices;
    std::vector<Triangle> triangles;
    bool have_vertices = false;
    bool have_faces = false;
    for (const Element& element : header.elements) {
        // +1: the last ascii value needs no separator.
        const uint64_t min_bytes = min_element_bytes(element, reader.is_binary());
        if (element.count > 0 && element.count > (reader.remaining() + 1) / min_bytes)
            fail_at_line(path, element.header_line,
                         "element '" + element.name + "' count " + std::to_string(element.count) +
                             " cannot fit in the remaining " + std::to_string(reader.remaining()) +
                             " bytes of the file (truncated or corrupt header)");

        const bool is_vertex = element.name == "vertex" && !have_vertices;
        const bool is_face = element.name == "face" && !have_faces;
        int axis_of[3] = {-1, -1, -1};
        int index_list = -1;
        if (is_vertex) {
            const char* names[3] = {"x", "y", "z"};
            for (int axis = 0; axis < 3; ++axis) {
                axis_of[axis] = find_property(element, {names[axis]});
                if (axis_of[axis] < 0 || element.properties[axis_of[axis]].is_list)
                    fail_at_line(path, element.header_line,
                                 std::string("vertex element has no scalar property '") + names[axis] + "'");
            }
            vertices.reserve(element.count);
            have_vertices = true;
        }
        if (is_face) {
            index_list = find_property(element, {"vertex_indices", "vertex_index"});
            if (index_list < 0 || !element.properties[index_list].is_list)
                fail_at_line(path, element.header_line, "face element has no list property 'vertex_indices'");
            if (!have_vertices) fail_at_line(path, element.header_line, "face element comes before the vertex element");
            triangles.reserve(element.count);
            have_faces = true;
        }

        for (uint64_t index = 0; index < element.count; ++index) {
            reader.start_element(element, index);
            Vec3 position;
            for (size_t p = 0; p < element.properties.size(); ++p) {
                const Property& property = element.properties[p];
                const int slot = static_cast<int>(p);
                if (!property.is_list) {
                    if (is_vertex && (slot == axis_of[0] || slot == axis_of[1] || slot == axis_of[2])) {
                        const int axis = slot == axis_of[0] ? 0 : (slot == axis_of[1] ? 1 : 2);
                        position[axis] = reader.read_coordinate(property.value_type);
                    } else {
                        reader.read(property.value_type);
                    }
                    continue;
                }
                const double count_value = reader.read(property.count_type);
                // Each list item takes at least one byte, which also rules out absurd (or infinite) lengths.
                if (!(count_value >= 0 && count_value <= static_cast<double>(reader.remaining())))
                    reader.fail("list length " + format_value(count_value) + " is negative or exceeds the file");
                const uint64_t count = static_cast<uint64_t>(count_value);
                if (slot != index_list) {
                    for (uint64_t i = 0; i < count; ++i) reader.read(property.value_type);
                    continue;
                }
                if (count < 3) reader.fail("face has " + std::to_string(count) + " vertices, at least 3 are needed");
                // Fan triangulation streams the indices: no per-face allocation.
                uint32_t first = 0, previous = 0;
                for (uint64_t i = 0; i < count; ++i) {
                    const double value = reader.read(property.value_type);
                    if (!(value >= 0 && value < static_cast<double>(vertices.size()) && value == std::floor(value)))
                        reader.fail("vertex index " + format_value(value) +
                                    " out of range: " + std::to_string(vertices.size()) + " vertices");
                    const uint32_t vertex = static_cast<uint32_t>(value);
                    if (i == 0)
                        first = vertex;
                    else if (i >= 2)
                        triangles.push_back({vertices[first], vertices[previous], vertices[vertex]});
                    previous = vertex;
                }
            }
            if (is_vertex) vertices.push_back(position);
        }
    }
    if (!have_faces) throw Error(path + ": no 'face' element: the PLY file has no triangles");
    if (triangles.empty()) throw Error(path + ": the face element is empty: no triangles");
    return triangles;
}

}  // namespace spacebvh::tools::scene_detail
