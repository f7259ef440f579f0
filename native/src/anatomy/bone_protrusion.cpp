#include "anatomy/bone_protrusion.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <numeric>

namespace sd::anatomy {

ProxyShape ellipsoid_shape(const dvec3& center, const dmat3& axes, const dvec3& semi, int subdivisions) {
    // Icosahedron, then midpoint subdivision projected to the unit sphere.
    const double t = (1.0 + std::sqrt(5.0)) / 2.0;
    std::vector<dvec3> v = {{-1, t, 0},  {1, t, 0},  {-1, -t, 0}, {1, -t, 0}, {0, -1, t},  {0, 1, t},
                            {0, -1, -t}, {0, 1, -t}, {t, 0, -1},  {t, 0, 1},  {-t, 0, -1}, {-t, 0, 1}};
    for (dvec3& p : v) p = glm::normalize(p);
    std::vector<int32_t> f = {0, 11, 5,  0, 5,  1, 0, 1, 7, 0, 7,  10, 0, 10, 11, 1, 5, 9, 5, 11,
                              4, 11, 10, 2, 10, 7, 6, 7, 1, 8, 3,  9,  4, 3,  4,  2, 3, 2, 6, 3,
                              6, 8,  3,  8, 9,  4, 9, 5, 2, 4, 11, 6,  2, 10, 8,  6, 7, 9, 8, 1};
    for (int level = 0; level < subdivisions; ++level) {
        std::map<std::pair<int32_t, int32_t>, int32_t> mid;
        const auto midpoint = [&](int32_t a, int32_t b) {
            const auto key = std::make_pair(std::min(a, b), std::max(a, b));
            const auto it = mid.find(key);
            if (it != mid.end()) return it->second;
            v.push_back(glm::normalize(v[a] + v[b]));
            return mid[key] = static_cast<int32_t>(v.size() - 1);
        };
        std::vector<int32_t> g;
        for (size_t i = 0; i < f.size(); i += 3) {
            const int32_t a = f[i], b = f[i + 1], c = f[i + 2];
            const int32_t ab = midpoint(a, b), bc = midpoint(b, c), ca = midpoint(c, a);
            g.insert(g.end(), {a, ab, ca, b, bc, ab, c, ca, bc, ab, bc, ca});
        }
        f.swap(g);
    }
    ProxyShape s;
    for (const dvec3& p : v) {
        const dvec3 q = center + axes * (semi * p);
        s.positions.insert(s.positions.end(),
                           {static_cast<float>(q.x), static_cast<float>(q.y), static_cast<float>(q.z)});
    }
    s.triangles = f;
    return s;
}

namespace {
dvec3 at(const std::vector<float>& p, int i) { return dvec3(p[3 * i], p[3 * i + 1], p[3 * i + 2]); }
}  // namespace

BoneProxy::BoneProxy(int joint, double fraction, ProxyShape shape, std::string name)
    : joint_(joint), fraction_(fraction), name_(std::move(name)), shape_(std::move(shape)) {
    if (!(fraction_ >= 0.0 && fraction_ <= 1.0)) throw InvalidInput("a proxy's joint fraction must be in [0, 1]");
    const int N = static_cast<int>(shape_.positions.size() / 3);
    const int F = static_cast<int>(shape_.triangles.size() / 3);
    if (N < 4 || F < 4 || shape_.positions.size() % 3 || shape_.triangles.size() % 3)
        throw InvalidInput("a bone proxy needs >= 4 vertices and >= 4 triangles");
    for (float x : shape_.positions)
        if (!std::isfinite(x)) throw InvalidInput("a bone proxy vertex is not finite");
    for (int32_t i : shape_.triangles)
        if (i < 0 || i >= N) throw InvalidInput("a bone proxy triangle index is out of range");
    // Closed and consistently oriented: every directed edge once, its reverse once.
    std::map<std::pair<int32_t, int32_t>, int> directed;
    for (int t = 0; t < F; ++t)
        for (int k = 0; k < 3; ++k) ++directed[{shape_.triangles[3 * t + k], shape_.triangles[3 * t + (k + 1) % 3]}];
    for (const auto& [e, count] : directed) {
        const auto rev = directed.find({e.second, e.first});
        if (count != 1 || rev == directed.end() || rev->second != 1 || e.first == e.second)
            throw InvalidInput("a bone proxy must be a closed, consistently oriented triangle mesh");
    }
    // Volume centroid (signed tetrahedra from the vertex mean).
    dvec3 mean(0.0);
    for (int i = 0; i < N; ++i) mean += at(shape_.positions, i);
    mean /= N;
    double volume = 0.0;
    dvec3 moment(0.0);
    for (int t = 0; t < F; ++t) {
        const dvec3 a = at(shape_.positions, shape_.triangles[3 * t]) - mean;
        const dvec3 b = at(shape_.positions, shape_.triangles[3 * t + 1]) - mean;
        const dvec3 c = at(shape_.positions, shape_.triangles[3 * t + 2]) - mean;
        const double vt = glm::dot(a, glm::cross(b, c)) / 6.0;
        volume += vt;
        moment += vt * (a + b + c) / 4.0;
    }
    if (!(std::abs(volume) > 0.0)) throw InvalidInput("a bone proxy encloses no volume");
    if (volume < 0.0)
        for (int t = 0; t < F; ++t) std::swap(shape_.triangles[3 * t + 1], shape_.triangles[3 * t + 2]);
    center_ = mean + moment / volume;
    for (int t = 0; t < F; ++t) {
        const dvec3 a = at(shape_.positions, shape_.triangles[3 * t]);
        const dvec3 b = at(shape_.positions, shape_.triangles[3 * t + 1]);
        const dvec3 c = at(shape_.positions, shape_.triangles[3 * t + 2]);
        if (!(glm::dot(glm::cross(b - a, c - a), a - center_) > 0.0))
            throw InvalidInput("a bone proxy must be star-shaped about its centroid (triangle " + std::to_string(t) +
                               " faces it)");
    }
    for (int i = 0; i < N; ++i) bound_ = std::max(bound_, glm::length(at(shape_.positions, i) - center_));
    anchor_ = center_;
    anchor_bound_ = bound_;
    mesh_ = MeshTopology::build(N, shape_.triangles.data(), F, shape_.positions.data());
    std::vector<int32_t> all(F);
    std::iota(all.begin(), all.end(), 0);
    bvh_.build(mesh_, all, shape_.positions.data(), 4, false);
}

double BoneProxy::surface_distance(const dvec3& dir) const {
    const double o[3] = {center_.x, center_.y, center_.z}, d[3] = {dir.x, dir.y, dir.z};
    double t = 0.0;
    int32_t tri = -1;
    if (!bvh_.ray_first_hit(shape_.positions.data(), o, d, 1.01 * bound_ + 1e-12, &t, &tri)) return bound_;
    return t;
}

bool BoneProxy::contains(const dvec3& x) const {
    const dvec3 d = x - center_;
    const double r = glm::length(d);
    if (r >= bound_) return false;
    if (r == 0.0) return true;
    return r < surface_distance(d / r);
}

void BoneProxy::set_anchor(const dvec3& anchor) {
    anchor_ = anchor;
    anchor_bound_ = 0.0;
    for (size_t i = 0; i < shape_.positions.size() / 3; ++i)
        anchor_bound_ = std::max(anchor_bound_, glm::length(at(shape_.positions, static_cast<int>(i)) - anchor_));
}

double BoneProxy::push(const dmat4& transform, const float* p, double strength, std::vector<int32_t>& sources,
                       std::vector<dvec3>& deltas) const {
    const dmat4 inv = glm::inverse(transform);
    const dmat3 lin(transform);
    const double b2 = anchor_bound_ * anchor_bound_;
    double largest = 0.0;
    for (int32_t v : candidates_) {
        const dvec3 x = dvec3(inv * dvec4(p[3 * static_cast<size_t>(v)], p[3 * static_cast<size_t>(v) + 1],
                                          p[3 * static_cast<size_t>(v) + 2], 1.0));
        const dvec3 d = x - anchor_;
        const double r2 = glm::dot(d, d);
        if (r2 >= b2 || r2 == 0.0) continue;
        const double r = std::sqrt(r2);
        const dvec3 dir = d / r;
        const double o[3] = {anchor_.x, anchor_.y, anchor_.z}, dd[3] = {dir.x, dir.y, dir.z};
        double s = 0.0;
        int32_t tri = -1;
        if (!bvh_.ray_first_hit(shape_.positions.data(), o, dd, 1.01 * anchor_bound_, &s, &tri, true)) continue;
        if (!(r < s)) continue;
        const dvec3 delta = strength * (lin * ((s - r) * dir));
        sources.push_back(v);
        deltas.push_back(delta);
        largest = std::max(largest, glm::length(delta));
    }
    return largest;
}

}  // namespace sd::anatomy
