// SPDX-License-Identifier: MIT
// Scene files (docs/tree-format.md, "Scene files"): a committed RenderScene and the scenes it
// instances, children first, each with its geometries by id and its top level; every tree is stored
// as a tree file and loaded with that format's checks.
#include "spacebvh/scene_file.hpp"

#include <algorithm>
#include <map>

#include "spacebvh/error.hpp"
#include "spacebvh/tree_file.hpp"
#include "trace/scene/scene_impl.hpp"
#include "tree_file/file_bytes.hpp"
#include "tree_file/tree_file_checksum.hpp"

namespace spacebvh {

struct SceneFileAccess {
    static RenderScene::Impl& impl(const RenderScene& scene) { return *scene.impl_; }
};

namespace {

using namespace tree_file_detail;
using scene::Geometry;
using scene::InstanceRecord;
using scene::MeshRecord;

constexpr char kSceneMagic[8] = {'S', 'B', 'V', 'H', 'S', 'C', 'N', 'E'};
constexpr uint32_t kEndianMarker = 0x0A0B0C0Du;
constexpr uint64_t kHeaderSize = 40;
constexpr uint64_t kMaxNameLength = 4096;
constexpr uint64_t kMaxSettingsLength = 1u << 20;
constexpr uint64_t kMaxCount = 0xFFFFFFFFull;
enum : uint32_t { kDetached = 0, kMesh = 1, kInstance = 2 };

// Appends little-endian fields; every variable-length field is followed by zeros up to a multiple of 8.
struct Writer {
    std::vector<std::byte> out;
    void u32(uint32_t v) { put(v); }
    void u64(uint64_t v) { put(v); }
    template <class T>
    void put(T v) {
        out.resize(out.size() + sizeof v);
        store_le(out.data() + out.size() - sizeof v, v);
    }
    void f32(float v) { u32(std::bit_cast<uint32_t>(v)); }
    void text(std::string_view s) {
        out.resize(out.size() + s.size());
        copy_bytes(out.data() + out.size() - s.size(), s.data(), s.size());
        align();
    }
    void blob(std::span<const std::byte> b) {
        u64(b.size());
        out.insert(out.end(), b.begin(), b.end());
        align();
    }
    void align() { out.resize(pad8(out.size())); }
};

// Reads fields with a bounds check each; errors name the source, the field and the offset.
struct Reader {
    std::span<const std::byte> in;
    const std::string& source;
    uint64_t at = 0;

