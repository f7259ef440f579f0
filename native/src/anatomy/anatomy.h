// The per-frame pipeline of anatomical effects (Sect. 4.3, 4.4), on top of the sweep
// deformation:
//
//   sweeps (Deformer, with volume control)
//     -> muscle bulge -> bone protrusion -> volume restoration push (height from before)
//     -> collision detection in the joint regions -> skin folding: bisecting planes for
//        contacts between parts at elbows and knees, relaxing for crumpled skin and what the
//        planes leave, re-detecting after each pass until no intersecting pair is left
//     -> volume restoration trim: the skin's measured volume deficit closed in this frame
//        by the push, contacts that makes folded
//     -> volume: I_C per sweep, fed back to the deformer (target V0 - I_C, "for the next
//        frame")
//
// Joints are added one by one (elbow, knee, or generic: shoulder, hip, neck — folding only)
// with per-joint switches and strengths. An elbow gets an olecranon proxy and a biceps, a
// knee a patella proxy and a calf muscle, automatically; a user proxy mesh can replace them.
// Every stage is timed; counts of intersecting pairs before and after folding are kept.
#pragma once

#include "anatomy/bone_protrusion.h"
#include "anatomy/falloff.h"
#include "anatomy/joint.h"
#include "geometry/mesh_topology.h"
#include "geometry/mesh_volume.h"
#include "anatomy/muscle_bulge.h"
#include "geometry/self_intersection.h"
#include "anatomy/skin_folding.h"
#include "anatomy/skin_parts.h"
#include "bind/bind.h"
#include "deform/deform.h"
#include "rig/rig.h"

#include <memory>
#include <vector>

namespace sd::anatomy {

/// How I_C reaches the volume controller.
enum class VolumeFeedback {
    Off = 0,        ///< not at all
    NextFrame = 1,  ///< this frame's I_C sets the next frame's target (the paper; one pass)
    InFrame = 2,    ///< I_C in the same frame: sweeps, effects (I_C known after bulge and
                    ///< protrusion, or at the end without the restoration), the sweeps again
                    ///< with it and their change added; the result depends on the pose only
};

struct AnatomyStats {
    // Milliseconds of the last frame, per stage.
    double ms_sweeps = 0, ms_bulge = 0, ms_protrusion = 0, ms_collision = 0, ms_folding = 0, ms_volume = 0,
           ms_total = 0;
    int collision_triangles = 0;  ///< triangles in the enabled joint regions
    int pairs_before = 0;         ///< intersecting pairs found after sweeps, bulge, protrusion
    int pairs_after = 0;          ///< left after folding
    int folding_iterations = 0;
    int folding_regions = 0;  ///< intersection regions folded (over all iterations)
    int bulge_vertices = 0, protrusion_vertices = 0, folding_vertices = 0, falloff_vertices = 0;
    int relaxed_vertices = 0;  ///< smoothed to untangle what the planes left
    double max_bulge = 0, max_protrusion = 0, max_fold_depth = 0;
    double volume_change = 0;       ///< Σ I_C over the sweeps handed to the deformer (units^3)
    double effects_volume = 0;      ///< Σ volume bulge, protrusion and folding added (with the
                                    ///< restoration on: bulge and protrusion only)
    double restored_volume = 0;     ///< Σ volume the restoration added
    int passes = 0;                 ///< passes of the effects (1; the sweeps run twice with InFrame)
    double ms_first_detection = 0;  ///< of ms_collision: the full query (the rest re-checks)
    int rechecks = 0;               ///< re-check queries after folding or restoration
    long rechecked_triangles = 0;   ///< triangles they were asked about
    long triangle_tests = 0;        ///< exact triangle-triangle tests run
};

class Anatomy {
public:
    /// @param triangles  #T*3 vertex indices of the mesh bound by `binding`
    /// @throws InvalidInput on bad triangles
    Anatomy(const Rig& rig, const Binding& binding, const int32_t* triangles, int triangle_count);

