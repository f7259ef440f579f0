// The C ABI of the anatomical effects (Sect. 4.3, 4.4): validation, status codes, and the
// exception barrier of abi/guard.h. No exception leaves this file.
#include "sweepdeform/sweepdeform.h"

#include "anatomy/anatomy.h"
#include "abi/guard.h"
#include "bind/serialize.h"

#include <cmath>
#include <memory>
#include <string>

struct sd_anatomy {
    std::unique_ptr<sd::anatomy::Anatomy> anatomy;
    uint64_t rig_fingerprint = 0;
    // The last deformer found to carry the same rig (the check serialises the rig).
    const sd_deformer* checked_deformer = nullptr;
};

namespace {

using sd::abi::fail;
using sd::abi::guarded;
using sd::abi::require_finite;
using sd::anatomy::JointSettings;

constexpr int32_t kMaxTriangles = 1 << 28;

sd::anatomy::Anatomy& of(sd_anatomy* a) {
    SD_REQUIRE(a && a->anatomy, "anatomy is NULL");
    return *a->anatomy;
}
const sd::anatomy::Anatomy& of(const sd_anatomy* a) {
    SD_REQUIRE(a && a->anatomy, "anatomy is NULL");
    return *a->anatomy;
}

void require_joint(const sd::anatomy::Anatomy& a, int32_t joint) {
    SD_REQUIRE(joint >= 0 && joint < a.joint_count(),
               "joint " + std::to_string(joint) + " is out of range (" + std::to_string(a.joint_count()) + " joints)");
}

/// SD_OK, or the status to return when `d` does not fit the anatomy.
sd_status check_deformer(sd_anatomy* a, const sd_deformer* d) {
    SD_REQUIRE(d && d->deformer, "deformer is NULL");
    const sd::Deformer& def = *d->deformer;
    const sd::anatomy::Anatomy& an = *a->anatomy;
    if (def.vertex_count() != an.vertex_count())
        return fail(SD_ERR_MISMATCH, "the deformer has " + std::to_string(def.vertex_count()) +
                                         " vertices, the anatomy " + std::to_string(an.vertex_count()));
    if (def.rig().sweeps.size() != an.rig().sweeps.size() ||
        def.rig().skeleton.bone_count() != an.rig().skeleton.bone_count())
        return fail(SD_ERR_MISMATCH, "the deformer was made with another rig");
    if (a->checked_deformer != d) {
        if (sd::rig_fingerprint(def.rig()) != a->rig_fingerprint)
            return fail(SD_ERR_MISMATCH, "the deformer was made with another rig");
        a->checked_deformer = d;
    }
    return SD_OK;
}

sd_status check_pose(const sd::anatomy::Anatomy& a, int32_t bone_count, const float* pose, int32_t vertex_count) {
    SD_REQUIRE(pose, "pose is NULL");
    if (bone_count != a.rig().skeleton.bone_count())
        return fail(SD_ERR_MISMATCH, "pose has " + std::to_string(bone_count) + " bones, the rig " +
                                         std::to_string(a.rig().skeleton.bone_count()));
    if (vertex_count != a.vertex_count())
        return fail(SD_ERR_MISMATCH, "vertex_count " + std::to_string(vertex_count) + " differs from the mesh's " +
                                         std::to_string(a.vertex_count()));
    return SD_OK;
}

}  // namespace

