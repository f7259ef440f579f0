#include "deform/trunk_fill.h"

#include "math/flush_denormals.h"
#include "math/math_types.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <string>
#include <tuple>
#include <utility>

#include <Eigen/Core>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

namespace sd {

namespace {

/// Inside a bend the nearest point of the spine jumps from one segment to the next where the
/// two are equally far; skin raised along the nearest segment's direction alone turned there by
/// the bend's angle, a step across the belly (MakeHuman bent 45 degrees: 13 intersecting pairs,
/// new creases up to 170 degrees). So the direction is the mean of the directions away from
/// every segment, weighted by exp(-(d_i - d) / (this d)).
constexpr double kDirectionSoftness = 0.1;

/// A weight below exp(-this) is left out of the direction (below 1e-7 of the nearest's, under
/// a float's rounding of the raise).
constexpr double kNegligibleExponent = 16.0;
/// Vertices a task takes a block of, and the segments a spine may have for the block path (a
/// longer one is taken vertex by vertex).
constexpr size_t kFillBlock = 256, kBlockSegments = 8;
/// A posed distance from the spine below this (in the mesh's units) gives no direction in float.
constexpr float kOnTheSpine = 1e-30f;

/// The spine's segments in one pose, as away_from_spine reads them.
struct Spine {
    std::vector<dvec3> from, along;  ///< each segment's first joint, and the way to its second
    std::vector<double> inverse_length2;
    explicit Spine(const std::vector<dvec3>& joints) {
        for (size_t i = 0; i + 1 < joints.size(); ++i) {
            from.push_back(joints[i]);
            along.push_back(joints[i + 1] - joints[i]);
            const double len2 = glm::dot(along.back(), along.back());
            inverse_length2.push_back(len2 > 0.0 ? 1.0 / len2 : 0.0);
        }
    }
    /// p less its nearest point of segment i.
    dvec3 offset(const dvec3& p, size_t i) const {
        const double t = std::clamp(glm::dot(p - from[i], along[i]) * inverse_length2[i], 0.0, 1.0);
        return p - (from[i] + t * along[i]);
    }
};

/// The direction away from the spine of a point at distance d from it (soft, above), from its
/// offsets from the S segments: offset(k) the point less its nearest point of segment k, d2(k)
/// that offset's square length, `nearest` the segment at distance d.
template <class Offset, class Square>
dvec3 soft_away(size_t S, size_t nearest, double d, const Offset& offset, const Square& d2) {
    const double far = d * (1.0 + kNegligibleExponent * kDirectionSoftness);
    dvec3 away(0.0);
    for (size_t k = 0; k < S; ++k) {
        const double x = d2(k);
        if (x > far * far) continue;  // a weight below 1e-7
        const dvec3 o = offset(k);
        if (k == nearest) {  // weight 1
            away += o / d;
            continue;
        }
        const double di = std::sqrt(x);
        away += std::exp(-(di - d) / (kDirectionSoftness * d)) * (o / di);
    }
    const double len = glm::length(away);
    return len > 0.0 ? away / len : dvec3(0.0);
}

/// p's distance from the spine and the direction away from it (vertex by vertex: at rest, and
/// for a spine longer than the blocks take).
std::pair<double, dvec3> away_from_spine(const dvec3& p, const Spine& spine) {
    const size_t S = spine.from.size();
    double least = HUGE_VAL;
    size_t nearest = 0;
    for (size_t k = 0; k < S; ++k) {
        const dvec3 o = spine.offset(p, k);
        const double x = glm::dot(o, o);
        if (x < least) least = x, nearest = k;
    }
    const double d = std::sqrt(least);
    if (!(d > 0.0)) return {0.0, dvec3(0.0)};
    const auto offset = [&](size_t k) { return spine.offset(p, k); };
    const auto d2 = [&](size_t k) {
        const dvec3 o = spine.offset(p, k);
        return glm::dot(o, o);
    };
    return {d, soft_away(S, nearest, d, offset, d2)};
}

dvec3 point(const float* p, int32_t v) {
    const float* q = p + 3 * static_cast<size_t>(v);
    return dvec3(q[0], q[1], q[2]);
}

/// The share of the fill skin pressed to `ratio` of its rest distance keeps (kPressedIntoFold).
double pressed_share(double ratio) {
    return std::clamp((ratio - (1.0 - kPressedIntoFold)) / kPressedIntoFold, 0.0, 1.0);
}

}  // namespace

double fill_raise(double rest, double posed, double level) {
    if (!(rest > 0.0) || !(level > 1.0)) return 0.0;
    return std::clamp(level * rest - posed, 0.0, pressed_share(posed / rest) * (level - 1.0) * rest);
}

double fill_level(const std::vector<FillVertex>& skin, double asked) {
    if (!(asked > 0.0)) return 1.0;
    // Skin nearer the spine than at rest is raised by its pressed share x (L - 1) x rest for
    // every L >= 1, skin at ratio r >= 1 by (L - r) x rest once L passes r: the volume is
    // slope x L + offset between the ratios at or above 1, walked upwards until it reaches
    // what is asked. The ratios are first dealt into bins (a sort of them all was a fifth of a
    // frame of the 80K-vertex body); only the bin where the volume reaches what is asked is
    // sorted and walked.
    constexpr int kBins = 1024;
    const double width = (kHighestFillLevel - 1.0) / kBins;
    double slope = 0.0, offset = 0.0;
    std::vector<std::pair<double, double>> above;  // (ratio, area x weight x rest)
    std::vector<double> bin_g(kBins, 0.0), bin_gr(kBins, 0.0);
    std::vector<int32_t> bin_of;
    for (const FillVertex& v : skin) {
        if (!(v.rest > 0.0) || !(v.area > 0.0) || !(v.weight > 0.0)) continue;
        const double ratio = v.posed / v.rest, g = v.area * v.weight * v.rest;
        if (ratio < 1.0) {
            slope += g * pressed_share(ratio);
            offset -= g * pressed_share(ratio);
        } else if (ratio < kHighestFillLevel) {
            const int b = std::min(kBins - 1, static_cast<int>((ratio - 1.0) / width));
            above.push_back({ratio, g});
            bin_of.push_back(b);
            bin_g[b] += g;
            bin_gr[b] += g * ratio;
        }
    }
    int b = 0;
    for (; b < kBins; ++b) {  // the first bin at whose end the volume reaches what is asked
        const double end = 1.0 + (b + 1) * width;
        if ((slope + bin_g[b]) * end + (offset - bin_gr[b]) >= asked) break;
        slope += bin_g[b];
        offset -= bin_gr[b];
    }
    if (b < kBins) {
        std::vector<std::pair<double, double>> in;
        for (size_t i = 0; i < above.size(); ++i)
            if (bin_of[i] == b) in.push_back(above[i]);
        std::sort(in.begin(), in.end());
        for (const auto& [ratio, g] : in) {
            if (slope > 0.0 && slope * ratio + offset >= asked) break;
            slope += g;
            offset -= g * ratio;
        }
    }
    if (!(slope > 0.0)) return kHighestFillLevel;
    return std::clamp((asked - offset) / slope, 1.0, kHighestFillLevel);
}

TrunkFill::TrunkFill(const Rig& rig, const Binding& binding, const std::vector<int32_t>& triangles) {
    const int V = binding.vertex_count();
    if (triangles.size() % 3) throw InvalidInput("the skin's triangles must come in threes of vertex indices");
    for (size_t i = 0; i < triangles.size(); ++i)
        if (triangles[i] < 0 || triangles[i] >= V)
            throw InvalidInput("triangle corner " + std::to_string(i) + " is not a vertex index (0.." +
                               std::to_string(V - 1) + ")");
    const float* rest = binding.rest_positions.data();
    const double tiny = 1e-6 * std::max(rig.skeleton.extent(), 1e-30);
    for (size_t si = 0; si < rig.sweeps.size(); ++si) {
        const Sweep& s = rig.sweeps[si];
        if (!s.bends_smoothly) continue;
        Chain c;
        c.sweep = static_cast<int>(si);
        // The spine: joint to joint along the bones its keys ride (each joint the head of the
        // bone after it, as the skin sees the skeleton; MakeHuman's last spine bone ends 21 cm
        // below the neck's head), then the last bone's tail unless the sweep ends at a joint.
        for (const KeyEllipse& k : s.keys)
            if (k.bone >= 0 && k.bone < rig.skeleton.bone_count() &&
                (c.joint_bones.empty() || c.joint_bones.back() != k.bone)) {
                c.joint_bones.push_back(k.bone);
                c.joints.push_back(rig.skeleton.heads[k.bone]);
            }
        if (c.joints.empty()) continue;
        if (!s.keys.back().is_joint_key()) {
            c.joint_bones.push_back(c.joint_bones.back());
            c.joints.push_back(rig.skeleton.tails[c.joint_bones.back()]);
        }
        if (c.joints.size() < 2) continue;
        const Spine rest_spine(c.joints);
        std::vector<int32_t> local(V, -1);
        for (int v = 0; v < V; ++v) {
            double w = 0.0;
            for (uint32_t i = binding.sweep_offsets[v]; i < binding.sweep_offsets[v + 1]; ++i)
                if (binding.sweep_influences[i].sweep == c.sweep) w += binding.sweep_influences[i].weight;
            if (!(w > 0.0)) continue;
            const double d = away_from_spine(point(rest, v), rest_spine).first;
            if (!(d > tiny)) continue;  // on the spine: no direction to raise it in
            local[v] = static_cast<int32_t>(c.vertex.size());
            c.vertex.push_back(v);
            c.weight.push_back(std::min(w, 1.0));
            c.rest.push_back(d);
        }
        if (c.vertex.empty()) continue;
        // The triangles about its skin; which way they face, read at rest (a mesh wound inside
        // out faces the spine).
        double facing = 0.0;
        for (size_t t = 0; t + 2 < triangles.size(); t += 3) {
            const int32_t l0 = local[triangles[t]], l1 = local[triangles[t + 1]], l2 = local[triangles[t + 2]];
            if (l0 < 0 && l1 < 0 && l2 < 0) continue;
            c.triangles.insert(c.triangles.end(), {triangles[t], triangles[t + 1], triangles[t + 2]});
            c.corners.insert(c.corners.end(), {l0, l1, l2});
            const dvec3 p0 = point(rest, triangles[t]), p1 = point(rest, triangles[t + 1]),
                        p2 = point(rest, triangles[t + 2]);
            const dvec3 centre = (p0 + p1 + p2) / 3.0;
            const dvec3 away = away_from_spine(centre, rest_spine).second;
            facing += glm::dot(glm::cross(p1 - p0, p2 - p0), away);
        }
        c.facing = facing < 0.0 ? -1.0 : 1.0;
        chains_.push_back(std::move(c));
    }
}

bool TrunkFill::fills(int sweep) const {
    return std::any_of(chains_.begin(), chains_.end(), [&](const Chain& c) { return c.sweep == sweep; });
}

std::vector<double> TrunkFill::apply(const SkeletonPose& pose, const std::vector<double>& need, float* out) const {
    std::vector<double> levels;
    for (const Chain& c : chains_) {
        const double asked = c.sweep < static_cast<int>(need.size()) ? need[c.sweep] : 0.0;
        levels.push_back(1.0);
        if (!(asked > 0.0)) continue;
        std::vector<dvec3> away;
        std::vector<FillVertex> skin = posed_skin(c, pose, out, away);
        // The posed mesh's area about each vertex along its way out (a third of each of its
        // triangles'): the volume a raise puts back, to first order. (The rest area overstated it
        // where the bend compresses the skin: MakeHuman's region came back to -1.6 % instead of
        // -0.3 %.)
        // (In float: a sixth of a frame's fill in double.)
        std::vector<glm::vec3> area(skin.size(), glm::vec3(0.0f));
        const float sixth = static_cast<float>(c.facing / 6.0);
        const auto at = [out](int32_t v) {
            const float* q = out + 3 * static_cast<size_t>(v);
            return glm::vec3(q[0], q[1], q[2]);
        };
        for (size_t t = 0; t < c.corners.size(); t += 3) {
            const glm::vec3 p0 = at(c.triangles[t]), p1 = at(c.triangles[t + 1]), p2 = at(c.triangles[t + 2]);
            const glm::vec3 third = sixth * glm::cross(p1 - p0, p2 - p0);
            for (int k = 0; k < 3; ++k)
                if (c.corners[t + k] >= 0) area[c.corners[t + k]] += third;
        }
        for (size_t i = 0; i < skin.size(); ++i) skin[i].area = std::max(0.0, glm::dot(dvec3(area[i]), away[i]));
        levels.back() = fill_level(skin, asked);
        raise(c, skin, away, levels.back(), out);
    }
    return levels;
}

void TrunkFill::apply_levels(const SkeletonPose& pose, const std::vector<double>& levels, float* out) const {
    for (size_t ci = 0; ci < chains_.size() && ci < levels.size(); ++ci) {
        if (!(levels[ci] > 1.0)) continue;
        std::vector<dvec3> away;
        const std::vector<FillVertex> skin = posed_skin(chains_[ci], pose, out, away);
        raise(chains_[ci], skin, away, levels[ci], out);
    }
}

std::vector<FillVertex> TrunkFill::posed_skin(const Chain& c, const SkeletonPose& pose, const float* out,
                                              std::vector<dvec3>& away) {
    std::vector<dvec3> joints(c.joints.size());
    for (size_t j = 0; j < joints.size(); ++j)
        joints[j] = dvec3(pose.deform[c.joint_bones[j]] * dvec4(c.joints[j], 1.0));
    const Spine spine(joints);
    const size_t n = c.vertex.size();
    std::vector<FillVertex> skin(n);
    away.assign(n, dvec3(0.0));
    const size_t S = spine.from.size();
    tbb::parallel_for(tbb::blocked_range<size_t>(0, n, kFillBlock), [&](const tbb::blocked_range<size_t>& r) {
        const FlushDenormals flush;
        for (size_t i = r.begin(); i < r.end(); ++i) {
            skin[i].rest = c.rest[i];
            skin[i].weight = c.weight[i];
        }
        if (S > kBlockSegments) {  // a long spine: vertex by vertex
            for (size_t i = r.begin(); i < r.end(); ++i)
                std::tie(skin[i].posed, away[i]) = away_from_spine(point(out, c.vertex[i]), spine);
            return;
        }
        // Block by block, one segment at a time over the block's vertices in float (loops the
        // compiler vectorises; vertex by vertex in double this pass was a fifth of a frame of the
        // 80K-vertex body), then each vertex's direction from its segments' offsets.
        for (size_t b0 = r.begin(); b0 < r.end(); b0 += kFillBlock) {
            const size_t m = std::min(kFillBlock, r.end() - b0);
            alignas(32) float px[kFillBlock], py[kFillBlock], pz[kFillBlock];
            alignas(32) float ox[kBlockSegments][kFillBlock], oy[kBlockSegments][kFillBlock],
                oz[kBlockSegments][kFillBlock], d2[kBlockSegments][kFillBlock];
            for (size_t i = 0; i < m; ++i) {
                const float* q = out + 3 * static_cast<size_t>(c.vertex[b0 + i]);
                px[i] = q[0], py[i] = q[1], pz[i] = q[2];
            }
            for (size_t k = 0; k < S; ++k) {
                const float ax = static_cast<float>(spine.from[k].x), ay = static_cast<float>(spine.from[k].y),
                            az = static_cast<float>(spine.from[k].z), ex = static_cast<float>(spine.along[k].x),
                            ey = static_cast<float>(spine.along[k].y), ez = static_cast<float>(spine.along[k].z),
                            inv = static_cast<float>(spine.inverse_length2[k]);
                for (size_t i = 0; i < m; ++i) {
                    const float dx = px[i] - ax, dy = py[i] - ay, dz = pz[i] - az;
                    const float t = std::min(1.0f, std::max(0.0f, (dx * ex + dy * ey + dz * ez) * inv));
                    const float x = dx - t * ex, y = dy - t * ey, z = dz - t * ez;
                    ox[k][i] = x, oy[k][i] = y, oz[k][i] = z;
                    d2[k][i] = x * x + y * y + z * z;
                }
            }
            // Each vertex's distance (its nearest segment's), then the soft mean of the ways away
            // from the segments in float over the block: Eigen's exp takes a packet at a time
            // (vertex by vertex in double, with libm's exp, this was a sixth of a frame).
            alignas(32) float dist[kFillBlock], soft[kFillBlock], far2[kFillBlock], wx[kFillBlock], wy[kFillBlock],
                wz[kFillBlock], e[kFillBlock], inv_dk[kFillBlock];
            std::copy(d2[0], d2[0] + m, dist);
            for (size_t k = 1; k < S; ++k)
                for (size_t i = 0; i < m; ++i) dist[i] = std::min(dist[i], d2[k][i]);
            for (size_t i = 0; i < m; ++i) {
                dist[i] = std::sqrt(dist[i]);
                // (A distance so small that its inverse overflows, on the spine as far as a float
                // can tell, has no direction: 0 x inf would make the nearest segment's weight NaN.)
                soft[i] = dist[i] > kOnTheSpine ? -1.0f / (static_cast<float>(kDirectionSoftness) * dist[i]) : 0.0f;
                const float far = dist[i] * static_cast<float>(1.0 + kNegligibleExponent * kDirectionSoftness);
                far2[i] = far * far;
                wx[i] = wy[i] = wz[i] = 0.0f;
            }
            for (size_t k = 0; k < S; ++k) {
                for (size_t i = 0; i < m; ++i) {
                    const float dk = std::sqrt(d2[k][i]);
                    inv_dk[i] = dk > 0.0f && d2[k][i] <= far2[i] ? 1.0f / dk : 0.0f;  // 0: a weight below 1e-7
                    e[i] = (dk - dist[i]) * soft[i];
                }
                Eigen::Map<Eigen::ArrayXf> exponent(e, static_cast<Eigen::Index>(m));
                exponent = exponent.exp();
                for (size_t i = 0; i < m; ++i) {
                    const float w = e[i] * inv_dk[i];
                    wx[i] += w * ox[k][i], wy[i] += w * oy[k][i], wz[i] += w * oz[k][i];
                }
            }
            for (size_t i = 0; i < m; ++i) {
                skin[b0 + i].posed = dist[i];
                const float len = std::sqrt(wx[i] * wx[i] + wy[i] * wy[i] + wz[i] * wz[i]);
                away[b0 + i] = len > 0.0f ? dvec3(wx[i] / len, wy[i] / len, wz[i] / len) : dvec3(0.0);
            }
        }
    });
    return skin;
}

void TrunkFill::raise(const Chain& c, const std::vector<FillVertex>& skin, const std::vector<dvec3>& away, double level,
                      float* out) {
    for (size_t i = 0; i < skin.size(); ++i) {
        const double r = c.weight[i] * fill_raise(c.rest[i], skin[i].posed, level);
        if (!(r > 0.0)) continue;
        float* q = out + 3 * static_cast<size_t>(c.vertex[i]);
        for (int k = 0; k < 3; ++k) q[k] += static_cast<float>(r * away[i][k]);
    }
}

std::vector<int32_t> TrunkFill::vertices_read() const {
    std::vector<int32_t> v;
    for (const Chain& c : chains_) {
        v.insert(v.end(), c.vertex.begin(), c.vertex.end());
        v.insert(v.end(), c.triangles.begin(), c.triangles.end());
    }
    std::sort(v.begin(), v.end());
    v.erase(std::unique(v.begin(), v.end()), v.end());
    return v;
}

std::vector<int32_t> TrunkFill::triangles_read() const {
    std::vector<std::array<int32_t, 3>> t;
    for (const Chain& c : chains_)
        for (size_t i = 0; i + 2 < c.triangles.size(); i += 3)
            t.push_back({c.triangles[i], c.triangles[i + 1], c.triangles[i + 2]});
    std::sort(t.begin(), t.end());  // (two chains may share a triangle: once)
    t.erase(std::unique(t.begin(), t.end()), t.end());
    std::vector<int32_t> flat;
    for (const auto& x : t) flat.insert(flat.end(), x.begin(), x.end());
    return flat;
}

}  // namespace sd