    /// Adds the joint whose lower link is `lower_bone` (see make_joint), with an olecranon
    /// proxy and a biceps for an elbow, a patella proxy and a calf for a knee.
    /// @return its index. @throws InvalidInput
    int add_joint(int lower_bone, JointKind kind, const dvec3* flexion_direction);
    int joint_count() const { return static_cast<int>(joints_.size()); }
    const Joint& joint(int j) const { return joints_.at(j); }
    /// @throws InvalidInput on an out-of-range value
    void set_joint_settings(int joint, const JointSettings& settings);

    /// Replaces the joint's proxies by a user mesh (rest, armature space) that follows
    /// `fraction` of the joint's rotation. @throws InvalidInput (see BoneProxy)
    void set_joint_proxy(int joint, ProxyShape shape, double fraction);
    const std::vector<BoneProxy>& proxies() const { return proxies_; }
    const std::vector<MuscleBulge>& muscles() const { return muscles_; }

    void set_collision_backend(std::unique_ptr<CollisionBackend> backend);
    void set_volume_feedback(VolumeFeedback mode) { feedback_ = mode; }
    VolumeFeedback volume_feedback() const { return feedback_; }
    /// Volume restoration (default on): the skin of each sweep that owns an elbow or a knee
    /// is held at its rest mesh volume by a smooth outward push around the joint, on the
    /// extensor half (flesh squeezed in the crease goes around it). The push is applied with
    /// bulge and protrusion at the height the frames before left, before collision detection
    /// (folding handles what it touches); after folding the skin's volume is measured and the
    /// push trimmed in the same frame by what closes the deficit (then re-checked for
    /// contacts). Folding's loss then stays out of I_C. It closes what I_C and the sweep
    /// integral cannot: the
    /// displacement map's own volume change at deep bends (the paper assumes it constant)
    /// and the volume the controller puts where the skin is not (e.g. a shoulder key).
    void set_volume_restoration(bool on) { restore_ = on; }
    bool volume_restoration() const { return restore_; }
    /// Folding passes per frame (detection after each), 1..64 (default 10).
    void set_folding_iterations(int n);

    /// The effects on `positions` (#V*3, the sweep deformation for `pose` made by
    /// `deformer`, or nullptr), in place; computes I_C (volume_offsets) and hands it to the
    /// deformer (when given) as the feedback mode says.
    void apply(const SkeletonPose& pose, float* positions, Deformer* deformer = nullptr);
    /// One frame: sweeps, effects, and I_C fed back to `deformer` as the feedback mode says.
    /// @param pose  #B*16 posed bone matrices. @throws InvalidInput
    void deform(Deformer& deformer, const float* pose, float* out);

    const AnatomyStats& stats() const { return stats_; }
    /// I_C per sweep of the last frame (units^3): what the effects added.
    const std::vector<double>& volume_offsets() const { return offsets_; }

    /// Exact count of intersecting pairs among the enabled joint regions' triangles
    /// (a full BVH query without normal-cone culling), for checks and display.
    int count_intersections(const float* positions, std::vector<TrianglePair>* pairs = nullptr);
    /// Mesh volume of the skin of sweep `s` (its triangles closed by caps), for sweeps that
    /// own an elbow or a knee; 0 otherwise. And its rest value.
    double sweep_skin_volume(int s, const float* positions) const;
    double sweep_skin_rest_volume(int s) const;
    /// The triangles of a joint's collision region (rest-pose ball, see Joint).
    const std::vector<int32_t>& region_triangles(int joint) const { return region_triangles_.at(joint); }