extern "C" {

sd_status sd_anatomy_create(const sd_rig* rig, const sd_binding* binding, int32_t triangle_count,
                            const int32_t* triangles, sd_anatomy** out) {
    return guarded(__func__, [&] {
        SD_REQUIRE(rig && binding && out, "rig, binding or out_anatomy is NULL");
        SD_REQUIRE(triangle_count >= 1 && triangle_count <= kMaxTriangles,
                   "triangle_count must be in 1.." + std::to_string(kMaxTriangles));
        SD_REQUIRE(triangles, "triangles is NULL");
        const uint64_t fingerprint = sd::rig_fingerprint(rig->rig);
        if (binding->binding.rig_fingerprint != fingerprint)
            return fail(SD_ERR_MISMATCH, "the binding was made for another rig; re-bind");
        auto a = std::make_unique<sd_anatomy>();
        a->anatomy = std::make_unique<sd::anatomy::Anatomy>(rig->rig, binding->binding, triangles, triangle_count);
        a->rig_fingerprint = fingerprint;
        *out = a.release();
        return SD_OK;
    });
}

void sd_anatomy_destroy(sd_anatomy* anatomy) { delete anatomy; }

sd_status sd_anatomy_add_joint(sd_anatomy* anatomy, int32_t lower_bone, int32_t kind, const float* flexion_direction,
                               int32_t* out_joint) {
    return guarded(__func__, [&] {
        sd::anatomy::Anatomy& a = of(anatomy);
        SD_REQUIRE(kind >= SD_JOINT_KIND_GENERIC && kind <= SD_JOINT_KIND_KNEE, "kind must be 0, 1 or 2");
        SD_REQUIRE(lower_bone >= 0 && lower_bone < a.rig().skeleton.bone_count(),
                   "lower_bone " + std::to_string(lower_bone) + " is out of range");
        SD_REQUIRE(flexion_direction || kind == SD_JOINT_KIND_GENERIC, "an elbow or a knee needs flexion_direction");
        sd::dvec3 f(0.0);
        if (flexion_direction) {
            require_finite(flexion_direction, 3, "flexion_direction");
            f = sd::dvec3(flexion_direction[0], flexion_direction[1], flexion_direction[2]);
        }
        const int j =
            a.add_joint(lower_bone, static_cast<sd::anatomy::JointKind>(kind), flexion_direction ? &f : nullptr);
        if (out_joint) *out_joint = j;
        return SD_OK;
    });
}

int32_t sd_anatomy_joint_count(const sd_anatomy* anatomy) {
    int32_t count = -1;
    guarded(__func__, [&] {
        count = of(anatomy).joint_count();
        return SD_OK;
    });
    return count;
}

sd_status sd_anatomy_set_joint_effects(sd_anatomy* anatomy, int32_t joint, int32_t effects) {
    return guarded(__func__, [&] {
        sd::anatomy::Anatomy& a = of(anatomy);
        require_joint(a, joint);
        SD_REQUIRE(effects >= 0 && effects <= (SD_EFFECT_FOLDING | SD_EFFECT_PROTRUSION | SD_EFFECT_BULGE),
                   "effects must be a combination of SD_EFFECT_FOLDING, _PROTRUSION and _BULGE");
        JointSettings s = a.joint(joint).settings;
        s.folding = (effects & SD_EFFECT_FOLDING) != 0;
        s.protrusion = (effects & SD_EFFECT_PROTRUSION) != 0;
        s.bulge = (effects & SD_EFFECT_BULGE) != 0;
        a.set_joint_settings(joint, s);
        return SD_OK;
    });
}

sd_status sd_anatomy_get_joint_effects(const sd_anatomy* anatomy, int32_t joint, int32_t* effects) {
    return guarded(__func__, [&] {
        const sd::anatomy::Anatomy& a = of(anatomy);
        require_joint(a, joint);
        SD_REQUIRE(effects, "effects is NULL");
        const JointSettings& s = a.joint(joint).settings;
        *effects = (s.folding ? SD_EFFECT_FOLDING : 0) | (s.protrusion ? SD_EFFECT_PROTRUSION : 0) |
                   (s.bulge ? SD_EFFECT_BULGE : 0);
        return SD_OK;
    });
}

namespace {
double* parameter(JointSettings& s, int32_t p) {
    switch (p) {
        case SD_JOINT_PARAM_PROTRUSION_STRENGTH:
            return &s.protrusion_strength;
        case SD_JOINT_PARAM_PROTRUSION_FALLOFF:
            return &s.protrusion_falloff;
        case SD_JOINT_PARAM_BULGE_STRENGTH:
            return &s.bulge_strength;
        case SD_JOINT_PARAM_BULGE_FALLOFF:
            return &s.bulge_falloff;
        case SD_JOINT_PARAM_FOLDING_FALLOFF:
            return &s.folding_falloff;
        case SD_JOINT_PARAM_FOLDING_MARGIN:
            return &s.folding_margin;
        case SD_JOINT_PARAM_REGION_RADIUS:
            return &s.region_radius;
        default:
            throw sd::InvalidInput("parameter " + std::to_string(p) + " is unknown");
    }
}
}  // namespace

sd_status sd_anatomy_set_joint_parameter(sd_anatomy* anatomy, int32_t joint, int32_t p, float value) {
    return guarded(__func__, [&] {
        sd::anatomy::Anatomy& a = of(anatomy);
        require_joint(a, joint);
        SD_REQUIRE(std::isfinite(value), "value is not finite");
        JointSettings s = a.joint(joint).settings;
        *parameter(s, p) = value;
        a.set_joint_settings(joint, s);  // validates the range
        return SD_OK;
    });
}

sd_status sd_anatomy_get_joint_parameter(const sd_anatomy* anatomy, int32_t joint, int32_t p, float* value) {
    return guarded(__func__, [&] {
        const sd::anatomy::Anatomy& a = of(anatomy);
        require_joint(a, joint);
        SD_REQUIRE(value, "value is NULL");
        JointSettings s = a.joint(joint).settings;
        *value = static_cast<float>(*parameter(s, p));
        return SD_OK;
    });
}

sd_status sd_anatomy_set_joint_proxy(sd_anatomy* anatomy, int32_t joint, int32_t vertex_count, const float* positions,
                                     int32_t triangle_count, const int32_t* triangles, float fraction) {
    return guarded(__func__, [&] {
        sd::anatomy::Anatomy& a = of(anatomy);
        require_joint(a, joint);
        SD_REQUIRE(vertex_count >= 4 && vertex_count <= (1 << 24), "vertex_count must be in 4..2^24");
        SD_REQUIRE(triangle_count >= 4 && triangle_count <= (1 << 24), "triangle_count must be in 4..2^24");
        SD_REQUIRE(positions && triangles, "positions or triangles is NULL");
        SD_REQUIRE(std::isfinite(fraction) && fraction >= 0.0f && fraction <= 1.0f, "fraction must be in [0, 1]");
        require_finite(positions, 3 * static_cast<size_t>(vertex_count), "positions");
        sd::anatomy::ProxyShape shape;
        shape.positions.assign(positions, positions + 3 * static_cast<size_t>(vertex_count));
        shape.triangles.assign(triangles, triangles + 3 * static_cast<size_t>(triangle_count));
        a.set_joint_proxy(joint, std::move(shape), fraction);
        return SD_OK;
    });
}

sd_status sd_anatomy_set_volume_feedback(sd_anatomy* anatomy, int32_t mode, int32_t restore) {
    return guarded(__func__, [&] {
        sd::anatomy::Anatomy& a = of(anatomy);
        SD_REQUIRE(mode >= 0 && mode <= 2, "mode must be 0, 1 or 2");
        a.set_volume_feedback(static_cast<sd::anatomy::VolumeFeedback>(mode));
        a.set_volume_restoration(restore != 0);
        return SD_OK;
    });
}

sd_status sd_anatomy_set_folding_iterations(sd_anatomy* anatomy, int32_t iterations) {
    return guarded(__func__, [&] {
        of(anatomy).set_folding_iterations(iterations);
        return SD_OK;
    });
}

sd_status sd_anatomy_apply(sd_anatomy* anatomy, sd_deformer* deformer, int32_t bone_count, const float* pose,
                           int32_t vertex_count, float* positions) {
    return guarded(__func__, [&] {
        sd::anatomy::Anatomy& a = of(anatomy);
        if (deformer) {
            const sd_status s = check_deformer(anatomy, deformer);
            if (s != SD_OK) return s;
        }
        const sd_status s = check_pose(a, bone_count, pose, vertex_count);
        if (s != SD_OK) return s;
        SD_REQUIRE(positions, "positions is NULL");
        require_finite(positions, 3 * static_cast<size_t>(vertex_count), "positions");
        sd::SkeletonPose p;
        p.set(a.rig().skeleton, pose);  // validates the matrices
        a.apply(p, positions, deformer ? deformer->deformer.get() : nullptr);
        return SD_OK;
    });
}

sd_status sd_deform_with_anatomy(sd_deformer* deformer, sd_anatomy* anatomy, int32_t bone_count, const float* pose,
                                 int32_t vertex_count, float* out_positions) {
    return guarded(__func__, [&] {
        sd::anatomy::Anatomy& a = of(anatomy);
        sd_status s = check_deformer(anatomy, deformer);
        if (s != SD_OK) return s;
        s = check_pose(a, bone_count, pose, vertex_count);
        if (s != SD_OK) return s;
        SD_REQUIRE(out_positions, "out_positions is NULL");
        sd::SkeletonPose p;
        p.set(a.rig().skeleton, pose);  // validates before anything is written
        a.deform(*deformer->deformer, pose, out_positions);
        return SD_OK;
    });
}

sd_status sd_anatomy_get_stats(const sd_anatomy* anatomy, int32_t count, double* values) {
    return guarded(__func__, [&] {
        const sd::anatomy::Anatomy& a = of(anatomy);
        SD_REQUIRE(count >= 0 && count <= SD_STAT_COUNT, "count must be in 0..SD_STAT_COUNT");
        SD_REQUIRE(values || count == 0, "values is NULL");
        const sd::anatomy::AnatomyStats& st = a.stats();
        const double all[SD_STAT_COUNT] = {st.ms_sweeps,
                                           st.ms_bulge,
                                           st.ms_protrusion,
                                           st.ms_collision,
                                           st.ms_folding,
                                           st.ms_volume,
                                           st.ms_total,
                                           static_cast<double>(st.collision_triangles),
                                           static_cast<double>(st.pairs_before),
                                           static_cast<double>(st.pairs_after),
                                           static_cast<double>(st.folding_iterations),
                                           static_cast<double>(st.folding_regions),
                                           static_cast<double>(st.bulge_vertices),
                                           static_cast<double>(st.protrusion_vertices),
                                           static_cast<double>(st.folding_vertices),
                                           static_cast<double>(st.falloff_vertices),
                                           static_cast<double>(st.relaxed_vertices),
                                           st.max_bulge,
                                           st.max_protrusion,
                                           st.max_fold_depth,
                                           st.volume_change,
                                           st.effects_volume,
                                           static_cast<double>(st.passes),
                                           st.restored_volume};
        for (int32_t i = 0; i < count; ++i) values[i] = all[i];
        return SD_OK;
    });
}

sd_status sd_anatomy_get_volume_offsets(const sd_anatomy* anatomy, int32_t sweep_count, double* offsets) {
    return guarded(__func__, [&] {
        const sd::anatomy::Anatomy& a = of(anatomy);
        SD_REQUIRE(offsets, "offsets is NULL");
        if (sweep_count != static_cast<int32_t>(a.volume_offsets().size()))
            return fail(SD_ERR_MISMATCH, "sweep_count differs from the rig's");
        for (int32_t s = 0; s < sweep_count; ++s) offsets[s] = a.volume_offsets()[s];
        return SD_OK;
    });
}

sd_status sd_anatomy_count_intersections(sd_anatomy* anatomy, int32_t vertex_count, const float* positions,
                                         int32_t* out_pairs) {
    return guarded(__func__, [&] {
        sd::anatomy::Anatomy& a = of(anatomy);
        SD_REQUIRE(positions && out_pairs, "positions or out_pairs is NULL");
        if (vertex_count != a.vertex_count())
            return fail(SD_ERR_MISMATCH, "vertex_count " + std::to_string(vertex_count) + " differs from the mesh's " +
                                             std::to_string(a.vertex_count()));
        require_finite(positions, 3 * static_cast<size_t>(vertex_count), "positions");
        *out_pairs = a.count_intersections(positions);
        return SD_OK;
    });
}

}  // extern "C"