    Error fail(const std::string& what) const { return Error(source + ": " + what); }
    const std::byte* take(uint64_t n, const std::string& what) {
        if (n > in.size() - at)
            throw fail("truncated: " + what + " needs " + std::to_string(n) + " bytes at offset " + std::to_string(at) +
                       ", " + std::to_string(in.size() - at) + " are left");
        const std::byte* p = in.data() + at;
        at += n;
        return p;
    }
    uint32_t u32(const std::string& what) { return load_le<uint32_t>(take(4, what)); }
    uint64_t u64(const std::string& what) { return load_le<uint64_t>(take(8, what)); }
    void align(const std::string& what) {
        for (const std::byte* p = take(pad8(at) - at, what); p != in.data() + at; ++p)
            if (*p != std::byte{0}) throw fail("nonzero padding after " + what);
    }
    std::string text(uint64_t n, const std::string& what) {
        const std::byte* p = take(n, what);
        std::string s(reinterpret_cast<const char*>(p), n);
        align(what);
        return s;
    }
    std::span<const std::byte> blob(const std::string& what) {
        const uint64_t n = u64(what + "'s length");
        const std::byte* p = take(n, what);
        align(what);
        return {p, n};
    }
};

// The saved scene and every scene it instances, each once, children before the scenes placing them.
void order_scenes(const RenderScene& scene, std::map<const RenderScene*, uint32_t>& index,
                  std::vector<const RenderScene*>& order) {
    if (index.count(&scene)) return;
    for (const Geometry& g : SceneFileAccess::impl(scene).geometries)
        if (const InstanceRecord* inst = g.instance()) order_scenes(*inst->scene, index, order);
    index[&scene] = uint32_t(order.size());
    order.push_back(&scene);
}

void write_tracer(Writer& w, const TracerConfig& t) {
    for (uint32_t v : {uint32_t(t.kernel), uint32_t(t.node_test), uint32_t(t.collapse), t.packet_size,
                       uint32_t(t.leaf_test), uint32_t(t.node_format)})
        w.u32(v);
}

void write_scene(Writer& w, const RenderScene::Impl& s, const std::map<const RenderScene*, uint32_t>& index) {
    if (s.name.size() > kMaxNameLength)
        throw Error("scene file: scene name longer than " + std::to_string(kMaxNameLength) + " bytes");
    w.u32(uint32_t(s.name.size()));
    w.u32(uint32_t(s.geometries.size()));
    write_tracer(w, s.config.tracer);
    w.u32(s.depth);
    w.u32(0);
    w.text(s.name);
    for (const Geometry& g : s.geometries) {
        w.u32(g.mesh() ? kMesh : g.instance() ? kInstance : kDetached);
        w.u32(g.mask);
        if (const MeshRecord* mesh = g.mesh()) {
            const std::span<const Triangle> triangles(mesh->triangles);
            w.u64(triangles.size());
            for (const Triangle& t : triangles)
                for (int v = 0; v < 3; ++v)
                    for (int axis = 0; axis < 3; ++axis) w.f32(t.vertex(v)[axis]);
            w.align();
            w.blob(serialize_bvh(mesh->bvh, triangles));
        } else if (const InstanceRecord* inst = g.instance()) {
            w.u32(index.at(inst->scene.get()));
            w.u32(0);
            for (float v : inst->transform.m) w.f32(v);
        }
    }
    w.blob(serialize_bvh(s.top.bvh, scene::top_level_triangles(s.items)));
}

}  // namespace

std::vector<std::byte> serialize_render_scene(const RenderScene& root, std::string_view settings) {
    if (settings.size() > kMaxSettingsLength)
        throw Error("scene file: the settings text exceeds " + std::to_string(kMaxSettingsLength) + " bytes");
    std::map<const RenderScene*, uint32_t> index;
    std::vector<const RenderScene*> order;
    order_scenes(root, index, order);
    for (const RenderScene* s : order) SceneFileAccess::impl(*s).check_traceable();
    Writer w;
    w.out.resize(kHeaderSize);
    std::byte* head = w.out.data();
    std::memcpy(head, kSceneMagic, sizeof kSceneMagic);
    store_le(head + 8, kSceneFileVersion);
    store_le(head + 12, kEndianMarker);
    store_le(head + 24, uint32_t(order.size()));
    store_le(head + 28, uint32_t(0));  // flags
    store_le(head + 32, uint32_t(settings.size()));
    store_le(head + 36, uint32_t(0));
    w.text(settings);
    for (const RenderScene* s : order) write_scene(w, SceneFileAccess::impl(*s), index);
    store_le(w.out.data() + 16, uint64_t(w.out.size() + 8));  // file size, checksum included
    w.u64(tree_file_detail::checksum(w.out));
    return std::move(w.out);
}

namespace {

TracerConfig read_tracer(Reader& r, const std::string& what) {
    uint32_t v[6];
    for (uint32_t& x : v) x = r.u32(what + "'s tracer settings");
    // Highest value of each enumeration: Kernel, NodeTest, WideCollapse, (packet size), LeafTest, NodeFormat.
    constexpr uint32_t kLargest[6] = {uint32_t(Kernel::packet16),           uint32_t(NodeTest::avx512),
                                      uint32_t(WideCollapse::largest_area), 256,
                                      uint32_t(LeafTest::moller),           uint32_t(NodeFormat::quantized)};
    for (int i = 0; i < 6; ++i)
        if (v[i] > kLargest[i])
            throw r.fail(what + ": tracer setting " + std::to_string(i) + " is " + std::to_string(v[i]) + " (at most " +
                         std::to_string(kLargest[i]) + ")");
    return {Kernel(v[0]), NodeTest(v[1]), WideCollapse(v[2]), v[3], LeafTest(v[4]), NodeFormat(v[5])};
}

// "" when the top level is one the walks take: each item in exactly one leaf, at most 64 levels deep.
std::string top_level_problem(const Bvh& bvh, size_t item_count) {
    if (bvh.primitives.size() != item_count)
        return std::to_string(bvh.primitives.size()) + " item references for " + std::to_string(item_count) + " items";
    std::vector<uint8_t> seen(item_count, 0);
    for (const uint32_t item : bvh.primitives)
        if (seen[item]++) return "item " + std::to_string(item) + " is referenced twice";
    std::vector<std::pair<uint32_t, uint32_t>> stack{{0u, 0u}};
    uint64_t listed = 0;
    while (!stack.empty()) {
        const auto [node, depth] = stack.back();
        stack.pop_back();
        if (depth > 64) return "deeper than 64 levels";
        const BvhNode& n = bvh.nodes[node];
        if (n.is_leaf()) {
            listed += n.reference_count;
            continue;
        }
        stack.push_back({n.first, depth + 1});
        stack.push_back({n.first + 1, depth + 1});
    }
    // The tree-file checks made every leaf range lie in the references; these ranges adding up to all
    // of them, with no reference repeated, leaves no two leaves sharing one.
    if (listed != item_count)
        return "its leaves list " + std::to_string(listed) + " references, not " + std::to_string(item_count);
    return "";
}

void read_mesh(Reader& r, RenderScene::Impl& s, uint32_t mask, const std::string& what) {
    const uint64_t count = r.u64(what + "'s triangle count");
    if (count == 0 || count > kMaxCount)
        throw r.fail(what + ": " + std::to_string(count) + " triangles (1 .. 2^32 - 1)");
    const std::byte* p = r.take(36 * count, what + "'s triangles");
    r.align(what + "'s triangles");
    auto owned = std::make_shared<std::vector<Triangle>>(count);
    const auto vertex = [&](const std::byte* q) { return Vec3{load_f32(q), load_f32(q + 4), load_f32(q + 8)}; };
    for (uint64_t t = 0; t < count; ++t) {
        const std::byte* q = p + 36 * t;
        (*owned)[t] = {vertex(q), vertex(q + 12), vertex(q + 24)};
    }
    MeshRecord record{MeshView(*owned), s.config.recipe, {}, *owned, {}, false, 0.0, {}};
    record.view.named(what + " (loaded from " + r.source + ")");
    const TriangleStore checked(record.view);  // NaN / inf coordinates: a clear error naming the triangle
    record.bvh = deserialize_bvh(r.blob(what + "'s tree"), record.triangles, r.source + ": " + what + "'s tree");
    record.owned = std::move(owned);
    s.add_mesh(std::move(record), mask);
}

std::shared_ptr<RenderScene> read_scene(Reader& r, uint32_t number,
                                        const std::vector<std::shared_ptr<RenderScene>>& done,
                                        const SceneLoadOptions& options) {
    const std::string at = "scene record " + std::to_string(number);
    const uint64_t name_length = r.u32(at + "'s name length");
    const uint64_t slots = r.u32(at + "'s geometry count");
    TracerConfig tracer = read_tracer(r, at);
    const uint32_t depth = r.u32(at + "'s depth");
    if (r.u32(at + "'s reserved field") != 0) throw r.fail(at + ": nonzero reserved field");
    if (name_length > kMaxNameLength)
        throw r.fail(at + ": a name of " + std::to_string(name_length) + " bytes (at most 4096)");
    const std::string name = r.text(name_length, at + "'s name");
    const std::string what = "scene '" + name + "'";
    SceneConfig config;
    config.tracer = options.tracer ? *options.tracer : tracer;
    auto scene = std::make_shared<RenderScene>(config, name);
    RenderScene::Impl& s = SceneFileAccess::impl(*scene);
    for (uint32_t id = 0; id < slots; ++id) {
        const std::string geometry = what + " geometry " + std::to_string(id);
        const uint32_t kind = r.u32(geometry + "'s kind");
        const uint32_t mask = r.u32(geometry + "'s mask");
        if (kind == kDetached) {
            s.geometries.push_back({mask, std::monostate{}});
        } else if (kind == kMesh) {
            read_mesh(r, s, mask, what + " mesh " + std::to_string(id));
        } else if (kind == kInstance) {
            const uint32_t child = r.u32(geometry + "'s scene");
            if (r.u32(geometry + "'s reserved field") != 0) throw r.fail(geometry + ": nonzero reserved field");
            if (child >= number)
                throw r.fail(geometry + " places scene record " + std::to_string(child) + ", not one stored before it");
            Affine transform;
            const std::byte* p = r.take(48, geometry + "'s transform");
            for (int k = 0; k < 12; ++k) transform.m[k] = load_f32(p + 4 * k);
            scene->attach_instance(done[child], transform, mask);
        } else {
            throw r.fail(geometry + ": unknown kind " + std::to_string(kind));
        }
    }
    std::vector<uint32_t> ids;
    std::vector<scene::TopLevelItem> items;
    uint32_t gathered_depth = 0;
    s.gather(ids, items, gathered_depth);
    if (gathered_depth != depth)
        throw r.fail(what + ": the record says " + std::to_string(depth) + " instance levels, its instances make " +
                     std::to_string(gathered_depth));
    scene::TopLevel top;
    top.bvh = deserialize_bvh(r.blob(what + "'s top level"), scene::top_level_triangles(items),
                              r.source + ": " + what + "'s top level");
    if (const std::string problem = top_level_problem(top.bvh, items.size()); !problem.empty())
        throw r.fail(what + "'s top level: " + problem);
    scene::refit_top_level(top, items);  // boxes and padding from the items, whatever the file's boxes
    s.install(std::move(top), std::move(ids), std::move(items), depth);
    return scene;
}

}  // namespace

std::shared_ptr<RenderScene> deserialize_render_scene(std::span<const std::byte> bytes, const std::string& source,
                                                      const SceneLoadOptions& options, SceneFileInfo* info) {
    Reader r{bytes, source};
    if (bytes.size() >= sizeof kSceneMagic && std::memcmp(bytes.data(), kSceneMagic, sizeof kSceneMagic) != 0)
        throw r.fail("not a spacebvh scene file (it does not start with \"SBVHSCNE\")");
    const std::byte* head = r.take(kHeaderSize, "the header");
    const uint32_t marker = load_le<uint32_t>(head + 12);
    if (marker != kEndianMarker) throw r.fail("corrupt endianness marker 0x" + hex(marker).substr(8));
    const uint32_t version = load_le<uint32_t>(head + 8);
    if (version != kSceneFileVersion)
        throw r.fail("scene file format version " + std::to_string(version) + ", this library reads " +
                     std::to_string(kSceneFileVersion));
    const uint64_t file_size = load_le<uint64_t>(head + 16);
    if (file_size != bytes.size())
        throw r.fail(file_size > bytes.size()
                         ? "truncated: the header says " + std::to_string(file_size) + " bytes, the file has " +
                               std::to_string(bytes.size())
                         : std::to_string(bytes.size() - file_size) + " bytes past the end the header gives (" +
                               std::to_string(file_size) + " bytes)");
    if (file_size < kHeaderSize + 8) throw r.fail("too short for the header and the checksum");
    const uint64_t stored = load_le<uint64_t>(bytes.data() + file_size - 8);
    const uint64_t checksum = tree_file_detail::checksum(bytes.first(file_size - 8));
    if (stored != checksum)
        throw r.fail("corrupt: checksum " + hex(checksum) + " does not match the stored " + hex(stored));
    // Past the checksum only a deliberately altered file can fail; it still gets a clear error.
    r.in = bytes.first(file_size - 8);
    const uint32_t scene_count = load_le<uint32_t>(head + 24);
    if (load_le<uint32_t>(head + 28) != 0) throw r.fail("unknown flags");
    const uint64_t settings_length = load_le<uint32_t>(head + 32);
    if (settings_length > kMaxSettingsLength) throw r.fail("a settings text longer than 1 MiB");
    if (scene_count == 0) throw r.fail("the header says the file holds no scene");
    const std::string settings = r.text(settings_length, "the settings text");
    std::vector<std::shared_ptr<RenderScene>> scenes;
    try {
        for (uint32_t k = 0; k < scene_count; ++k) scenes.push_back(read_scene(r, k, scenes, options));
    } catch (const Error& e) {
        const std::string message = e.what();
        if (message.rfind(source + ":", 0) == 0) throw;
        throw r.fail(message);
    }
    if (r.at != r.in.size()) throw r.fail(std::to_string(r.in.size() - r.at) + " bytes after the last scene record");
    if (info) {
        *info = {};
        info->format_version = version;
        info->scene_count = scene_count;
        info->settings = settings;
        for (const auto& s : scenes)
            for (const Geometry& g : SceneFileAccess::impl(*s).geometries) {
                info->instance_count += g.instance() != nullptr;
                if (const MeshRecord* mesh = g.mesh())
                    ++info->mesh_count, info->triangle_count += mesh->triangles.size();
            }
    }
    return scenes.back();
}

void save_render_scene(const std::string& path, const RenderScene& scene, std::string_view settings) {
    write_file(path, serialize_render_scene(scene, settings));
}

std::shared_ptr<RenderScene> load_render_scene(const std::string& path, const SceneLoadOptions& options,
                                               SceneFileInfo* info) {
    return deserialize_render_scene(read_file(path, "scene file"), path, options, info);
}

bool is_scene_file(std::span<const std::byte> bytes) {
    return bytes.size() >= sizeof kSceneMagic && std::memcmp(bytes.data(), kSceneMagic, sizeof kSceneMagic) == 0;
}

bool is_scene_file(const std::string& path) {
    File file(std::fopen(path.c_str(), "rb"));
    std::byte magic[sizeof kSceneMagic];
    return file && std::fread(magic, 1, sizeof magic, file.get()) == sizeof magic && is_scene_file(magic);
}

}  // namespace spacebvh