    const MeshTopology& mesh() const { return mesh_; }
    const SkinParts& parts() const { return parts_; }
    const Rig& rig() const { return rig_; }
    int vertex_count() const { return mesh_.vertex_count; }

private:
    /// The effects on `positions`. With `in_frame` (VolumeFeedback::InFrame), the frame's own
    /// I_C is put back as soon as it is known, by the sweeps once more (correct_in_frame).
    struct InFrame {
        Deformer* deformer = nullptr;
        const float* pose = nullptr;
    };
    void apply_pass(const SkeletonPose& pose, float* positions, const InFrame& in_frame);
    /// The sweeps again with the volume offsets I_C sets, their change added to `positions`:
    /// the effects are displacements of the swept skin, which I_C moves by a few per cent of
    /// the joints' volume.
    void correct_in_frame(const InFrame& in_frame, const std::vector<double>& ic, float* positions);
    /// The next offsets for I_C `ic` (per sweep), from those last applied.
    void offsets_toward(const std::vector<double>& ic);
    void effects_change(const std::vector<JointPose>& jp, std::vector<double>& change);
    void feed(Deformer& deformer);
    void build_sweep_region(int sweep);
    void build_restore_zone(int joint);
    /// The restoration's push at each zone's height (from the frames before); the volume added.
    double restore_push(const SkeletonPose& pose, float* positions);
    /// Measures each restored sweep's skin volume and pushes its zone by what closes the
    /// deficit (first order, from the posed skin); the zone's height keeps the sum for the
    /// next frame. Moved vertices go to moved_. @return the volume added
    double restore_trim(const SkeletonPose& pose, float* positions);
    struct RestoreZone;
    /// zone_radial_: the posed push direction of each vertex of sweep s's zone.
    void zone_directions(int s, const SkeletonPose& pose);
    void push_zone(const RestoreZone& z, double height, float* positions, std::vector<int32_t>* moved);
    void build_regions(int joint);
    void rebuild_collision_set();
    /// Removes from `pairs` those of two triangles that already intersect at rest.
    void drop_rest_pairs(std::vector<TrianglePair>& pairs) const;
    void add_automatic_effects(int joint);
    FoldingParams folding_params(int joint) const;
    double protrusion_falloff(int joint) const;

    Rig rig_;
    MeshTopology mesh_;
    std::vector<float> rest_;
    SkinParts parts_;
    std::vector<Joint> joints_;
    std::vector<std::vector<int32_t>> region_triangles_;  // per joint
    std::vector<double> region_edge_;                     // per joint: mean rest edge length
    std::vector<BoneProxy> proxies_;
    std::vector<MuscleBulge> muscles_;

    std::unique_ptr<CollisionBackend> backend_;
    std::unique_ptr<CollisionBackend> checker_;  // no culling, for count_intersections
    bool collision_dirty_ = true;
    std::vector<int32_t> collision_set_, triangle_joint_;
    double relax_radius_ = 0.0;

    VolumeFeedback feedback_ = VolumeFeedback::NextFrame;
    bool restore_ = true;
    std::vector<ClosedRegion> sweep_regions_;  // per sweep; empty for sweeps without elbow/knee
    std::vector<double> sweep_region_rest_;
    /// Per sweep: the skin the restoration pushes out, with its static weights.
    struct RestoreZone {
        std::vector<int32_t> vertex, span;
        std::vector<float> u, dir, weight;  // dir: 2 per vertex (radial direction, ellipse frame)
        double rate = 0.0;                  // volume per unit push: Σ w A (n . r) at rest
        double limit = 0.0;                 // largest push
        double height = 0.0;                // the push (from the frames before)
        int joint = -1;
    };
    std::vector<RestoreZone> restore_zones_;
    std::vector<dvec3> zone_centers_, zone_radial_;
    std::vector<dquat> zone_rotations_;
    int folding_iterations_ = 10;
    std::vector<double> offsets_;
    std::vector<double> applied_;                      // the offsets last handed to a deformer
    std::vector<double> early_change_, total_change_;  // per sweep: after bulge+protrusion, after folding
    const float* current_ = nullptr;                   // the positions of the frame being made
    std::vector<float> swept_, corrected_;             // InFrame: the sweeps before and after I_C
    AnatomyStats stats_;

    // Per-frame scratch.
    VertexEdits edits_;
    Falloff falloff_;
    SkinFolding folding_;
    std::vector<TrianglePair> pairs_, single_part_;
    std::vector<char> rest_intersecting_;  // per triangle: it intersects another at rest
    std::vector<int32_t> moved_, changed_, triangle_stamp_;
    int stamp_ = 0;
    SkeletonPose pose_;
};

}  // namespace sd::anatomy
