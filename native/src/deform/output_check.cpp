#include "deform/output_check.h"

#include "math/flush_denormals.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

namespace sd {

namespace {

constexpr int32_t kGrain = 4096;
/// The float filter's bound is this share below the exact one. Float rounding of a squared
/// distance is far below it for a body within ~1000x its floor distance of the origin (a
/// body in metres anywhere in a scene of kilometres); farther out, a vertex within float
/// rounding of the bound may pass the filter.
constexpr double kFilterMargin = 1e-3;

dmat4 matrix_at(const float* m16) {
    dmat4 m;
    for (int c = 0; c < 4; ++c)
        for (int r = 0; r < 4; ++r) m[c][r] = m16[4 * c + r];
    return m;
}

/// Every entry of #B*16 matrices finite and not enormous. @throws InvalidInput naming `what`.
void require_matrices(const float* m, int32_t bone_count, const char* what) {
    if (!m) throw InvalidInput(std::string(what) + " is NULL");
    for (int64_t i = 0; i < 16 * static_cast<int64_t>(bone_count); ++i)
        if (!std::isfinite(m[i]) || std::abs(m[i]) > 1e12f)
            throw InvalidInput(std::string(what) + ": bone " + std::to_string(i / 16) +
                               " has a non-finite or enormous value");
}

/// A bone as a segment: its head and head -> tail (the matrix's Y axis times its length).
struct Segment {
    dvec3 head, axis;
    double inv_aa;
};

std::vector<Segment> segments(const float* pose, const std::vector<double>& lengths) {
    std::vector<Segment> s(lengths.size());
    for (size_t b = 0; b < lengths.size(); ++b) {
        const float* m = pose + 16 * b;
        s[b].head = dvec3(m[12], m[13], m[14]);
        s[b].axis = dvec3(m[4], m[5], m[6]) * lengths[b];
        s[b].inv_aa = 1.0 / std::max(glm::dot(s[b].axis, s[b].axis), 1e-30);
    }
    return s;
}

double distance2(const dvec3& p, const Segment& s) {
    const dvec3 d = p - s.head;
    const double t = std::clamp(glm::dot(d, s.axis) * s.inv_aa, 0.0, 1.0);
    const dvec3 e = d - t * s.axis;
    return glm::dot(e, e);
}

}  // namespace

OutputCheck::OutputCheck(int32_t vertex_count, const float* rest_positions, int32_t bone_count, const float* rest_pose,
                         const float* bone_lengths, int32_t skin_slots, const int32_t* skin_bones,
                         const float* skin_weights, double floor_share) {
    if (vertex_count < 1 || vertex_count > 50'000'000)
        throw InvalidInput("vertex_count must be in 1..50000000, got " + std::to_string(vertex_count));
    if (bone_count < 1 || bone_count > 100'000)
        throw InvalidInput("bone_count must be in 1..100000, got " + std::to_string(bone_count));
    if (skin_slots < 0 || skin_slots > 64)
        throw InvalidInput("skin_slots must be in 0..64, got " + std::to_string(skin_slots));
    if (!rest_positions || !bone_lengths) throw InvalidInput("rest_positions or bone_lengths is NULL");
    if (skin_slots > 0 && (!skin_bones || !skin_weights)) throw InvalidInput("skin_bones or skin_weights is NULL");
    if (!(floor_share >= 0.0 && floor_share <= 1.0)) throw InvalidInput("floor_share must be in [0, 1]");
    require_matrices(rest_pose, bone_count, "rest_pose");
    const size_t V = static_cast<size_t>(vertex_count);
    rest_.resize(V);
    dvec3 lo(std::numeric_limits<double>::infinity()), hi(-std::numeric_limits<double>::infinity());
    for (size_t v = 0; v < V; ++v) {
        const float* p = rest_positions + 3 * v;
        for (int k = 0; k < 3; ++k)
            if (!std::isfinite(p[k]) || std::abs(p[k]) > 1e12f)
                throw InvalidInput("rest vertex " + std::to_string(v) + " has a non-finite or enormous coordinate");
        rest_[v] = dvec3(p[0], p[1], p[2]);
        lo = glm::min(lo, rest_[v]);
        hi = glm::max(hi, rest_[v]);
    }
    lengths_.resize(bone_count);
    inverse_rest_.resize(bone_count);
    for (int32_t b = 0; b < bone_count; ++b) {
        if (!std::isfinite(bone_lengths[b]) || !(bone_lengths[b] > 0.0f) || bone_lengths[b] > 1e12f)
            throw InvalidInput("bone " + std::to_string(b) + " has a length that is not finite and > 0");
        lengths_[b] = bone_lengths[b];
        const dmat4 m = matrix_at(rest_pose + 16 * b);
        const double det = glm::determinant(m);
        if (!std::isfinite(det) || std::abs(det) < 1e-18)
            throw InvalidInput("the rest matrix of bone " + std::to_string(b) + " is not invertible");
        inverse_rest_[b] = glm::inverse(m);
    }
    slots_ = skin_slots;
    skin_.assign(V * skin_slots, Slot{0, 0.0});
    bones_.assign(V, Bones{});
    heaviest_.assign(V, -1);
    for (size_t v = 0; v < V; ++v) {
        double total = 0.0;
        int32_t first = -1, second = -1;  // slots of the heaviest two (the earlier slot among equals)
        double w_first = 0.0, w_second = 0.0;
        for (int32_t s = 0; s < skin_slots; ++s) {
            const int32_t id = skin_bones[v * skin_slots + s];
            const float w = skin_weights[v * skin_slots + s];
            if (id < -1 || id >= bone_count)
                throw InvalidInput("vertex " + std::to_string(v) + " has skin bone " + std::to_string(id) +
                                   ", out of range");
            if (!std::isfinite(w) || w < 0.0f || w > 1e12f)
                throw InvalidInput("vertex " + std::to_string(v) + " has a skin weight that is not finite and >= 0");
            if (id < 0 || w <= 0.0f) continue;
            skin_[v * skin_slots + s] = Slot{id, w};
            total += w;
            if (first < 0 || w > w_first) {
                second = first, w_second = w_first;
                first = s, w_first = w;
            } else if (second < 0 || w > w_second) {
                second = s, w_second = w;
            }
        }
        if (first < 0) continue;  // no skin weights: never beyond, stays at rest in the fallback
        for (int32_t s = 0; s < skin_slots; ++s) skin_[v * skin_slots + s].weight /= total;
        heaviest_[v] = skin_bones[v * skin_slots + first];
        bones_[v].near = heaviest_[v];
        bones_[v].far = second < 0 ? heaviest_[v] : skin_bones[v * skin_slots + second];
    }
    const double floor = floor_share * glm::length(hi - lo);
    const std::vector<Segment> rest = segments(rest_pose, lengths_);
    rest_distance_.assign(V, floor);
    tbb::this_task_arena::isolate([&] {
        tbb::parallel_for(tbb::blocked_range<size_t>(0, V, kGrain), [&](const tbb::blocked_range<size_t>& r) {
            for (size_t v = r.begin(); v != r.end(); ++v) {
                Bones& b = bones_[v];
                if (b.near < 0) continue;
                const double d_near = distance2(rest_[v], rest[b.near]), d_far = distance2(rest_[v], rest[b.far]);
                if (d_far < d_near) std::swap(b.near, b.far);
                rest_distance_[v] = std::max(std::sqrt(std::min(d_near, d_far)), floor);
                b.rest2 = rest_distance_[v] * rest_distance_[v];
            }
        });
    });
    // The filter's copy: the bone nearer at rest and the squared rest distance less the margin
    // (a vertex without skin weights: bone 0 and no bound).
    near_.resize(V);
    filter_rest2_.resize(V);
    for (size_t v = 0; v < V; ++v) {
        near_[v] = bones_[v].near < 0 ? 0 : bones_[v].near;
        // (a rest distance of 0 never passes: only the exact test can tell 0 from tiny)
        filter_rest2_[v] = bones_[v].near < 0      ? std::numeric_limits<float>::infinity()
                           : bones_[v].rest2 > 0.0 ? static_cast<float>(bones_[v].rest2 * (1.0 - kFilterMargin))
                                                   : -1.0f;
    }
    // A floor of 0 (floor_share 0, or a body without extent) leaves a vertex on its bone with
    // rest distance 0: on its bone it is ratio 0, any move off it an infinite ratio.
}

namespace {

/// The posed bones as float segments, one array per coordinate (the filter's gathers).
struct FloatSegments {
    std::vector<float> hx, hy, hz, ax, ay, az, inv_aa;
    explicit FloatSegments(const std::vector<Segment>& s)
        : hx(s.size()), hy(s.size()), hz(s.size()), ax(s.size()), ay(s.size()), az(s.size()), inv_aa(s.size()) {
        for (size_t b = 0; b < s.size(); ++b) {
            hx[b] = float(s[b].head.x), hy[b] = float(s[b].head.y), hz[b] = float(s[b].head.z);
            ax[b] = float(s[b].axis.x), ay[b] = float(s[b].axis.y), az[b] = float(s[b].axis.z);
            inv_aa[b] = float(s[b].inv_aa);
        }
    }
};

// An AVX2 copy of the filter beside the baseline one, picked when the library loads (GCC on
// x86-64; the baseline x86-64 build has only SSE2): about twice as fast on 75K vertices.
#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__)
#define SD_FILTER_CLONES __attribute__((target_clones("avx2", "default")))
#else
#define SD_FILTER_CLONES
#endif

/// How many vertices of [begin, end) are farther from their bone nearer at rest than
/// sqrt(limit2 x bound2[v]) (or not finite). Branch-free float arithmetic the compiler
/// vectorises (this file is built with -fno-trapping-math, which lets it turn the clamps and
/// the comparison into selects); a NaN fails the comparison, so it counts.
SD_FILTER_CLONES int32_t count_past(int32_t begin, int32_t end, const float* __restrict positions,
                                    const int32_t* __restrict near, const float* __restrict bound2,
                                    const FloatSegments& s, float limit2) {
    const float *hx = s.hx.data(), *hy = s.hy.data(), *hz = s.hz.data();
    const float *ax = s.ax.data(), *ay = s.ay.data(), *az = s.az.data(), *inv = s.inv_aa.data();
    int32_t past = 0;
    for (int32_t v = begin; v < end; ++v) {
        const int32_t b = near[v];
        float dx = positions[3 * v] - hx[b], dy = positions[3 * v + 1] - hy[b], dz = positions[3 * v + 2] - hz[b];
        float t = (dx * ax[b] + dy * ay[b] + dz * az[b]) * inv[b];
        t = t < 0.0f ? 0.0f : t;
        t = t > 1.0f ? 1.0f : t;
        dx -= t * ax[b], dy -= t * ay[b], dz -= t * az[b];
        past += (dx * dx + dy * dy + dz * dz <= limit2 * bound2[v]) ? 0 : 1;
    }
    return past;
}

}  // namespace

/// A frame's posed bones and limits, as the exact test and the filter read them.
struct OutputCheck::Frame::Posed {
    std::vector<Segment> bones;
    FloatSegments fast;
    double limit2;
    float fast_limit2;
    bool use_filter;
};

OutputCheck::Frame::Frame(const OutputCheck& check, const float* pose, double ratio_limit, float* ratios,
                          int32_t block_size)
    : check_(check), ratios_(ratios), block_size_(block_size) {
    if (!(ratio_limit > 0.0) || !std::isfinite(ratio_limit)) throw InvalidInput("ratio_limit must be finite and > 0");
    if (block_size < 1) throw InvalidInput("block_size must be >= 1");
    require_matrices(pose, check.bone_count(), "pose");
    std::vector<Segment> posed = segments(pose, check.lengths_);
    FloatSegments fast(posed);
    const double limit2 = ratio_limit * ratio_limit;
    // (a limit below 1e-3, which asks for the frame's largest ratios, goes to the exact test)
    posed_.reset(new Posed{std::move(posed), std::move(fast), limit2, static_cast<float>(limit2),
                           !ratios && ratio_limit >= 1e-3});
    const int32_t V = check.vertex_count();
    found_.resize(static_cast<size_t>((V + block_size - 1) / block_size));
}

OutputCheck::Frame::~Frame() = default;

// Two passes per block. The filter (float, one bone) passes a block whose every vertex is
// within the limit of its bone nearer at rest, by a margin (its bound is kFilterMargin below
// the true one), so float rounding never passes a vertex the exact test would not: within by
// that bone means within, the nearer of the two being nearer still. Any other block, and
// every block when `ratios` is asked, gets the exact test: double, both bones, a vertex
// beyond when !(d^2 <= limit^2 rest^2) (NaN too), its ratio sqrt(d^2 / rest^2).
void OutputCheck::Frame::range(const float* positions, int32_t block) {
    const OutputCheck& c = check_;
    const Posed& p = *posed_;
    const int32_t begin = block * block_size_, end = std::min(c.vertex_count(), begin + block_size_);
    if (p.use_filter &&
        count_past(begin, end, positions, c.near_.data(), c.filter_rest2_.data(), p.fast, p.fast_limit2) == 0)
        return;
    Verdict& chunk = found_[static_cast<size_t>(block)];
    for (int32_t v = begin; v != end; ++v) {
        const Bones& b = c.bones_[v];
        if (b.near < 0) {
            if (ratios_) ratios_[v] = 0.0f;
            continue;
        }
        const float* at = positions + 3 * static_cast<size_t>(v);
        const dvec3 q(at[0], at[1], at[2]);
        double d2 = distance2(q, p.bones[b.near]);
        if (b.far != b.near) {
            const double other = distance2(q, p.bones[b.far]);
            if (other < d2) d2 = other;  // a NaN d2 stays NaN
        }
        double ratio = d2 == 0.0 ? 0.0 : std::sqrt(d2 / b.rest2);
        if (!std::isfinite(ratio)) ratio = std::numeric_limits<double>::infinity();  // NaN too
        if (ratios_) ratios_[v] = static_cast<float>(ratio);
        if (d2 <= p.limit2 * b.rest2) continue;
        ++chunk.beyond;
        if (chunk.worst_vertex < 0 || ratio > chunk.worst_ratio)
            chunk.worst_ratio = ratio, chunk.worst_vertex = v, chunk.worst_bone = c.heaviest_[v];
    }
}

OutputCheck::Verdict OutputCheck::Frame::verdict() const {
    Verdict result;
    for (const Verdict& chunk : found_) {
        result.beyond += chunk.beyond;
        if (chunk.worst_vertex >= 0 && (result.worst_vertex < 0 || chunk.worst_ratio > result.worst_ratio)) {
            result.worst_ratio = chunk.worst_ratio;
            result.worst_vertex = chunk.worst_vertex;
            result.worst_bone = chunk.worst_bone;
        }
    }
    return result;
}

OutputCheck::Verdict OutputCheck::check(const float* pose, const float* positions, double ratio_limit,
                                        float* ratios) const {
    if (!positions) throw InvalidInput("positions is NULL");
    Frame frame(*this, pose, ratio_limit, ratios, kGrain);
    const int32_t chunks = (vertex_count() + kGrain - 1) / kGrain;
    tbb::this_task_arena::isolate([&] {
        tbb::parallel_for(tbb::blocked_range<int32_t>(0, chunks, 1), [&](const tbb::blocked_range<int32_t>& r) {
            const FlushDenormals flush;  // a frame's check (flush_denormals.h)
            for (int32_t c = r.begin(); c != r.end(); ++c) frame.range(positions, c);
        });
    });
    return frame.verdict();
}

void OutputCheck::linear_blend(const float* pose, float* out) const {
    if (!out) throw InvalidInput("out_positions is NULL");
    require_matrices(pose, bone_count(), "pose");
    std::vector<dmat4> skinning(lengths_.size());
    for (size_t b = 0; b < skinning.size(); ++b) skinning[b] = matrix_at(pose + 16 * b) * inverse_rest_[b];
    tbb::this_task_arena::isolate([&] {
        tbb::parallel_for(tbb::blocked_range<size_t>(0, rest_.size(), kGrain),
                          [&](const tbb::blocked_range<size_t>& r) {
                              const FlushDenormals flush;
                              for (size_t v = r.begin(); v != r.end(); ++v) {
                                  dvec3 p = rest_[v];
                                  if (heaviest_[v] >= 0) {
                                      dvec3 sum(0.0);
                                      for (int32_t s = 0; s < slots_; ++s) {
                                          const Slot& slot = skin_[v * slots_ + s];
                                          if (slot.weight > 0.0)
                                              sum += slot.weight * dvec3(skinning[slot.bone] * dvec4(rest_[v], 1.0));
                                      }
                                      p = sum;
                                  }
                                  for (int k = 0; k < 3; ++k) out[3 * v + k] = static_cast<float>(p[k]);
                              }
                          });
    });
}

}  // namespace sd
