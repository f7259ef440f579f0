#include "rig/key_motion.h"

#include "math/smoothstep.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace sd {

namespace {

/// Where a link runs at rest: from its head to the next joint key's joint (or its tail).
struct Link {
    dvec3 start{0.0}, end{0.0};
    double fraction_of(const dvec3& p) const {
        const dvec3 d = end - start;
        const double len2 = glm::dot(d, d);
        return len2 > 0.0 ? std::clamp(glm::dot(p - start, d) / len2, 0.0, 1.0) : 0.5;
    }
};

/// Thick chains: each key's blend of the chain's bones, each bone weighted by the share of a
/// tent of half-width `h` centred on the key that lies along it (the tent clipped at the
/// chain's start, so the first keys stay with the first bone, as the pelvis holds the hips;
/// the last bone reaches on beyond the chain). A tent, not a box: a bone's weight then has a
/// continuous slope along the chain. With a box the slope jumped wherever the window's edge
/// crossed a joint, and each jump was a band across a bent torso's flank.
void blend_thick_chain(const std::vector<KeyEllipse>& keys, const Skeleton& skeleton, const std::vector<char>& blended,
                       double h, std::vector<KeyMotion>& motions) {
    const int K = static_cast<int>(keys.size());
    std::vector<int> bones;  // the chain's links in order
    for (int k = 0; k < K; ++k)
        if (blended[k] && (bones.empty() || bones.back() != keys[k].bone)) bones.push_back(keys[k].bone);
    const dvec3 origin = keys.front().center;
    dvec3 axis = keys.back().center - origin;
    axis = glm::length(axis) > 0.0 ? glm::normalize(axis) : dvec3(0, 0, 1);
    const auto along = [&](const dvec3& p) { return glm::dot(p - origin, axis); };
    const int n = static_cast<int>(bones.size());
    std::vector<double> from(n), to(n);
    for (int i = 0; i < n; ++i) from[i] = along(skeleton.heads[bones[i]]);
    for (int i = 0; i + 1 < n; ++i) to[i] = from[i + 1];
    to[n - 1] = std::numeric_limits<double>::infinity();
    from[0] = std::min(from[0], 0.0);
    for (int k = 0; k < K; ++k) {
        if (!blended[k]) continue;
        const double s = along(keys[k].center);
        const double r = std::max(0.0, std::min(h, s - from[0]));
        KeyMotion& m = motions[k];
        m.blend.clear();
        double total = 0.0;
        const auto under_tent = [&](double x) {  // the tent's area from s - r to x
            const double u = std::clamp(x - s, -r, r);
            return u <= 0.0 ? (u + r) * (u + r) / (2.0 * r) : 0.5 * r + u - u * u / (2.0 * r);
        };
        for (int i = 0; i < n; ++i) {
            const double lo = std::max(s - r, from[i]), hi = std::min(s + r, to[i]);
            const double w = r > 0.0 && hi > lo ? under_tent(hi) - under_tent(lo) : 0.0;
            if (w > 0.0) {
                m.blend.push_back({bones[i], w});
                total += w;
            }
        }
        if (!(total > 0.0)) {  // a window of zero width: the bone the key sits on
            m.blend.assign(1, {keys[k].bone, 1.0});
            total = 1.0;
        }
        for (auto& bw : m.blend) bw.second /= total;
        if (m.blend.size() == 1 && m.blend[0].first == keys[k].bone) m.blend.clear();  // rigid
    }
}

}  // namespace

