#include "fit/deform_hierarchy.h"

#include "math/segment_distance.h"

#include <algorithm>
#include <array>
#include <limits>
#include <map>

namespace sd::fit {

namespace {

std::string bone_text(const std::vector<std::string>& names, int b) {
    return b < static_cast<int>(names.size()) && !names[b].empty() ? "'" + names[b] + "'" : "bone " + std::to_string(b);
}

using Place = std::array<double, 6>;  // head and tail

Place place_of(const Skeleton& s, int b) {
    return {s.heads[b].x, s.heads[b].y, s.heads[b].z, s.tails[b].x, s.tails[b].y, s.tails[b].z};
}

}  // namespace

Skeleton deform_hierarchy(const Skeleton& skeleton, const std::vector<double>& bone_mass,
                          const std::vector<std::string>& names, std::vector<std::string>* notes) {
    const int B = skeleton.bone_count();
    if (static_cast<int>(bone_mass.size()) != B) return skeleton;
    const auto skinned = [&](int b) { return bone_mass[b] > 0.0; };
    // Each skinned bone's nearest skinned ancestor: the trees the skinned bones form.
    std::vector<int> above(B, -1);
    std::vector<int> roots;
    for (int b = 0; b < B; ++b) {
        if (!skinned(b)) continue;
        int p = skeleton.parents[b];
        while (p >= 0 && !skinned(p)) p = skeleton.parents[p];
        above[b] = p;
        if (p < 0) roots.push_back(b);
    }
    // One tree: nothing to do. Thousands of separate skinned bones are no humanoid's rig (and
    // hanging them would cost their count squared): left as they are.
    if (roots.size() < 2 || roots.size() > kMostDeformRoots) return skeleton;
    std::vector<int> root_of(B, -1);
    for (int b = 0; b < B; ++b) {
        if (!skinned(b)) continue;
        int r = b;
        while (above[r] >= 0) r = above[r];
        root_of[b] = r;
    }

    Skeleton out = skeleton;
    std::vector<int> hung_on(B, -1);  // per deform root: the skinned bone it now hangs from
    const auto top = [&](int b) {     // the root of b's tree with the hung trees joined
        int r = root_of[b];
        while (hung_on[r] >= 0) r = root_of[hung_on[r]];
        return r;
    };
    const auto hang = [&](int r, int on, const std::string& why) {
        out.parents[r] = on;
        hung_on[r] = on;
        if (notes)
            notes->push_back(bone_text(names, r) + " hangs from no skinned bone: taken as a child of " +
                             bone_text(names, on) + why);
    };

    // First where the mechanism bones say it: Rigify's ORG bones lie exactly where the deform
    // bones do (ORG-shoulder.L where DEF-shoulder.L), and DEF-upper_arm.L hangs from
    // ORG-shoulder.L. A deform root hangs from the skinned bone in the place of its nearest
    // unskinned ancestor that has one (never from its own tree, never closing a loop).
    std::map<Place, std::vector<int>> skinned_at;
    for (int b = 0; b < B; ++b)
        if (skinned(b)) skinned_at[place_of(skeleton, b)].push_back(b);
    for (int r : roots)
        for (int p = skeleton.parents[r]; p >= 0 && hung_on[r] < 0; p = skeleton.parents[p]) {
            const auto it = skinned_at.find(place_of(skeleton, p));
            if (it == skinned_at.end()) continue;
            for (int x : it->second)
                if (top(x) != r) {
                    hang(r, x, ", the skinned bone where its parent " + bone_text(names, p) + " lies");
                    break;
                }
        }

    // Then by place: what is left hangs on the tree whose root lies highest in the hierarchy
    // (Rigify's DEF-spine hangs from the root bone, its thighs from ORG-spine below it), the
    // heaviest of those (a leg can outweigh the trunk), each from the skinned bone nearest its
    // head, nearest pairs first (Prim's order), within kDeformRootReach of the skeleton's size.
    std::vector<int> waiting;
    for (int r : roots)
        if (hung_on[r] < 0) waiting.push_back(r);
    if (waiting.size() < 2) return out;
    std::vector<double> mass_of(B, 0.0);
    for (int b = 0; b < B; ++b)
        if (skinned(b)) mass_of[top(b)] += bone_mass[b];
    const auto depth = [&](int b) {
        int d = 0;
        for (int p = skeleton.parents[b]; p >= 0; p = skeleton.parents[p]) ++d;
        return d;
    };
    const auto main_it = std::min_element(waiting.begin(), waiting.end(), [&](int a, int b) {
        return depth(a) != depth(b) ? depth(a) < depth(b) : mass_of[a] > mass_of[b];
    });
    const int main_root = *main_it;
    waiting.erase(main_it);
    const double reach = kDeformRootReach * skeleton.extent();
    // Each waiting root keeps its nearest hung bone, updated with each tree as it is hung.
    std::vector<double> nearest(B, std::numeric_limits<double>::infinity());
    std::vector<int> nearest_bone(B, -1);
    const auto in_tree = [&](int b, int tree) {  // b's tree is `tree` or hangs below it
        for (int r = root_of[b];; r = root_of[hung_on[r]]) {
            if (r == tree) return true;
            if (hung_on[r] < 0) return false;
        }
    };
    const auto joined = [&](int tree) {
        for (int b = 0; b < B; ++b) {
            if (!skinned(b) || !in_tree(b, tree)) continue;
            for (int r : waiting) {
                const double d = segment_distance(skeleton.heads[r], skeleton.heads[b], skeleton.tails[b]);
                if (d < nearest[r]) nearest[r] = d, nearest_bone[r] = b;
            }
        }
    };
    joined(main_root);
    while (!waiting.empty()) {
        const auto next =
            std::min_element(waiting.begin(), waiting.end(), [&](int a, int b) { return nearest[a] < nearest[b]; });
        const int r = *next;
        if (!(nearest[r] <= reach)) break;  // the rest lie apart from the body
        waiting.erase(next);
        hang(r, nearest_bone[r], ", the skinned bone nearest its head");
        joined(r);
    }
    return out;
}

}  // namespace sd::fit
