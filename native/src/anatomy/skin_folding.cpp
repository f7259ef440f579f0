#include "anatomy/skin_folding.h"
#include "geometry/disjoint_sets.h"

#include <Eigen/Eigenvalues>

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <numeric>

namespace sd::anatomy {

namespace {

// cos 75 degrees: how squarely skin must face the other sheet to be pulled back.
constexpr double kFacing = 0.26;

dvec3 point(const float* p, int v) {
    return dvec3(p[3 * static_cast<size_t>(v)], p[3 * static_cast<size_t>(v) + 1], p[3 * static_cast<size_t>(v) + 2]);
}

/// The part most of a triangle's vertices belong to (the first vertex's on a three-way tie).
int32_t triangle_part(const MeshTopology& mesh, const SkinParts& parts, int t) {
    const int32_t* v = mesh.triangle(t);
    const int32_t a = parts.part[v[0]], b = parts.part[v[1]], c = parts.part[v[2]];
    return (b == c) ? b : a;
}

/// How far a vertex `depth` past the plane (negative: short of it) is pulled towards it: the
/// depth itself beyond `soft`, nothing below -soft, and a quadratic blend between (C1, and never
/// less than the depth, so every pulled vertex ends on its own side).
double pull_depth(double depth, double soft) {
    if (depth >= soft) return depth;
    if (depth <= -soft) return 0.0;
    return (depth + soft) * (depth + soft) / (4.0 * soft);
}

/// Area-weighted vertex normal at the current positions.
dvec3 vertex_normal(const MeshTopology& mesh, const float* p, int v) {
    dvec3 n(0.0);
    for (uint32_t i = mesh.vertex_triangle_offsets[v]; i < mesh.vertex_triangle_offsets[v + 1]; ++i) {
        const int32_t* t = mesh.triangle(mesh.vertex_triangles[i]);
        n += glm::cross(point(p, t[1]) - point(p, t[0]), point(p, t[2]) - point(p, t[0]));
    }
    return n;
}

}  // namespace

FoldingStats SkinFolding::fold(const MeshTopology& mesh, const SkinParts& parts, const std::vector<TrianglePair>& pairs,
                               const std::vector<dvec3>& part_reference, const std::vector<int32_t>& triangle_joint,
                               const std::vector<FoldingParams>& params, float* p, VertexEdits& edits, Falloff& falloff,
                               std::vector<int32_t>* moved, std::vector<TrianglePair>* single_part) {
    FoldingStats stats;
    if (pairs.empty()) return stats;
    const int T = mesh.triangle_count(), V = mesh.vertex_count;
    if (static_cast<int>(local_of_triangle_.size()) != T) local_of_triangle_.assign(T, -1);
    if (static_cast<int>(vertex_mark_.size()) != V) {
        vertex_mark_.assign(V, -1);
        vertex_side_.assign(V, 0);
    }
    label_mask_.assign(part_reference.size(), 0);

    // Intersection regions: triangles joined by intersecting pairs and by shared vertices.
    std::vector<int32_t> tris;
    for (const TrianglePair& pr : pairs)
        for (int32_t t : {pr.a, pr.b})
            if (local_of_triangle_[t] < 0) {
                local_of_triangle_[t] = static_cast<int32_t>(tris.size());
                tris.push_back(t);
            }
    DisjointSets sets(tris.size());
    for (const TrianglePair& pr : pairs) sets.unite(local_of_triangle_[pr.a], local_of_triangle_[pr.b]);
    for (size_t i = 0; i < tris.size(); ++i) {
        const int32_t* tv = mesh.triangle(tris[i]);
        for (int k = 0; k < 3; ++k)
            for (uint32_t j = mesh.vertex_triangle_offsets[tv[k]]; j < mesh.vertex_triangle_offsets[tv[k] + 1]; ++j) {
                const int32_t o = local_of_triangle_[mesh.vertex_triangles[j]];
                if (o >= 0) sets.unite(static_cast<int32_t>(i), o);
            }
    }
    std::map<int32_t, std::vector<size_t>> region_pairs;
    for (size_t i = 0; i < pairs.size(); ++i) region_pairs[sets.find(local_of_triangle_[pairs[i].a])].push_back(i);
    std::map<int32_t, std::vector<int32_t>> region_tris;
    for (size_t i = 0; i < tris.size(); ++i) region_tris[sets.find(static_cast<int32_t>(i))].push_back(tris[i]);

    for (auto& [root, rp] : region_pairs) {
        const std::vector<int32_t>& rt = region_tris[root];
        ++stats.regions;
        stamp_ += 2;
        const int region_stamp = stamp_;     // vertex of the region
        const int flood_stamp = stamp_ + 1;  // vertex reached by the flood

        // 1. Sides.
        std::map<std::pair<int32_t, int32_t>, int> counts;
        for (size_t i : rp) {
            const int32_t la = triangle_part(mesh, parts, pairs[i].a), lb = triangle_part(mesh, parts, pairs[i].b);
            if (la != lb && la >= 0 && lb >= 0) ++counts[{std::min(la, lb), std::max(la, lb)}];
        }
        std::map<int32_t, int> side_of_part;
        const bool by_parts = !counts.empty();
        if (by_parts) {
            auto best = counts.begin();
            for (auto it = counts.begin(); it != counts.end(); ++it)
                if (it->second > best->second) best = it;
            side_of_part[best->first.first] = -1;
            side_of_part[best->first.second] = 1;
            for (int round = 0; round < 3; ++round)
                for (size_t i : rp) {
                    const int32_t la = triangle_part(mesh, parts, pairs[i].a),
                                  lb = triangle_part(mesh, parts, pairs[i].b);
                    if (la == lb || la < 0 || lb < 0) continue;
                    const bool ha = side_of_part.count(la) > 0, hb = side_of_part.count(lb) > 0;
                    if (ha && !hb) side_of_part[lb] = -side_of_part[la];
                    if (hb && !ha) side_of_part[la] = -side_of_part[lb];
                }
        } else {
            ++stats.single_part_regions;
        }
        int32_t joint = -1;
        {
            std::map<int32_t, int> votes;
            for (int32_t t : rt) ++votes[triangle_joint[t]];
            int most = -1;
            for (auto [j, count] : votes)
                if (count > most) {
                    most = count;
                    joint = j;
                }
        }
        FoldingParams fp = joint >= 0 && joint < static_cast<int32_t>(params.size()) ? params[joint] : FoldingParams{};
        if (single_part && (!by_parts || !fp.planes)) {
            for (size_t i : rp) single_part->push_back(pairs[i]);
            continue;
        }

        // 2. The bisecting plane through the region's vertices.
        std::vector<int32_t> verts;
        for (int32_t t : rt)
            for (int k = 0; k < 3; ++k) {
                const int32_t v = mesh.triangle(t)[k];
                if (vertex_mark_[v] != region_stamp) {
                    vertex_mark_[v] = region_stamp;
                    verts.push_back(v);
                }
            }
        dvec3 c(0.0);
        for (int32_t v : verts) c += point(p, v);
        c /= static_cast<double>(verts.size());
        Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
        double reach = 0.0;
        for (int32_t v : verts) {
            const dvec3 d = point(p, v) - c;
            const Eigen::Vector3d e(d.x, d.y, d.z);
            cov += e * e.transpose();
            reach = std::max(reach, glm::length(d));
        }
        Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(cov);
        const Eigen::Vector3d e0 = eig.eigenvectors().col(0), e2 = eig.eigenvectors().col(2);
        dvec3 n(e0.x(), e0.y(), e0.z());
        const dvec3 principal(e2.x(), e2.y(), e2.z());

        double mean_edge = 0.0;
        for (int32_t t : rt) {
            const int32_t* tv = mesh.triangle(t);
            mean_edge += glm::length(point(p, tv[1]) - point(p, tv[0]));
        }
        mean_edge /= static_cast<double>(rt.size());
        if (!(fp.margin > 0.0)) fp.margin = 0.05 * mean_edge;
        if (!(fp.falloff_radius >= 0.0)) fp.falloff_radius = 0.0;

        const auto side_of = [&](int32_t v) -> int {
            if (by_parts) {
                const auto it = side_of_part.find(parts.part[v]);
                return it == side_of_part.end() ? 0 : it->second;
            }
            if (vertex_mark_[v] != region_stamp && vertex_mark_[v] != flood_stamp) return 0;
            return vertex_side_[v];
        };
        if (by_parts) {
            dvec3 ref[2] = {dvec3(0.0), dvec3(0.0)};
            double weight[2] = {0.0, 0.0};
            for (int32_t v : verts) {
                const int s = side_of(v);
                if (s == 0) continue;
                ref[s > 0] += part_reference[parts.part[v]];
                weight[s > 0] += 1.0;
            }
            if (weight[0] > 0 && weight[1] > 0) {
                const dvec3 ab = ref[1] / weight[1] - ref[0] / weight[0];
                const double lambda1 = eig.eigenvalues()(1), lambda2 = eig.eigenvalues()(2);
                if (!(lambda1 > 1e-3 * lambda2) && glm::length(ab) > 0.0) {
                    // The region is a thin strip: its plane holds the strip and the
                    // direction between the parts' bones.
                    const dvec3 q = ab - glm::dot(ab, principal) * principal;
                    if (glm::length(q) > 1e-12) n = glm::normalize(q);
                }
                if (glm::dot(n, ab) < 0.0) n = -n;
            }
        } else {
            // Skin folded onto itself within one part: its two layers face each other, so
            // their normals cluster around +m and -m; the plane between them has normal m
            // (the principal axis of the normals), and each vertex's side is where its
            // normal does not point.
            Eigen::Matrix3d nn = Eigen::Matrix3d::Zero();
            for (int32_t v : verts) {
                const dvec3 nv = vertex_normal(mesh, p, v);
                const double len = glm::length(nv);
                if (!(len > 0.0)) continue;
                const Eigen::Vector3d e(nv.x / len, nv.y / len, nv.z / len);
                nn += e * e.transpose();
            }
            Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> ne(nn);
            const Eigen::Vector3d m = ne.eigenvectors().col(2);
            n = dvec3(m.x(), m.y(), m.z());
            for (int32_t v : verts) vertex_side_[v] = glm::dot(vertex_normal(mesh, p, v), n) > 0.0 ? -1 : 1;
        }

        // 3. Penetrating vertices: flood from the region through same-side skin still on the
        // wrong side of the plane, within a sphere around the region.
        const double eps = fp.margin;
        double bound = std::max(1.5 * reach, 2.0 * mean_edge);
        double deepest = std::numeric_limits<double>::infinity();
        if (fp.limb_radius > 0.0) {
            bound = std::min(bound, std::max(4.0 * fp.limb_radius, 2.0 * mean_edge));
            deepest = fp.limb_radius;
        }
        const auto depth = [&](int32_t v, int s) {  // > 0: how far v is on the wrong side (plus the margin)
            const double d = glm::dot(point(p, v) - c, n);
            return s < 0 ? d + eps : eps - d;
        };
        // Only skin that faces the other sheet takes part: the sheets' outsides meet at the
        // plane, while skin running across it (the sides of the joint ring, where both links'
        // skin lies on the bisecting plane by construction) is no contact.
        const auto facing = [&](int32_t v, int s) {
            const dvec3 nv = vertex_normal(mesh, p, v);
            return -s * glm::dot(nv, n) > kFacing * glm::length(nv);
        };
        // The pull is a smooth function of the depth (pull_depth), so the skin next to the
        // contact, up to `soft` on the right side, bends onto the plane with it: pulling only the
        // penetrating vertices leaves a staircase along the contact's edge, where a vertex just
        // past the plane moves its full depth and its neighbour just short of it not at all.
        const double soft = fp.limb_radius > 0.0 ? std::max(1.5 * mean_edge, 0.1 * fp.limb_radius) : 1.5 * mean_edge;
        std::vector<int32_t> queue;
        for (int32_t v : verts) {
            const int s = side_of(v);
            if (s != 0 && depth(v, s) > 0.0 && depth(v, s) < deepest && glm::length(point(p, v) - c) < bound &&
                facing(v, s)) {
                queue.push_back(v);
                vertex_mark_[v] = flood_stamp;
            }
        }
        std::vector<int32_t> sources[2];
        std::vector<dvec3> deltas[2];
        for (size_t qi = 0; qi < queue.size(); ++qi) {
            const int32_t v = queue[qi];
            const int s = side_of(v);
            const double dp = depth(v, s);
            sources[s > 0].push_back(v);
            deltas[s > 0].push_back(static_cast<double>(s) * pull_depth(dp, soft) * n);
            stats.max_depth = std::max(stats.max_depth, dp - eps);
            for (uint32_t e = mesh.neighbour_offsets[v]; e < mesh.neighbour_offsets[v + 1]; ++e) {
                const int32_t w = mesh.neighbours[e];
                if (vertex_mark_[w] == flood_stamp) continue;
                int sw;
                if (by_parts) {
                    sw = side_of(w);
                } else {
                    if (vertex_mark_[w] != region_stamp)
                        vertex_side_[w] = glm::dot(vertex_normal(mesh, p, w), n) > 0.0 ? -1 : 1;
                    sw = vertex_side_[w];
                }
                if (sw != s || !(depth(w, sw) > -soft) || !(depth(w, sw) < deepest) ||
                    !(glm::length(point(p, w) - c) < bound) || !facing(w, sw))
                    continue;
                vertex_mark_[w] = flood_stamp;
                queue.push_back(w);
            }
        }

        // 4. Pull back, with the falloff into the same side's skin.
        for (int side = 0; side < 2; ++side) {
            if (sources[side].empty()) continue;
            stats.pulled += static_cast<int>(sources[side].size());
            if (by_parts) {
                std::fill(label_mask_.begin(), label_mask_.end(), 0);
                for (auto [label, s] : side_of_part)
                    if ((s > 0) == (side == 1) && label >= 0 && label < static_cast<int32_t>(label_mask_.size()))
                        label_mask_[label] = 1;
                stats.falloff += falloff.apply(mesh, sources[side], deltas[side], fp.falloff_radius, parts.part.data(),
                                               label_mask_.data(), p, edits, joint, moved);
            } else {
                stats.falloff +=
                    falloff.apply(mesh, sources[side], deltas[side], 0.0, nullptr, nullptr, p, edits, joint, moved);
            }
        }
    }
    for (int32_t t : tris) local_of_triangle_[t] = -1;
    return stats;
}

int SkinFolding::relax(const MeshTopology& mesh, const SkinParts& parts, const std::vector<TrianglePair>& pairs,
                       double radius, int passes, float* p, VertexEdits& edits,
                       const std::vector<int32_t>& triangle_joint, std::vector<int32_t>* moved) {
    const int V = mesh.vertex_count;
    if (static_cast<int>(vertex_mark_.size()) != V) {
        vertex_mark_.assign(V, -1);
        vertex_side_.assign(V, 0);
    }
    stamp_ += 2;
    const int in = stamp_;
    // The pairs' vertices, and the skin within `radius` of them (rest edge lengths).
    std::vector<int32_t> verts, owner;
    std::vector<float> dist;
    for (const TrianglePair& pr : pairs)
        for (int32_t t : {pr.a, pr.b})
            for (int k = 0; k < 3; ++k) {
                const int32_t v = mesh.triangle(t)[k];
                if (vertex_mark_[v] == in) continue;
                vertex_mark_[v] = in;
                verts.push_back(v);
                owner.push_back(triangle_joint[t]);
                dist.push_back(0.0f);
            }
    for (size_t i = 0; i < verts.size(); ++i)  // breadth-first, bounded by the path length
        for (uint32_t e = mesh.neighbour_offsets[verts[i]]; e < mesh.neighbour_offsets[verts[i] + 1]; ++e) {
            const int32_t w = mesh.neighbours[e];
            const float d = dist[i] + mesh.edge_lengths[e];
            if (vertex_mark_[w] == in || !(d < radius)) continue;
            vertex_mark_[w] = in;
            verts.push_back(w);
            owner.push_back(owner[i]);
            dist.push_back(d);
        }
    // Skin on no sweep (head, hands, feet) moves rigidly with its bones and does not
    // crumple: it stays.
    size_t kept = 0;
    for (size_t i = 0; i < verts.size(); ++i)
        if (parts.sweep[verts[i]] >= 0) {
            verts[kept] = verts[i];
            owner[kept++] = owner[i];
        }
    verts.resize(kept);
    owner.resize(kept);
    for (size_t i = 0; i < verts.size(); ++i) {
        edits.touch(verts[i], p, owner[i]);
        if (moved) moved->push_back(verts[i]);
    }
    // Uniform Laplacian steps of 0.5 (Jacobi). They shrink the patch a little, which is what
    // pulls a crumple flat; Taubin's alternating inflating steps keep the volume but leave
    // the crumple. The volume restoration gives the skin's volume back.
    std::vector<dvec3> next(verts.size());
    for (int pass = 0; pass < passes; ++pass) {
        const double step = 0.5;
        for (size_t i = 0; i < verts.size(); ++i) {
            const int32_t v = verts[i];
            dvec3 sum(0.0);
            const uint32_t b = mesh.neighbour_offsets[v], e = mesh.neighbour_offsets[v + 1];
            for (uint32_t j = b; j < e; ++j) sum += point(p, mesh.neighbours[j]);
            const dvec3 x = point(p, v);
            next[i] = e > b ? x + step * (sum / static_cast<double>(e - b) - x) : x;
        }
        for (size_t i = 0; i < verts.size(); ++i)
            for (int k = 0; k < 3; ++k) p[3 * static_cast<size_t>(verts[i]) + k] = static_cast<float>(next[i][k]);
    }
    return static_cast<int>(verts.size());
}

}  // namespace sd::anatomy
