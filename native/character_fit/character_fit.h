// The automatic fitting's input from a character loaded by sweepdeform_io (its own skin
// weights, 4 per vertex), and fit + bind as the add-on does it; for the native tests and the
// benchmarks (target sweepdeform_character_fit: the core and sweepdeform_io, header-only).
#pragma once

#include "bind/bind.h"
#include "deform/deform.h"
#include "deform/linear_blend_skinning.h"
#include "fit/fit_rig.h"

#include <sweepdeform_io/character.h>

#include <memory>
#include <string>
#include <utility>
#include <vector>

namespace sd::character_fit {

inline Skeleton skeleton_of(const io::Character& c) {
    return Skeleton::from_arrays(static_cast<int>(c.bone_names.size()), c.bone_parents.data(), c.bone_rest.data(),
                                 c.bone_heads.data(), c.bone_tails.data());
}

inline fit::FitInput character_input(const io::Character& c, const Skeleton& s) {
    fit::FitInput in;
    in.vertex_count = static_cast<int>(c.positions.size() / 3);
    in.positions = c.positions.data();
    in.triangle_count = static_cast<int>(c.triangles.size() / 3);
    in.triangles = c.triangles.data();
    in.skeleton = s;
    in.bone_names = c.bone_names;
    in.skin_slots = 4;
    in.skin_bones = c.skin_joints.data();
    in.skin_weights = c.skin_weights.data();
    return in;
}

inline fit::FitInput fit_input(const io::Character& c) { return character_input(c, skeleton_of(c)); }

/// Binds `vertex_count` positions (x, y, z each) with the fitted rig and region weights.
inline Binding bind_fitted(const fit::FitResult& f, int vertex_count, const float* positions) {
    const fit::RegionWeights& w = f.weights;
    return bind_vertices(f.rig, vertex_count, positions, w.sweep_slots, w.sweep_ids.data(), w.sweep_weights.data(),
                         w.bone_slots, w.bone_ids.data(), w.bone_weights.data());
}

/// Binds the character with the fitted rig and region weights.
inline Binding bind_fitted(const io::Character& c, const fit::FitResult& f) {
    return bind_fitted(f, static_cast<int>(c.positions.size() / 3), c.positions.data());
}

/// A character fitted and bound by the product as the add-on does it, with its deformer.
struct Fitted {
    io::Character character;
    Skeleton skeleton;
    fit::FitResult fit;
    std::unique_ptr<Deformer> deformer;  // held by pointer: a Deformer does not move
};

inline Fitted fit_and_bind(io::Character c) {
    Fitted f;
    f.skeleton = skeleton_of(c);
    f.fit = fit::fit_rig(character_input(c, f.skeleton));
    f.deformer = std::make_unique<Deformer>(f.fit.rig, bind_fitted(c, f.fit));
    f.deformer->set_skin_triangles(std::vector<int32_t>(c.triangles.begin(), c.triangles.end()));  // the trunk's fill
    f.character = std::move(c);
    return f;
}

/// The index of the bone called `name`, -1 if the character has none.
inline int bone_named(const io::Character& c, const std::string& name) {
    for (size_t b = 0; b < c.bone_names.size(); ++b)
        if (c.bone_names[b] == name) return static_cast<int>(b);
    return -1;
}

/// The character's own linear blend skinning (its 4 weights a vertex) in `pose` (#B*16
/// posed matrices of `s`): the positions into `out` (#V*3).
inline void skin_linearly(const io::Character& c, const Skeleton& s, const float* pose, float* out) {
    SkeletonPose sp;
    sp.set(s, pose);
    skin_linear_blend4(bone_affines(sp), static_cast<int>(c.positions.size() / 3), c.positions.data(),
                       c.skin_joints.data(), c.skin_weights.data(), out);
}

/// `c` re-rested in `pose` (#B*16 posed matrices of `s`): its mesh skinned there by its own
/// weights, and the posed bones its new rest (a T-pose made from an A-pose, say).
inline io::Character rerested(const io::Character& c, const Skeleton& s, const std::vector<float>& pose) {
    io::Character t = c;
    skin_linearly(c, s, pose.data(), t.positions.data());
    SkeletonPose sp;
    sp.set(s, pose.data());
    t.bone_rest = pose;
    for (int b = 0; b < s.bone_count(); ++b) {
        const dvec3 head(sp.deform[b] * dvec4(s.heads[b], 1.0)), tail(sp.deform[b] * dvec4(s.tails[b], 1.0));
        for (int i = 0; i < 3; ++i) {
            t.bone_heads[3 * b + i] = static_cast<float>(head[i]);
            t.bone_tails[3 * b + i] = static_cast<float>(tail[i]);
        }
    }
    return t;
}

}  // namespace sd::character_fit
