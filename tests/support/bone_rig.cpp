#include "bone_rig.h"

#include <Eigen/Eigenvalues>

#include <algorithm>
#include <map>
#include <stdexcept>

namespace sd::testing {

std::vector<ChainSpec> makehuman_chains() {
    std::vector<ChainSpec> chains = {
        {"", {"pelvis", "spine_01", "spine_02", "spine_03"}, "neck_01"},
        {"spine_03", {"neck_01"}, "head"},
    };
    for (const char* side : {"_l", "_r"}) {
        const std::string s = side;
        chains.push_back({"spine_03", {"clavicle" + s, "upperarm" + s, "lowerarm" + s}, "hand" + s});
        chains.push_back({"pelvis", {"thigh" + s, "calf" + s}, "foot" + s});
    }
    return chains;
}

namespace {

dvec3 point(const std::vector<float>& a, int i) { return dvec3(a[3 * i], a[3 * i + 1], a[3 * i + 2]); }

/// Half-axes and major direction of the skin around a key: second moments, about the key's
/// center, of the chain's vertices in a thin slab around the key's plane. For points spread
/// evenly over an ellipse's boundary the moment along a half-axis is half its square.
void size_key(const io::Character& c, const std::vector<bool>& in_chain, double slab, double reach, KeyEllipse& key) {
    const dmat3 frame = glm::mat3_cast(key.orientation);
    Eigen::Matrix2d m = Eigen::Matrix2d::Zero();
    int n = 0;
    const int V = static_cast<int>(c.positions.size() / 3);
    for (int v = 0; v < V; ++v) {
        if (!in_chain[c.skin_joints[4 * v]]) continue;
        const dvec3 d = point(c.positions, v) - key.center;
        const dvec3 l = glm::transpose(frame) * d;
        if (std::abs(l.z) > slab || std::hypot(l.x, l.y) > reach) continue;
        m += Eigen::Vector2d(l.x, l.y) * Eigen::Vector2d(l.x, l.y).transpose();
        ++n;
    }
    if (n < 8) {
        key.a = key.b = 0.3 * reach;
        return;
    }
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> eig(m / n);
    const Eigen::Vector2d major = eig.eigenvectors().col(1);
    key.a = std::sqrt(2.0 * eig.eigenvalues()(1));
    key.b = std::max(std::sqrt(2.0 * std::max(eig.eigenvalues()(0), 0.0)), 0.3 * key.a);
    const dvec3 x = frame[0] * major.x() + frame[1] * major.y(), z = frame[2];
    key.orientation = glm::normalize(glm::quat_cast(dmat3(x, glm::cross(z, x), z)));
}

}  // namespace

BoneRig make_bone_rig(const io::Character& c, const std::vector<ChainSpec>& chains, int intermediate_keys) {
    std::map<std::string, int> index;
    for (size_t b = 0; b < c.bone_names.size(); ++b) index[c.bone_names[b]] = static_cast<int>(b);
    const auto bone = [&](const std::string& name) {
        if (name.empty()) return -1;
        const auto it = index.find(name);
        if (it == index.end()) throw std::runtime_error("bone_rig: no bone named " + name);
        return it->second;
    };
    const int B = static_cast<int>(c.bone_names.size());
    BoneRig out;
    out.rig.skeleton =
        Skeleton::from_arrays(B, c.bone_parents.data(), c.bone_rest.data(), c.bone_heads.data(), c.bone_tails.data());
    std::vector<int> chain_of_bone(B, -1);
    for (const ChainSpec& spec : chains) {
        std::vector<int> links;
        for (const auto& name : spec.links) links.push_back(bone(name));
        const int start = bone(spec.start_parent), end = bone(spec.end_child);
        std::vector<KeyEllipse> keys;
        for (size_t i = 0; i < links.size(); ++i) {
            const dvec3 head = point(c.bone_heads, links[i]), tail = point(c.bone_tails, links[i]);
            KeyEllipse joint;
            joint.center = head;
            joint.bone = links[i];
            joint.joint_parent = i == 0 ? start : links[i - 1];
            keys.push_back(joint);
            for (int j = 1; j <= intermediate_keys; ++j) {
                KeyEllipse mid;
                mid.center = glm::mix(head, tail, static_cast<double>(j) / (intermediate_keys + 1));
                mid.bone = links[i];
                keys.push_back(mid);
            }
        }
        KeyEllipse last;
        last.center = point(c.bone_tails, links.back());
        last.bone = end >= 0 ? end : links.back();
        last.joint_parent = end >= 0 ? links.back() : -1;
        last.twist_fraction = 1.0;  // the wrist and ankle turn with the hand and foot
        keys.push_back(last);

        double length = 0.0;
        for (size_t k = 1; k < keys.size(); ++k) length += glm::length(keys[k].center - keys[k - 1].center);
        std::vector<bool> in_chain(B, false);
        for (int l : links) {
            in_chain[l] = true;
            chain_of_bone[l] = static_cast<int>(out.rig.sweeps.size());
        }
        for (size_t k = 0; k < keys.size(); ++k) {
            const dvec3 prev = keys[k > 0 ? k - 1 : k].center, next = keys[k + 1 < keys.size() ? k + 1 : k].center;
            const dvec3 n = glm::normalize(next - prev);
            const dvec3 ref = std::abs(n.x) < 0.9 ? dvec3(1, 0, 0) : dvec3(0, 1, 0);
            const dvec3 x = glm::normalize(ref - glm::dot(ref, n) * n);
            keys[k].orientation = glm::quat_cast(dmat3(x, glm::cross(n, x), n));
            const double gap = glm::length(next - prev) / (k == 0 || k + 1 == keys.size() ? 1.0 : 2.0);
            size_key(c, in_chain, 0.3 * gap, 0.5 * length, keys[k]);
        }
        out.rig.add_sweep(keys);
    }

    // Sweep weights from the skin weights: a vertex's weight on a chain is the sum of its
    // weights on the chain's links; the rest stays on the bones (hands, feet, head, root).
    const int V = static_cast<int>(c.positions.size() / 3);
    out.sweep_ids.assign(2 * V, -1);
    out.sweep_weights.assign(2 * V, 0.0f);
    out.bone_ids.assign(4 * V, -1);
    out.bone_weights.assign(4 * V, 0.0f);
    for (int v = 0; v < V; ++v) {
        std::map<int, float> per_chain;
        int bone_slot = 0;
        for (int i = 0; i < 4; ++i) {
            const int j = c.skin_joints[4 * v + i];
            const float w = c.skin_weights[4 * v + i];
            if (w <= 0.0f) continue;
            if (chain_of_bone[j] >= 0) {
                per_chain[chain_of_bone[j]] += w;
            } else {
                out.bone_ids[4 * v + bone_slot] = j;
                out.bone_weights[4 * v + bone_slot++] = w;
            }
        }
        std::vector<std::pair<float, int>> ranked;
        for (auto [chain, w] : per_chain) ranked.push_back({w, chain});
        std::sort(ranked.rbegin(), ranked.rend());
        for (size_t i = 0; i < ranked.size() && i < 2; ++i) {
            out.sweep_ids[2 * v + i] = ranked[i].second;
            out.sweep_weights[2 * v + i] = ranked[i].first;
        }
    }
    return out;
}

Binding BoneRig::bind(const io::Character& c) const {
    const int V = static_cast<int>(c.positions.size() / 3);
    return bind_vertices(rig, V, c.positions.data(), 2, sweep_ids.data(), sweep_weights.data(), 4, bone_ids.data(),
                         bone_weights.data());
}

}  // namespace sd::testing
