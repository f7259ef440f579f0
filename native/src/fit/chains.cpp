#include "fit/chains.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <limits>

namespace sd::fit {

const char* chain_kind_name(ChainKind kind) {
    switch (kind) {
        case ChainKind::Torso:
            return "torso";
        case ChainKind::Neck:
            return "neck";
        case ChainKind::Arm:
            return "arm";
        case ChainKind::Leg:
            return "leg";
        case ChainKind::Custom:
            break;
    }
    return "custom";
}

namespace {

/// The bones in an order where each comes after its parent (the skeleton does not promise
/// parents-first indices).
std::vector<int> parents_first(const Skeleton& s) {
    const int B = s.bone_count();
    std::vector<std::vector<int>> children(B);
    std::vector<int> order;
    for (int b = 0; b < B; ++b)
        if (s.parents[b] >= 0)
            children[s.parents[b]].push_back(b);
        else
            order.push_back(b);
    for (size_t i = 0; i < order.size(); ++i)
        for (int c : children[order[i]]) order.push_back(c);
    return order;
}

/// Per-bone facts of the rest skeleton used by the rules below.
struct Tree {
    const Skeleton& s;
    int count;
    std::vector<std::vector<int>> children;
    std::vector<double> length;  ///< |tail - head|
    /// Longest geometric path from the bone's head through its subtree (to a tail).
    std::vector<double> reach;
    std::vector<double> mass;      ///< summed skin weight of the subtree (empty: unknown)
    std::vector<double> own_mass;  ///< skin weight of the bone itself (empty: unknown)
    std::vector<int> order;        ///< every bone after its parent
    double size = 1.0;             ///< diagonal of the heads' and tails' bounding box