std::vector<KeyMotion> key_motions(const std::vector<KeyEllipse>& keys, const Skeleton& skeleton) {
    const int K = static_cast<int>(keys.size());
    std::vector<KeyMotion> motions(K);
    // Per intermediate key: its joint keys before and after along its own link, and its link.
    std::vector<int> before(K, -1), after(K, -1);
    std::vector<Link> links(K);
    std::vector<double> ratios, radii;
    std::vector<int> intermediate_bones;
    for (int k = 0; k < K; ++k) {
        const KeyEllipse& e = keys[k];
        if (e.is_joint_key()) continue;
        intermediate_bones.push_back(e.bone);
        for (int j = k - 1; j >= 0 && before[k] < 0; --j)
            if (keys[j].is_joint_key() && keys[j].bone == e.bone) before[k] = j;
        for (int j = k + 1; j < K && after[k] < 0; ++j)
            if (keys[j].is_joint_key() && keys[j].joint_parent == e.bone) after[k] = j;
        links[k].start = skeleton.heads[e.bone];
        links[k].end = after[k] >= 0 ? skeleton.heads[keys[after[k]].bone] : skeleton.tails[e.bone];
        const double len = glm::length(links[k].end - links[k].start);
        radii.push_back(std::max(e.a, e.b));
        if (len > 0.0) ratios.push_back(std::max(e.a, e.b) / len);
    }
    const auto median = [](std::vector<double> v) {
        std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
        return v[v.size() / 2];
    };
    const bool thick = !ratios.empty() && median(ratios) >= kThickChainRatio;
    const auto on_chain = [&](int bone) {
        return std::find(intermediate_bones.begin(), intermediate_bones.end(), bone) != intermediate_bones.end();
    };
    std::vector<char> blended(K, 0);
    for (int k = 0; k < K; ++k) {
        const KeyEllipse& e = keys[k];
        KeyMotion& m = motions[k];
        m.from_bone = m.to_bone = e.bone;
        // A thick chain's own keys (not a joint with another chain: the neck's start) blend.
        if (thick && (!e.is_joint_key() || (on_chain(e.bone) && on_chain(e.joint_parent)))) {
            blended[k] = 1;
        } else if (e.is_joint_key()) {
            m.from_bone = e.joint_parent;
            m.swing_share = e.swing_fraction;
            m.twist_share = e.twist_fraction;
            m.axis = e.twist_axis();
            m.turns_about_pivot = true;
            m.pivot = skeleton.heads[e.bone];
        } else if (after[k] >= 0 && after[k] == K - 1) {
            // The last link: its share of the end key's twist, none of its swing. The twist is
            // taken about the link itself and the key turns about it, not about its own center:
            // a forearm turns about its bones, and a section centered a centimetre off them
            // would otherwise swing round the bone and ripple the outline. The share grows as
            // the square of the key's place along the link, as a forearm turns: the radius
            // rolls round the ulna at the wrist while the muscle bellies at the elbow hardly
            // move. In proportion to the place, the elbow end's bulk turned a third of the
            // wrist's turn and the twisted forearm was lumpy from behind; MakeHuman's skin
            // there 1.028x its rest distance from the bone at 180 degrees, now 1.011
            // (Preserve Volume 1.029). On a mesh with few rings along the link the end key's
            // twist_spread lowers the power towards 1 (fit/twist_spread.h): there the square
            // put most of the turn into the last ring or two before the wrist.
            const KeyEllipse& j = keys[after[k]];
            const Link& link = links[k];
            const double along = link.fraction_of(e.center);
            m.twist_share = std::pow(along, j.twist_spread) * j.twist_fraction;
            if (m.twist_share > 0.0) {  // else rigid with its own bone
                m.to_bone = j.bone;
                const dvec3 d = link.end - link.start;
                if (glm::length(d) > 0.0) {
                    m.axis = glm::normalize(d);
                    m.turns_about_pivot = true;
                    m.pivot = link.start + glm::dot(e.center - link.start, m.axis) * m.axis;
                } else {
                    m.axis = j.normal();
                }
            }
        }
    }
    if (thick) blend_thick_chain(keys, skeleton, blended, kThickChainTent * median(radii), motions);
    // A limb whose last link twists: every key of it turns about its link or joint
    // (twisted_trajectory.h). A rigid key's pivot is its center's foot on its link.
    bool twists = false;
    for (int k = 0; k < K; ++k) twists = twists || (!keys[k].is_joint_key() && motions[k].turns_about_pivot);
    for (int k = 0; twists && k < K; ++k) {
        KeyMotion& m = motions[k];
        if (!m.blend.empty()) continue;
        if (m.turns_about_pivot) {
            m.twist_axis = m.axis;
            continue;
        }
        const dvec3 d = links[k].end - links[k].start;
        if (keys[k].is_joint_key() || !(glm::dot(d, d) > 0.0)) continue;
        m.twist_axis = glm::normalize(d);
        m.pivot = links[k].start + glm::dot(keys[k].center - links[k].start, m.twist_axis) * m.twist_axis;
    }
    return motions;
}

double shoulder_swing_share(const KeyMotion& m, const dquat& swing) {
    if (m.lowering == dvec3(0.0)) return m.swing_share;
    const double lowered = glm::dot(swing * m.axis - m.axis, m.lowering);
    const double towards = lowered >= 0.0 ? m.lowering_share : m.raising_share;
    return m.swing_share + (towards - m.swing_share) * smoothstep01(std::abs(lowered) / kFullLowering);
}

}  // namespace sd
