#include "cli_common.hpp"

#include <tbb/info.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>

#include "embree/embree_builder.hpp"
#include "spacebvh/error.hpp"

namespace spacebvh::cli {

void SceneOptions::add_to(CLI::App& command) {
    command.add_option("--rotate", rotate, "rotate every vertex at load time, degrees: x:45,y:45,z:45 (R = Rz*Ry*Rx)");
    command.add_option("--scale", scale, "uniform scale applied after the rotation");
    command.add_option("--translate", translate, "translation applied last: X Y Z")->expected(3);
}

SceneTransform SceneOptions::transform() const {
    SceneTransform transform;
    if (!rotate.empty()) transform.rotate_degrees = SceneTransform::parse_rotation(rotate);
    if (!std::isfinite(scale) || scale == 0.0f) throw Error("--scale must be a finite non-zero number");
    transform.scale = scale;
    if (translate.size() == 3) {
        transform.translate = {translate[0], translate[1], translate[2]};
        if (!is_finite(transform.translate)) throw Error("--translate must be finite");
    }
    return transform;
}

float parse_float_or_inf(const std::string& text, const char* what) {
    if (text == "inf" || text == "infinity" || text == "Inf") return kInfinity;
    try {
        size_t used = 0;
        const float value = std::stof(text, &used);
        if (used != text.size()) throw std::invalid_argument(text);
        return value;
    } catch (const std::exception&) {
        throw Error(std::string(what) + ": expected a number or 'inf', got '" + text + "'");
    }
}

void BuildCliOptions::add_to(CLI::App& command, bool with_builder) {
    if (with_builder) {
        command.add_option("--builder,-b", builder, "builder: " + builder_list())->capture_default_str();
    }
    command.add_option("--ct", traversal_cost, "C_T, cost of a traversal step")->capture_default_str();
    command.add_option("--ci", intersection_cost, "C_I, cost of a triangle test")->capture_default_str();
    command.add_option("--co", overlap_penalty,
                       "C_o, overlap penalty (0 = plain SAH, inf = disjoint children only; default: the builder's)");
    command.add_option("--max-leaf", max_leaf_size, "largest leaf (nodes with more references are split)")
        ->capture_default_str();
    command.add_option("--max-depth", max_depth, "deepest level; nodes there become leaves")->capture_default_str();
    command.add_option("--bins", bins, "bins per axis of the binned object search space")->capture_default_str();
    command.add_option("--spatial-bins", spatial_bins, "bins per axis of the spatial search space")->capture_default_str();
    command.add_option("--budget", reference_budget, "reference budget of spatial splits, x triangles")
        ->capture_default_str();
    command.add_flag("--no-unsplitting", no_unsplitting, "clip every straddling reference into both children");
    command.add_flag("--spatial-sweep", spatial_sweep,
                     "kd planes at every reference bound with exact child boxes (the sweep) instead of --spatial-bins bins");
    command.add_option("--sweep-samples", sweep_samples,
                       "spatial sweep: positions sampled inside the intervals next to the best event planes (0 = events only)")
        ->capture_default_str();
}

BuildOptions BuildCliOptions::options(const std::string& builder_name) const {
    // Embree's trees take the same limits and costs; their name is not one of our presets.
    BuildOptions options = options_for(is_embree_tree(builder_name) ? "binned" : builder_name);
    options.cost.traversal_cost = traversal_cost;
    options.cost.intersection_cost = intersection_cost;
    if (!overlap_penalty.empty()) options.cost.overlap_penalty = parse_float_or_inf(overlap_penalty, "--co");
    options.max_leaf_size = max_leaf_size;
    options.max_depth = max_depth;
    options.object_bins = bins;
    options.spatial_bins = spatial_bins;
    options.reference_budget = reference_budget;
    options.unsplitting = !no_unsplitting;
    options.exact_spatial_sweep = spatial_sweep;
    options.sweep_interior_samples = sweep_samples;
    options.validate();
    options.builder = builder_name;
    return options;
}

void CommonOptions::add_to(CLI::App& command) {
    command.add_option("--threads,-j", threads, "worker threads (0 = all cores)")->capture_default_str();
    command.add_flag("--quiet,-q", quiet, "no progress bar");
    command.add_option("--json", json_path, "also write the results as JSON to this file");
}

std::unique_ptr<tbb::global_control> CommonOptions::thread_limit() const {
    if (threads > 4096) throw Error("--threads must be at most 4096");
    if (threads == 0) return nullptr;
    return std::make_unique<tbb::global_control>(tbb::global_control::max_allowed_parallelism, threads);
}

unsigned CommonOptions::effective_threads() const {
    return threads ? threads : unsigned(tbb::info::default_concurrency());
}

void CameraOptions::add_to(CLI::App& command) {
    command.add_option("--camera", camera, "eye, target, up, fovy: ex,ey,ez,tx,ty,tz,ux,uy,uz,fovy "
                                           "(default: the scene's MANIFEST camera, else the spec's default)");
    command.add_option("--width", width, "image width in pixels")->capture_default_str();
    command.add_option("--height", height, "image height in pixels")->capture_default_str();
}

Camera CameraOptions::camera_for(const Scene& scene, const std::string& source, const SceneTransform& transform) const {
    if (width == 0 || height == 0 || width > 16384 || height > 16384)
        throw Error("--width and --height must be in [1, 16384]");
    if (!camera.empty()) return Camera::parse(camera);
    return camera_for_scene(scene, source, transform);
}

Progress::Progress(std::string label, bool enabled)
    : label_(std::move(label)), enabled_(enabled && isatty(STDERR_FILENO)), start_(std::chrono::steady_clock::now()) {}

Progress::~Progress() {
    if (drawn_) std::fprintf(stderr, "\r\033[K");
}

void Progress::update(double fraction) {
    if (!enabled_) return;
    const double elapsed = milliseconds_since(start_) / 1000.0;
    if (elapsed < 1.0) return;  // only work over about a second gets a bar
    std::lock_guard lock(mutex_);
    constexpr int kWidth = 30;
    const int filled = int(std::clamp(fraction, 0.0, 1.0) * kWidth);
    const double eta = fraction > 0.01 ? elapsed * (1.0 - fraction) / fraction : 0.0;
    std::fprintf(stderr, "\r%s [%.*s%*s] %3.0f%%  %.0fs elapsed, ~%.0fs left", label_.c_str(), filled,
                 "##############################", kWidth - filled, "", fraction * 100.0, elapsed, eta);
    std::fflush(stderr);
    drawn_ = true;
}

std::function<void(double)> Progress::callback() {
    if (!enabled_) return {};
    return [this](double fraction) { update(fraction); };
}

bool is_embree_tree(const std::string& builder) { return builder == "embree-medium" || builder == "embree-high"; }

Bvh build_tree(const Scene& scene, const BuildOptions& options) {
    if (options.builder == "embree-medium") return build_bvh_with_embree(scene, EmbreeQuality::medium, options);
    if (options.builder == "embree-high") return build_bvh_with_embree(scene, EmbreeQuality::high, options);
    return build_bvh(scene, options);  // our presets; reports an unknown name
}

std::string builder_list() {
    std::string names;
    for (const auto& name : builder_names()) names += name + ", ";
    return names + "embree-medium, embree-high (Embree 3's own binary trees under our kernel)";
}

double milliseconds_since(std::chrono::steady_clock::time_point start) {
    return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
}

double median(std::vector<double> values) {
    if (values.empty()) return 0.0;
    std::sort(values.begin(), values.end());
    const size_t n = values.size();
    return n % 2 ? values[n / 2] : 0.5 * (values[n / 2 - 1] + values[n / 2]);
}

void write_json(const std::string& path, const nlohmann::json& json) {
    if (path.empty()) return;
    std::ofstream out(path);
    if (!out) throw Error("cannot write JSON file '" + path + "'");
    out << json.dump(2) << '\n';
    if (!out) throw Error("error writing JSON file '" + path + "'");
}

}  // namespace spacebvh::cli