    Tree(const Skeleton& skeleton, const std::vector<double>& bone_mass) : s(skeleton), count(skeleton.bone_count()) {
        children.resize(count);
        length.resize(count);
        reach.resize(count);
        for (int b = 0; b < count; ++b) {
            if (s.parents[b] >= 0) children[s.parents[b]].push_back(b);
            length[b] = glm::length(s.tails[b] - s.heads[b]);
        }
        size = std::max(s.extent(), 1e-300);
        order = parents_first(skeleton);
        if (!bone_mass.empty()) mass = own_mass = bone_mass;
        for (auto it = order.rbegin(); it != order.rend(); ++it) {  // children are done first
            const int b = *it;
            reach[b] = length[b];
            for (int c : children[b]) {
                reach[b] = std::max(reach[b], glm::length(s.heads[c] - s.heads[b]) + reach[c]);
                if (!mass.empty()) mass[b] += mass[c];
            }
        }
    }
    bool deforms(int b) const { return mass.empty() || mass[b] > 0.0; }
    /// A branch long enough to be a limb or the spine (fingers, toes, face bones are not).
    bool long_branch(int b) const { return deforms(b) && reach[b] >= 0.15 * size; }
    /// Not a tiny helper bone.
    bool real(int b) const { return deforms(b) && reach[b] >= 0.02 * size; }
    std::vector<int> long_children(int b) const {
        std::vector<int> out;
        for (int c : children[b])
            if (long_branch(c)) out.push_back(c);
        return out;
    }
    /// Bones of b's subtree that are long branches without long children.
    int extremities(int b) const {
        const std::vector<int> lc = long_children(b);
        if (lc.empty()) return long_branch(b) ? 1 : 0;
        int n = 0;
        for (int c : lc) n += extremities(c);
        return n;
    }
    /// Where bone b points, joint to joint: to the head of its one child (a foot to its toe)
    /// when it has one away from it, else to its tail. glTF stores joints, not bones, and its
    /// importers point every tail one way (CesiumMan's along the body's side).
    dvec3 pointing(int b) const {
        if (children[b].size() == 1) {
            const dvec3 d = s.heads[children[b][0]] - s.heads[b];
            if (glm::length(d) > 1e-3 * size) return d;
        }
        return s.tails[b] - s.heads[b];
    }
    /// The point of b's subtree farthest from `from`.
    dvec3 farthest(int b, const dvec3& from) const {
        dvec3 best = s.heads[b];
        double d = glm::length(best - from);
        const auto visit = [&](auto&& self, int x) -> void {
            for (const dvec3& p : {s.heads[x], s.tails[x]})
                if (glm::length(p - from) > d) {
                    d = glm::length(p - from);
                    best = p;
                }
            for (int c : children[x]) self(self, c);
        };
        visit(visit, b);
        return best;
    }
    /// Following the child whose subtree reaches farthest from b's head, down to a leaf or to
    /// a bone with three or more real children (a hand with fingers, a foot with toes), which
    /// ends the path. Farthest, not longest: a twist bone hung beside a limb's link (Unreal's
    /// calf_twist_01_l, half a shin long) can be longer than the foot and its toe together,
    /// but the foot reaches past it.
    std::vector<int> main_path(int b, int* fan_out) const {
        std::vector<int> path{b};
        *fan_out = -1;
        // How far each subtree reaches from b's head (one pass, children before parents).
        const dvec3 origin = s.heads[b];
        std::vector<double> far_of(count, 0.0);
        for (auto it = order.rbegin(); it != order.rend(); ++it) {
            const int x = *it;
            double f = std::max(glm::length(s.heads[x] - origin), glm::length(s.tails[x] - origin));
            for (int c : children[x]) f = std::max(f, far_of[c]);
            far_of[x] = f;
        }
        for (int cur = b;;) {
            int real_children = 0, best = -1;
            double best_far = -1.0;
            for (int c : children[cur]) {
                if (!deforms(c)) continue;
                if (reach[c] > 0.0) ++real_children;
                const double far = far_of[c];
                if (best < 0 || far > best_far + 1e-9 * size ||
                    (far > best_far - 1e-9 * size && reach[c] > reach[best])) {
                    best = c;
                    best_far = far;
                }
            }
            if (real_children >= 3 && path.size() > 1) {
                path.pop_back();
                *fan_out = cur;
                return path;
            }
            if (best < 0) return path;
            path.push_back(best);
            cur = best;
        }
    }
    bool is_descendant(int b, int ancestor) const {
        for (int x = b; x >= 0; x = s.parents[x])
            if (x == ancestor) return true;
        return false;
    }
};

/// Whether `bone`, the parent of the torso's first link `first` (the hips, or a bone taken
/// before them), is a skinned bone at the hips: it carries at least 1 % of the body's skin
/// weight itself and its head lies within 0.1 of the skeleton's size of `first`'s head (a Root
/// bone at the floor does not), but not on it (a link from the one head to the other would
/// have no length).
bool pelvis_above_hips(const Tree& t, int bone, int first) {
    if (t.own_mass.empty()) return false;
    double total = 0.0;
    for (double m : t.own_mass) total += m;
    const double apart = glm::length(t.s.heads[bone] - t.s.heads[first]);
    return t.own_mass[bone] >= 0.01 * total && apart <= 0.1 * t.size && apart >= 0.01 * t.size;
}

/// Whether the spine bone the arms hang from, spine[chest], is the neck (3ds Max Biped hangs
/// its clavicles from Bip01 Neck): only the head follows it on the spine, every arm starts
/// within its first tenth (joint to joint), and it carries less than half the skin weight of
/// the spine bones below it on average (a neck, not a chest). A chest whose arms start at its
/// head is followed by a neck (CesiumMan), or carries the chest's skin.
bool arms_hang_from_the_neck(const Tree& t, const std::vector<int>& spine, int chest,
                             const std::vector<std::pair<int, int>>& arms) {
    if (t.own_mass.empty() || chest < 2 || chest + 2 != static_cast<int>(spine.size())) return false;
    const int neck = spine[chest];
    const dvec3 d = t.s.heads[spine[chest + 1]] - t.s.heads[neck];
    for (const auto& [root, from] : arms)
        if (from != neck || glm::dot(t.s.heads[root] - t.s.heads[neck], d) > 0.1 * glm::dot(d, d)) return false;
    double below = 0.0;
    for (int i = 1; i < chest; ++i) below += t.own_mass[spine[i]];
    return t.own_mass[neck] < 0.5 * below / (chest - 1);
}

std::string lower(std::string s) {
    for (char& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    return s;
}

/// +1 when a bone name says left, -1 right, 0 neither (Blender .L/_l, Mixamo Left..., l_...).
int name_side(const std::string& name) {
    const std::string n = lower(name);
    const auto has = [&](const char* s) { return n.find(s) != std::string::npos; };
    const auto ends = [&](const char* s) {
        const std::string e(s);
        return n.size() >= e.size() && n.compare(n.size() - e.size(), e.size(), e) == 0;
    };
    const auto starts = [&](const char* s) { return n.rfind(s, 0) == 0; };
    if (has("left") || ends("_l") || ends(".l") || ends("-l") || has("_l_") || has(".l.") || starts("l_") ||
        starts("l.") || has("_l.") || has("_l0"))
        return 1;
    if (has("right") || ends("_r") || ends(".r") || ends("-r") || has("_r_") || has(".r.") || starts("r_") ||
        starts("r.") || has("_r.") || has("_r0"))
        return -1;
    return 0;
}

std::string bone_label(const std::vector<std::string>& names, int b) {
    return "bone " + std::to_string(b) +
           (b < static_cast<int>(names.size()) && !names[b].empty() ? " '" + names[b] + "'" : std::string());
}

/// Lengths summed along `path`: element i is the length of path[0 .. i), for i in [0, count].
std::vector<double> summed_lengths(const Tree& t, const std::vector<int>& path, int count) {
    std::vector<double> sums(count + 1, 0.0);
    for (int i = 0; i < count; ++i) sums[i + 1] = sums[i] + t.length[path[i]];
    return sums;
}

/// The limb's path cut into segments: runs of bones that continue one another (each next one
/// starting where the last ends and pointing the same way within kContinues). Rigify's
/// DEF-upper_arm.L / .001, DAZ's bend and twist bones and MakeHuman's default lowerarm01 / 02
/// cut one anatomical segment into two or more bones; without this the longest pair of bones
/// was the clavicle and the upper arm's first half, and the forearm was left to the bones.
/// No segment grows past kLongestSegment of the path, so an arm straight at the elbow (a
/// T-pose) keeps its elbow: the shortest merges go first, and the halves of a segment are
/// shorter than an arm straight through. Only runs of similar length merge (within
/// kMostUnequal): a cut makes pieces of a segment alike, while a short clavicle in line with a
/// T-posed arm is not the arm's first piece. Without a fan-out (a hand without fingers, a foot
/// with one toe) the path's last bone is that extremity, never part of a segment: CesiumMan's
/// hand continues its forearm straight.
/// Returns each segment's first index into `path[0, count)` (each ends where the next begins).
std::vector<int> limb_segments(const Tree& t, const std::vector<int>& path, int count, bool last_is_extremity) {
    const double kContinues = std::cos(2.0 * 3.14159265358979323846 / 180.0);
    constexpr double kLongestSegment = 0.6, kMostUnequal = 2.5;
    // A limb is a handful of bones; a longer path (a tentacle, a malformed rig) is left uncut,
    // which also bounds the merging below (quadratic in the path's length).
    constexpr int kMostBones = 64;
    std::vector<int> starts(count);
    for (int i = 0; i < count; ++i) starts[i] = i;
    if (count > kMostBones) return starts;
    const std::vector<double> sums = summed_lengths(t, path, count);
    const auto length = [&](int from, int to) { return sums[to] - sums[from]; };
    const double total = length(0, count);
    const auto continues = [&](int i) {  // bone path[i] continues path[i - 1]
        if (last_is_extremity && i == count - 1) return false;
        const int a = path[i - 1], b = path[i];
        const dvec3 to_b = t.s.heads[b] - t.s.heads[a], along_b = t.pointing(b);
        const double la = glm::length(to_b), lb = glm::length(along_b);
        return la > 0.0 && lb > 0.0 && glm::length(t.s.tails[a] - t.s.heads[b]) <= 1e-3 * t.size &&
               glm::dot(to_b, along_b) >= kContinues * la * lb;
    };
    for (;;) {
        int best = -1;
        double best_len = 0.0;
        for (size_t k = 1; k < starts.size(); ++k) {
            if (!continues(starts[k])) continue;
            const int end = k + 1 < starts.size() ? starts[k + 1] : count;
            const double before = length(starts[k - 1], starts[k]), after = length(starts[k], end);
            const double merged = before + after;
            if (std::max(before, after) > kMostUnequal * std::min(before, after)) continue;
            if (merged <= kLongestSegment * total && (best < 0 || merged < best_len)) {
                best = static_cast<int>(k);
                best_len = merged;
            }
        }
        if (best < 0) return starts;
        starts.erase(starts.begin() + best);
    }
}

/// Splits a limb's main path into links and end bone: the upper and lower link are the two
/// consecutive segments (limb_segments) of largest summed length.
void split_limb(const Tree& t, int root, Chain* chain) {
    int fan_out = -1;
    std::vector<int> path = t.main_path(root, &fan_out);
    if (fan_out >= 0) path.push_back(fan_out);
    // The pair search stops before the fan-out bone (the hand itself is never a link).
    const int searchable = static_cast<int>(path.size()) - (fan_out >= 0 ? 1 : 0);
    const std::vector<int> starts = limb_segments(t, path, searchable, fan_out < 0);
    const int n = static_cast<int>(starts.size());
    const auto segment_end = [&](int k) { return k + 1 < n ? starts[k + 1] : searchable; };
    const std::vector<double> sums = summed_lengths(t, path, searchable);
    const auto segment_length = [&](int k) { return sums[segment_end(k)] - sums[starts[k]]; };
    int best = 0;
    double best_len = -1.0;
    for (int k = 0; k + 1 < n; ++k) {
        const double len = segment_length(k) + segment_length(k + 1);
        if (len > best_len + 1e-9 * t.size) {
            best_len = len;
            best = k;
        }
    }
    const int last = (n >= 2 ? segment_end(best + 1) : segment_end(0)) - 1;
    chain->bones.assign(path.begin(), path.begin() + last + 1);
    chain->first_swept = starts[best];
    chain->end_bone = last + 1 < static_cast<int>(path.size()) ? path[last + 1] : -1;
    chain->continues.assign(chain->bones.size(), 0);
    bool any = false;
    for (int i = chain->first_swept + 1; i <= last; ++i)
        if (std::find(starts.begin(), starts.end(), i) == starts.end()) chain->continues[i] = 1, any = true;
    if (!any) chain->continues.clear();
}

}  // namespace

std::vector<int> Chain::links() const {
    std::vector<int> out;
    for (size_t i = static_cast<size_t>(std::max(first_swept, 0)); i < bones.size(); ++i)
        if (out.empty() || i >= continues.size() || !continues[i]) out.push_back(bones[i]);
    return out;
}

std::vector<dvec3> Chain::joints(const Skeleton& s) const {
    std::vector<dvec3> out;
    for (int b : links()) out.push_back(s.heads[b]);
    out.push_back(end_bone >= 0 ? s.heads[end_bone] : s.tails[bones.back()]);
    return out;
}

ChainSet find_chains(const Skeleton& s, const std::vector<std::string>& names, const std::vector<double>& bone_mass) {
    const Tree t(s, bone_mass);
    ChainSet out;
    out.size = t.size;
    const auto label = [&](int b) { return bone_label(names, b); };

    // The root with the longest reach (a rig may carry extra roots: IK targets, props).
    int root = -1;
    for (int b = 0; b < t.count; ++b)
        if (s.parents[b] < 0 && t.deforms(b) && (root < 0 || t.reach[b] > t.reach[root])) root = b;
    if (root < 0) throw InvalidInput("automatic chains: the skeleton has no root bone with skin weights");

    // Hips: the first bone from the root where two or more long branches split.
    int hips = root;
    for (;;) {
        const std::vector<int> lc = t.long_children(hips);
        if (lc.size() >= 2) break;
        if (lc.empty())
            throw InvalidInput("automatic chains: no branching found below " + label(root) +
                               " (a humanoid splits into spine and legs); give the chains explicitly");
        hips = lc[0];
    }
    std::vector<int> branches = t.long_children(hips);
    int spine_child = branches[0];
    for (int c : branches)
        if (t.extremities(c) > t.extremities(spine_child) ||
            (t.extremities(c) == t.extremities(spine_child) && t.reach[c] < t.reach[spine_child]))
            spine_child = c;
    // Legs: the other long branches (descending where a branch splits again, as in rigs
    // whose legs hang from a pelvis bone beside the spine).
    std::vector<int> legs;
    const auto collect_legs = [&](auto&& self, int b) -> void {
        const std::vector<int> lc = t.long_children(b);
        if (t.extremities(b) <= 1 || lc.empty()) {
            legs.push_back(b);
            return;
        }
        if (lc.size() == 1) return self(self, lc[0]);
        for (int c : lc) self(self, c);
    };
    for (int c : branches)
        if (c != spine_child) collect_legs(collect_legs, c);
    if (legs.size() > 2) {
        std::sort(legs.begin(), legs.end(), [&](int a, int b) { return t.reach[a] > t.reach[b]; });
        out.notes.push_back("more than two leg-like branches at " + label(hips) + "; kept the two longest");
        legs.resize(2);
    }
    if (legs.size() != 2)
        throw InvalidInput("automatic chains: expected two legs branching at the hips " + label(hips) + ", found " +
                           std::to_string(legs.size()) + "; give the chains explicitly");

    const dvec3 hip = s.heads[hips];
    const auto leg_center = [&](int b) {
        int fan = -1;
        dvec3 c(0.0);
        const std::vector<int> path = t.main_path(b, &fan);
        for (int x : path) c += 0.5 * (s.heads[x] + s.tails[x]);
        return c / static_cast<double>(path.size());
    };
    dvec3 lateral = leg_center(legs[0]) - leg_center(legs[1]);
    if (!(glm::length(lateral) > 1e-6 * t.size))
        throw InvalidInput("automatic chains: the two legs " + label(legs[0]) + " and " + label(legs[1]) +
                           " coincide; give the chains explicitly");
    lateral = glm::normalize(lateral);

    // The spine, from the hips to the head: at each bone continue into the child whose far
    // end lies nearest the mid-plane; long side branches are arms.
    std::vector<int> spine{hips};
    std::vector<std::pair<int, int>> arms;  // (arm root, spine bone it hangs from)
    for (int cur = spine_child;;) {
        spine.push_back(cur);
        int next = -1;
        double next_ratio = 2.0;
        std::vector<std::pair<int, double>> candidates;
        for (int c : t.children[cur]) {
            // Any deforming child may continue the spine (a short head bone too); only
            // long ones can be arms.
            if (!(t.mass.empty() ? t.reach[c] >= 0.005 * t.size : t.mass[c] > 0.0)) continue;
            const dvec3 e = t.farthest(c, hip) - hip;
            const double ratio = std::abs(glm::dot(e, lateral)) / std::max(glm::length(e), 1e-300);
            candidates.push_back({c, ratio});
            if (ratio < next_ratio) {
                next_ratio = ratio;
                next = c;
            }
        }
        if (next < 0) break;
        for (const auto& [c, ratio] : candidates)
            if (c != next && t.long_branch(c) && ratio > 0.25) arms.push_back({c, cur});
        cur = next;
    }
    if (arms.size() > 2) {
        std::sort(arms.begin(), arms.end(), [&](auto& a, auto& b) { return t.reach[a.first] > t.reach[b.first]; });
        out.notes.push_back("more than two arm-like branches on the spine; kept the two longest");
        arms.resize(2);
    }
    if (arms.size() == 1) out.notes.push_back("found only one arm (" + label(arms[0].first) + ")");
    if (arms.empty()) out.notes.push_back("found no arms on the spine");

    // Chest: the deepest spine bone an arm hangs from. The torso ends there.
    int chest_index = static_cast<int>(spine.size()) - 1;
    if (!arms.empty()) {
        chest_index = 0;
        for (const auto& a : arms)
            chest_index = std::max(chest_index,
                                   static_cast<int>(std::find(spine.begin(), spine.end(), a.second) - spine.begin()));
        if (arms_hang_from_the_neck(t, spine, chest_index, arms)) {
            --chest_index;
            out.notes.push_back("the arms hang from the neck " + label(spine[chest_index + 1]) +
                                " (as in 3ds Max Biped): the torso ends below it");
        }
    } else {
        chest_index = std::max(0, static_cast<int>(spine.size()) - 3);
    }
    const std::vector<int> rest(spine.begin() + chest_index + 1, spine.end());
    int head = -1;
    std::vector<int> neck;
    if (rest.size() == 1) {
        head = rest[0];
    } else if (rest.size() >= 2) {
        int h = 1;
        if (!t.mass.empty()) {
            for (int i = 1; i < static_cast<int>(rest.size()); ++i)
                if (bone_mass[rest[i]] > bone_mass[rest[h]]) h = i;
        } else {
            for (int i = 1; i < static_cast<int>(rest.size()); ++i)
                if (rest[i] < static_cast<int>(names.size()) &&
                    lower(names[rest[i]]).find("head") != std::string::npos) {
                    h = i;
                    break;
                }
        }
        head = rest[h];
        neck.assign(rest.begin(), rest.begin() + h);
    }

    // Body frame: up from the hips to the head, left from the legs, forward from the feet.
    const dvec3 top = head >= 0 ? s.heads[head] : s.tails[spine.back()];
    dvec3 up = top - hip;
    up -= glm::dot(up, lateral) * lateral;
    if (!(glm::length(up) > 1e-3 * t.size))
        throw InvalidInput("automatic chains: the spine from " + label(hips) + " does not rise above the hips");
    up = glm::normalize(up);
    BodyFrame& frame = out.frame;
    frame.up = up;
    Chain leg_chain[2];
    dvec3 feet(0.0);
    double foot_length = 0.0;
    for (int i = 0; i < 2; ++i) {
        leg_chain[i].kind = ChainKind::Leg;
        split_limb(t, legs[i], &leg_chain[i]);
        if (leg_chain[i].end_bone >= 0) {
            const int f = leg_chain[i].end_bone;
            feet += t.pointing(f);
            foot_length += t.length[f];
        }
    }
    feet -= glm::dot(feet, up) * up;
    int leg0_side = 0;  // +1: legs[0] is the left leg
    if (foot_length > 0.0 && glm::length(feet) > 0.2 * foot_length) {
        frame.forward = glm::normalize(feet);
        frame.left = glm::normalize(glm::cross(up, frame.forward));
        frame.sides_known = true;
        leg0_side = glm::dot(lateral, frame.left) > 0.0 ? 1 : -1;
        out.notes.push_back("forward direction from the feet");
    } else {
        int vote = 0;
        for (int i = 0; i < 2; ++i)
            for (int b : leg_chain[i].bones)
                if (b < static_cast<int>(names.size())) vote += (i == 0 ? 1 : -1) * name_side(names[b]);
        frame.left = vote < 0 ? -lateral : lateral;
        frame.forward = glm::normalize(glm::cross(frame.left, up));
        frame.sides_known = vote != 0;
        leg0_side = vote < 0 ? -1 : 1;
        out.notes.push_back(vote != 0 ? "no feet found: sides from the bone names"
                                      : "no feet and no side names: left and right are a guess");
    }
    frame.left = glm::normalize(frame.left - glm::dot(frame.left, up) * up);

    const auto side_name = [&](int side) {
        return !frame.sides_known ? (side > 0 ? "_a" : "_b") : (side > 0 ? "_l" : "_r");
    };
    const auto mirrored_check = [&](const Chain& c) {
        // Names contradicting the geometry are worth a note (mirrored rig, odd naming).
        int vote = 0;
        for (int b : c.bones)
            if (b < static_cast<int>(names.size())) vote += name_side(names[b]);
        if (frame.sides_known && vote != 0 && (vote > 0) != (c.side > 0))
            out.notes.push_back("chain " + c.name + ": bone names say the other side");
    };

    // Torso: hips .. chest; its end key sits at the neck base.
    Chain torso;
    torso.kind = ChainKind::Torso;
    torso.name = "torso";
    torso.bones.assign(spine.begin(), spine.begin() + chest_index + 1);
    // Skinned bones above the hips at the hips (3ds Max Biped's Bip01 Pelvis above Bip01 Spine,
    // from which its thighs hang) are the torso's first links: left out, the skin they carry
    // (the pelvis, the belly) stayed with a bone the torso does not bend, and a cut ran across
    // the waist.
    for (int p = s.parents[hips]; p >= 0 && pelvis_above_hips(t, p, torso.bones.front()); p = s.parents[p])
        torso.bones.insert(torso.bones.begin(), p);
    torso.end_bone = !rest.empty() ? rest[0] : -1;
    out.chains.push_back(torso);
    if (!neck.empty()) {
        Chain c;
        c.kind = ChainKind::Neck;
        c.name = "neck";
        c.bones = neck;
        c.end_bone = head;
        c.parent_chain = 0;
        c.joint_parent = spine[chest_index];
        out.chains.push_back(c);
    }
    // Arms, left first.
    std::vector<Chain> arm_chains;
    for (const auto& [arm_root, attach] : arms) {
        Chain c;
        c.kind = ChainKind::Arm;
        split_limb(t, arm_root, &c);
        c.side = glm::dot(t.farthest(arm_root, hip) - hip, frame.left) > 0.0 ? 1 : -1;
        c.name = std::string("arm") + side_name(c.side);
        c.parent_chain = 0;
        c.joint_parent = c.first_swept > 0 ? c.bones[c.first_swept - 1] : attach;
        arm_chains.push_back(c);
    }
    std::sort(arm_chains.begin(), arm_chains.end(), [](const Chain& a, const Chain& b) { return a.side > b.side; });
    if (arm_chains.size() == 2 && arm_chains[0].side == arm_chains[1].side)
        out.notes.push_back("both arms lie on the same side of the body");
    for (Chain& c : arm_chains) {
        mirrored_check(c);
        out.chains.push_back(c);
    }
    for (int k = 0; k < 2; ++k) {
        const int i = (leg0_side > 0) == (k == 0) ? 0 : 1;  // left leg first
        Chain c = leg_chain[i];
        c.side = (i == 0 ? leg0_side : -leg0_side);
        c.name = std::string("leg") + side_name(c.side);
        c.parent_chain = 0;
        c.joint_parent = c.first_swept > 0 ? c.bones[c.first_swept - 1] : s.parents[c.bones[0]];
        mirrored_check(c);
        out.chains.push_back(c);
    }
    return out;
}

ChainSet chains_from_lists(const Skeleton& s, const std::vector<std::vector<int>>& lists) {
    const Tree t(s, {});
    ChainSet out;
    out.size = t.size;
    std::vector<int> owner(t.count, -1);
    for (size_t c = 0; c < lists.size(); ++c) {
        const std::string where = "chain " + std::to_string(c);
        if (lists[c].empty()) throw InvalidInput(where + " has no bones");
        for (size_t k = 0; k < lists[c].size(); ++k) {
            const int b = lists[c][k];
            if (b < 0 || b >= t.count)
                throw InvalidInput(where + ": bone index " + std::to_string(b) + " is out of range 0.." +
                                   std::to_string(t.count - 1));
            if (owner[b] >= 0)
                throw InvalidInput(where + ": bone " + std::to_string(b) + " is already in chain " +
                                   std::to_string(owner[b]));
            owner[b] = static_cast<int>(c);
            if (k > 0 && !t.is_descendant(b, lists[c][k - 1]))
                throw InvalidInput(where + ": bone " + std::to_string(b) + " is not below bone " +
                                   std::to_string(lists[c][k - 1]) + " (a chain runs down the hierarchy)");
        }
    }
    for (size_t c = 0; c < lists.size(); ++c) {
        Chain ch;
        ch.name = "chain_" + std::to_string(c);
        ch.bones = lists[c];
        const int last = ch.bones.back();
        const dvec3 dir = s.tails[last] - s.heads[last];
        double best = -std::numeric_limits<double>::infinity();
        for (int child : t.children[last]) {
            if (!t.real(child)) continue;
            const dvec3 cd = glm::normalize(s.tails[child] - s.heads[child]);
            const double score = glm::dot(cd, glm::normalize(dir));
            if (score > best) {
                best = score;
                ch.end_bone = child;
            }
        }
        out.chains.push_back(ch);
    }
    // A chain hangs from the chain owning the nearest chain bone above its first bone.
    for (Chain& ch : out.chains)
        for (int x = s.parents[ch.bones[0]]; x >= 0; x = s.parents[x])
            if (owner[x] >= 0) {
                ch.parent_chain = owner[x];
                ch.joint_parent = s.parents[ch.bones[0]];
                break;
            }
    out.notes.push_back("chains given explicitly");
    return out;
}

BoneOwners bone_owners(const Skeleton& s, const ChainSet& set) {
    const int B = s.bone_count();
    BoneOwners o;
    o.chain.assign(B, -1);
    o.attached.assign(B, -1);
    o.inner.assign(B, 0);
    std::vector<char> decided(B, 0);
    for (size_t c = 0; c < set.chains.size(); ++c)
        for (size_t i = 0; i < set.chains[c].bones.size(); ++i) {
            const int b = set.chains[c].bones[i];
            o.chain[b] = static_cast<int>(c);
            o.inner[b] = static_cast<int>(i) < set.chains[c].first_swept;
            decided[b] = 1;
        }
    for (size_t c = 0; c < set.chains.size(); ++c) {
        const int e = set.chains[c].end_bone;
        if (e >= 0 && !decided[e]) {
            o.attached[e] = static_cast<int>(c);
            decided[e] = 1;
        }
    }
    // Everything else follows its parent (visited parents first): below a rigid end bone it
    // is rigid too, below a link it rides that link's chain.
    for (int b : parents_first(s)) {
        if (decided[b]) continue;
        const int p = s.parents[b];
        if (p < 0) continue;  // an extra root (e.g. a "Root" bone at the origin): rigid
        o.chain[b] = o.chain[p];
        o.attached[b] = o.attached[p];
    }
    return o;
}

}  // namespace sd::fit
