// SPDX-License-Identifier: MIT
// Ray and hit files of docs/rays.md ("Ray file", "Hit file"): 8 bytes magic, uint64 count, then fixed-size
// little-endian records. Values are encoded byte by byte so the files are the same on any host.
#include <algorithm>
#include <bit>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <memory>
#include <string>
#include <vector>

#include "spacebvh/error.hpp"
#include "spacebvh/tools/rays.hpp"

namespace spacebvh::tools {

HitRecord to_record(const Hit& hit) {
    if (!hit.is_hit()) return {};
    return {hit.t, hit.primitive};
}

HitRecord occlusion_record(bool occluded) { return {occluded ? 0.0f : kInfinity, kInvalidIndex}; }

namespace {

constexpr char kRayMagic[8] = {'R', 'E', 'F', 'R', 'A', 'Y', 'S', '1'};
constexpr char kHitMagic[8] = {'R', 'E', 'F', 'H', 'I', 'T', 'S', '1'};
constexpr size_t kHeaderBytes = 16;
constexpr size_t kRayRecordBytes = 32;        // org.xyz, dir.xyz, tmin, tmax
constexpr size_t kHitRecordBytes = 8;         // t, primitive
constexpr size_t kRecordsPerChunk = 1 << 16;  // I/O in chunks, not one huge buffer

void put_u32(unsigned char* out, uint32_t v) {
    for (int i = 0; i < 4; ++i) out[i] = static_cast<unsigned char>(v >> (8 * i));
}
void put_u64(unsigned char* out, uint64_t v) {
    for (int i = 0; i < 8; ++i) out[i] = static_cast<unsigned char>(v >> (8 * i));
}
void put_f32(unsigned char* out, float v) { put_u32(out, std::bit_cast<uint32_t>(v)); }
uint32_t get_u32(const unsigned char* in) {
    uint32_t v = 0;
    for (int i = 0; i < 4; ++i) v |= uint32_t(in[i]) << (8 * i);
    return v;
}
uint64_t get_u64(const unsigned char* in) {
    uint64_t v = 0;
    for (int i = 0; i < 8; ++i) v |= uint64_t(in[i]) << (8 * i);
    return v;
}
float get_f32(const unsigned char* in) { return std::bit_cast<float>(get_u32(in)); }

struct FileCloser {
    void operator()(std::FILE* f) const { std::fclose(f); }
};
using FilePtr = std::unique_ptr<std::FILE, FileCloser>;

FilePtr open_file(const std::string& path, const char* mode) {
    FilePtr f(std::fopen(path.c_str(), mode));
    if (!f) throw Error(path + ": cannot open (" + std::strerror(errno) + ")");
    return f;
}

// Writes header and records; `encode(i, out)` fills record i.
template <class Encode>
void write_records(const std::string& path, const char (&magic)[8], size_t count, size_t record_bytes, Encode encode) {
    FilePtr f = open_file(path, "wb");
    unsigned char header[kHeaderBytes];
    std::memcpy(header, magic, 8);
    put_u64(header + 8, count);
    bool ok = std::fwrite(header, 1, kHeaderBytes, f.get()) == kHeaderBytes;
    std::vector<unsigned char> buffer(std::min(count, kRecordsPerChunk) * record_bytes);
    for (size_t first = 0; ok && first < count; first += kRecordsPerChunk) {
        const size_t n = std::min(kRecordsPerChunk, count - first);
        for (size_t i = 0; i < n; ++i) encode(first + i, buffer.data() + i * record_bytes);
        ok = std::fwrite(buffer.data(), 1, n * record_bytes, f.get()) == n * record_bytes;
    }
    // fclose flushes: a full disk may only show here.
    if (std::fclose(f.release()) != 0) ok = false;
    if (!ok) throw Error(path + ": write failed (" + std::strerror(errno) + ")");
}

// An opened record file whose header has been checked against the file size (before anything is
// allocated, so a corrupt count cannot ask for terabytes).
struct RecordFile {
    FilePtr file;
    size_t count = 0;
};

// `file` is open for reading at its start; `path` names it in messages.
RecordFile open_records(FilePtr file, const std::string& path, const char (&magic)[8], const char* what,
                        size_t record_bytes) {
    RecordFile rf{std::move(file), 0};
    std::FILE* f = rf.file.get();
    if (std::fseek(f, 0, SEEK_END) != 0) throw Error(path + ": cannot determine the file size");
    const long end = std::ftell(f);
    if (end < 0) throw Error(path + ": cannot determine the file size");
    std::rewind(f);
    const uint64_t file_bytes = uint64_t(end);

    unsigned char header[kHeaderBytes];
    const size_t got = std::fread(header, 1, kHeaderBytes, f);
    if (got < 8 || std::memcmp(header, magic, 8) != 0)
        throw Error(path + ": not a " + what + " file (bad magic; expected '" + std::string(magic, 8) + "')");
    if (got < kHeaderBytes) throw Error(path + ": truncated header (" + std::to_string(got) + " of 16 bytes)");
    const uint64_t count = get_u64(header + 8);
    const uint64_t available = (file_bytes - kHeaderBytes) / record_bytes;
    if (count > available)
        throw Error(path + ": truncated: the header says " + std::to_string(count) + " records but the file (" +
                    std::to_string(file_bytes) + " bytes) ends inside record " + std::to_string(available));
    const uint64_t expected = kHeaderBytes + count * record_bytes;
    if (file_bytes != expected)
        throw Error(path + ": the header says " + std::to_string(count) + " records (" + std::to_string(expected) +
                    " bytes) but the file has " + std::to_string(file_bytes) + " bytes (data after record " +
                    std::to_string(count) + ")");
    rf.count = size_t(count);
    return rf;
}

// Decodes every record of an opened file with `decode(i, bytes)`, chunk by chunk.
template <class Decode>
void read_records(const std::string& path, RecordFile& rf, size_t record_bytes, Decode decode) {
    std::vector<unsigned char> buffer(std::min(rf.count, kRecordsPerChunk) * record_bytes);
    for (size_t first = 0; first < rf.count; first += kRecordsPerChunk) {
        const size_t n = std::min(kRecordsPerChunk, rf.count - first);
        const size_t bytes = std::fread(buffer.data(), 1, n * record_bytes, rf.file.get());
        if (bytes != n * record_bytes)
            throw Error(path + ": read error at record " + std::to_string(first + bytes / record_bytes));
        for (size_t i = 0; i < n; ++i) decode(first + i, buffer.data() + i * record_bytes);
    }
}

}  // namespace

void write_ray_file(const std::string& path, std::span<const Ray> rays) {
    write_records(path, kRayMagic, rays.size(), kRayRecordBytes, [&](size_t i, unsigned char* out) {
        const Ray& r = rays[i];
        const float values[8] = {r.org.x, r.org.y, r.org.z, r.dir.x, r.dir.y, r.dir.z, r.tmin, r.tmax};
        for (int k = 0; k < 8; ++k) put_f32(out + 4 * k, values[k]);
    });
}

std::vector<Ray> read_ray_file(const std::string& path) { return read_ray_file(open_file(path, "rb").release(), path); }

std::vector<Ray> read_ray_file(std::FILE* file, const std::string& path) {
    RecordFile rf = open_records(FilePtr(file), path, kRayMagic, "ray", kRayRecordBytes);
    std::vector<Ray> rays(rf.count);
    read_records(path, rf, kRayRecordBytes, [&](size_t i, const unsigned char* in) {
        Ray& r = rays[i];
        r.org = {get_f32(in), get_f32(in + 4), get_f32(in + 8)};
        r.dir = {get_f32(in + 12), get_f32(in + 16), get_f32(in + 20)};
        r.tmin = get_f32(in + 24);
        r.tmax = get_f32(in + 28);
        if (const char* reason = untraceable_ray_reason(r))
            throw Error(path + ": record " + std::to_string(i) + ": " + reason);
    });
    return rays;
}

const char* untraceable_ray_reason(const Ray& ray) {
    // A NaN or infinite origin/direction cannot be traced by anyone.
    if (!is_finite(ray.org) || !is_finite(ray.dir) || std::isnan(ray.tmin) || std::isnan(ray.tmax))
        return "non-finite origin or direction, or NaN t range";
    if (ray.dir == Vec3(0.0f)) return "zero direction";
    return nullptr;
}

void write_hit_file(const std::string& path, std::span<const HitRecord> hits) {
    write_records(path, kHitMagic, hits.size(), kHitRecordBytes, [&](size_t i, unsigned char* out) {
        put_f32(out, hits[i].t);
        put_u32(out + 4, hits[i].primitive);
    });
}

std::vector<HitRecord> read_hit_file(const std::string& path) {
    return read_hit_file(open_file(path, "rb").release(), path);
}

std::vector<HitRecord> read_hit_file(std::FILE* file, const std::string& path) {
    RecordFile rf = open_records(FilePtr(file), path, kHitMagic, "hit", kHitRecordBytes);
    std::vector<HitRecord> hits(rf.count);
    read_records(path, rf, kHitRecordBytes, [&](size_t i, const unsigned char* in) {
        hits[i].t = get_f32(in);
        hits[i].primitive = get_u32(in + 4);
        if (std::isnan(hits[i].t)) throw Error(path + ": record " + std::to_string(i) + ": t is NaN");
    });
    return hits;
}

}  // namespace spacebvh::tools
