#include "deform/deform.h"

#include "bind/serialize.h"
#include "deform/frame_blend.h"
#include "math/flush_denormals.h"
#include "math/smoothstep.h"
#include "rig/bent_joint_trajectory.h"
#include "rig/key_pose.h"
#include "rig/twisted_trajectory.h"

#include <algorithm>
#include <cmath>

#include <glm/gtc/quaternion.hpp>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <array>
#include <cmath>

namespace sd {

double span_thickness(const SweepGeometry& g, int span) {
    const double tilt = 0.5 * (glm::dot(g.normal(span, 0.0), g.tangent(span, 0.0)) +
                               glm::dot(g.normal(span, 1.0), g.tangent(span, 1.0)));
    return g.span_length(span) * std::max(tilt, 0.0);
}

namespace {

using Quat = std::array<float, 4>;  // x, y, z, w

/// Every key rotation of every sweep in float, flattened, with each sweep's first index.
void flatten(const std::vector<std::vector<dquat>>& keys, std::vector<Quat>& out, std::vector<int>& first) {
    out.clear();
    first.clear();
    for (const auto& sweep : keys) {
        first.push_back(static_cast<int>(out.size()));
        for (const dquat& q : sweep)
            out.push_back(
                {static_cast<float>(q.x), static_cast<float>(q.y), static_cast<float>(q.z), static_cast<float>(q.w)});
    }
}

/// Q(u) = (1-u) q0 + u q1 of a span's key rotations, normalised, as the kernel blends them.
Quat blend(const Quat& q0, const Quat& q1, float u) {
    Quat q;
    float n = 0.0f;
    for (int i = 0; i < 4; ++i) {
        q[i] = q0[i] + u * (q1[i] - q0[i]);
        n += q[i] * q[i];
    }
    const float inv = 1.0f / std::sqrt(n);
    for (float& c : q) c *= inv;
    return q;
}

/// conj(Q_rest(u)) of every sweep influence, in the binding's order.
std::vector<std::array<float, 4>> rest_inverse_rotations(const std::vector<std::vector<dquat>>& rest_keys,
                                                         const std::vector<SweepInfluence>& influences) {
    std::vector<Quat> keys;
    std::vector<int> first;
    flatten(rest_keys, keys, first);
    std::vector<std::array<float, 4>> out(influences.size());
    for (size_t i = 0; i < influences.size(); ++i) {
        const SweepInfluence& in = influences[i];
        const int k = first[in.sweep] + in.span;
        const Quat q = blend(keys[k], keys[k + 1], in.u);
        out[i] = {-q[0], -q[1], -q[2], q[3]};
    }
    return out;
}

/// How far the volume control may be trusted on a sweep in a pose (issue 15), from 1 (fully)
/// to 0 (not at all). The integral is the volume of a sweep that does not pass through itself.
/// A sweep crumpled by an extreme pose (a spine bent far at every joint, an elbow folded with
/// a twist) breaks that in two ways, each of which made the controller blow single keys up to
/// 4–10x their half-axes, a body in shards a metre across:
///  * it folds back (<N, C'> < 0 over part of it): the integral subtracts that part, and the
///    joint keys there add little or even negative volume, so the controller's step
///    (V_target − V) / |∇V|² explodes;
///  * its cross-sections turn nearly edge-on to the curve and overlap (the integral keeps a
///    small share of the rest volume), and the few joint keys are grown to make up 30–50 %.
/// So the trust falls linearly from 1 to 0 as the folded share of the integrand (rest
/// half-axes, |integrand|) goes from 0.5 % to 2 %, and as the integral over its rest value
/// goes from 80 % to 65 %; continuous in the pose. On the MakeHuman clips of the shared data
/// (1756 frames) no sweep folds by more than 0.4 % or keeps less than 85 %: the trust is 1,
/// the result unchanged; random poses with every joint at up to ±170° fold a sweep by up to
/// 13 % or keep as little as 51 %.
double control_trust(const Sweep& s, const VolumeQuadrature& q, const std::vector<double>& density,
                     const VolumeForm& form) {
    constexpr double kFoldFull = 0.005, kFoldNone = 0.02, kKeptFull = 0.8, kKeptNone = 0.65;
    const std::vector<double>& a = s.rest_half_axes.a;
    const std::vector<double>& b = s.rest_half_axes.b;
    const int K = q.key_count;
    double folded = 0.0, total = 0.0;
    for (int i = 0; i < q.node_count(); ++i) {
        const double* phi = &q.phi[static_cast<size_t>(i) * K];
        double ai = 0.0, bi = 0.0;
        for (int k = 0; k < K; ++k) {
            ai += a[k] * phi[k];
            bi += b[k] * phi[k];
        }
        const double x = q.weight[i] * ai * bi * density[i];
        total += std::abs(x);
        if (x < 0.0) folded -= x;
    }
    const double fold = total > 0.0 ? folded / total : 0.0;
    const double kept = s.corrected_rest_volume > 0.0 ? form.volume(a.data(), b.data()) / s.corrected_rest_volume : 1.0;
    return std::clamp((kFoldNone - fold) / (kFoldNone - kFoldFull), 0.0, 1.0) *
           std::clamp((kept - kKeptNone) / (kKeptFull - kKeptNone), 0.0, 1.0);
}

/// A thick chain's folding (sweep_folding) from which its volume hold, and the share of the
/// volume it gives back inside the bend, fade, and over how much they fade out (smoothstep).
constexpr double kFoldingFrom = 0.55, kFoldingWidth = 0.2;

/// The bend across a limb key's neighbours from which its growth is held off the fold in full.
constexpr double kFullHoldBend = 0.25 * 3.14159265358979323846;  // 45 degrees

/// How the sweep bends at key k: the turn from the previous to the next key since rest, seen
/// in the key's posed axes.
struct BendAtKey {
    dmat3 frame{1.0};
    dvec3 turn{0.0};  ///< sin(angle / 2) times the unit axis, the rotation's w made >= 0

    /// Of the key's area change, the share its first half-axis (a) takes: all of it on the
    /// axis nearest the axis the sweep bends about, so a trunk bent forward fills out at its
    /// flanks, not along its spine; half each where the sweep twists rather than bends.
    /// Continuous in the pose.
    double axis_share_a() const {
        const double ca = glm::dot(turn, frame[0]), cb = glm::dot(turn, frame[1]);
        const double across = ca * ca + cb * cb, all = glm::dot(turn, turn);
        if (!(across > 1e-12)) return 0.5;
        // how much of the turn is a bend (1) rather than a twist about the sweep (0)
        const double bend = across / all;
        return 0.5 + bend * (ca * ca / across - 0.5);
    }
    /// Where the key's normal turns, along its half-axes: towards the inside of the bend, of
    /// length sin(bend / 2) for a pure bend, zero where the sweep only twists.
    dvec2 towards_inside() const {
        const dvec3 d = glm::cross(turn, frame[2]);  // a turn about A takes the normal N towards A x N
        return dvec2(glm::dot(d, frame[0]), glm::dot(d, frame[1]));
    }
    /// The inside of the bend (the direction the sweep turns towards) in the key's plane, as
    /// components along its half-axes: a unit vector, or zero where the sweep only twists.
    dvec2 inside() const {
        const dvec2 in = towards_inside();
        const double len = std::hypot(in.x, in.y);
        return len > 1e-9 ? in / len : dvec2(0.0);
    }
    /// The key's move that keeps its outside edge in place as it grows by (grow_a, grow_b).
    dvec3 holding_outside(double grow_a, double grow_b) const {
        const dvec2 in = inside();
        return grow_a * in.x * frame[0] + grow_b * in.y * frame[1];
    }
    /// 1 where the keys either side differ by a bend of `full` or more, falling linearly in
    /// sin(bend / 2) to 0 at rest, where inside() may point any way in the key's plane.
    double bent_share(double full) const {
        const dvec2 in = towards_inside();
        return std::min(1.0, std::hypot(in.x, in.y) / std::sin(0.5 * full));
    }
};

/// The posed center of key k (the trajectory at its knot).
dvec3 key_center(const SweepGeometry& g, int k) {
    return k < g.span_count() ? g.center(k, 0.0) : g.center(g.span_count() - 1, 1.0);
}

BendAtKey bend_at_key(const Sweep& s, const SweepGeometry& posed, int k) {
    const auto& q = posed.key_rotations();
    const auto& r = s.rest_geometry.key_rotations();
    const int k0 = std::max(0, k - 1), k1 = std::min(s.key_count() - 1, k + 1);
    dquat turn = (q[k1] * glm::conjugate(r[k1])) * glm::conjugate(q[k0] * glm::conjugate(r[k0]));
    if (turn.w < 0.0) turn = -turn;
    BendAtKey bend;
    bend.frame = glm::mat3_cast(glm::normalize(q[k]));
    bend.turn = dvec3(turn.x, turn.y, turn.z);
    return bend;
}

/// How sharply a sweep bends for its depth: the largest, over its inner keys, of the key's
/// inside half-axis times the sweep's curvature there (the turn between its neighbours over the
/// distance between them). At 1 the planes cross on that key's inside edge. MakeHuman's trunk
/// bent forward 45 degrees over its three spine bones reaches 0.52; bent 60 degrees, 0.77.
double sweep_folding(const Sweep& s, const SweepGeometry& posed, const std::vector<double>& a,
                     const std::vector<double>& b) {
    double folding = 0.0;
    for (int k = 1; k + 1 < s.key_count(); ++k) {
        const BendAtKey bend = bend_at_key(s, posed, k);
        const dvec2 in = bend.inside();
        const double chord = glm::length(key_center(posed, k + 1) - key_center(posed, k - 1));
        const double turned = 2.0 * std::asin(std::min(1.0, glm::length(bend.towards_inside())));
        if (chord > 0.0) folding = std::max(folding, std::hypot(a[k] * in.x, b[k] * in.y) * turned / chord);
    }
    return folding;
}

}  // namespace

double folding_hold(const Sweep& s, const SweepGeometry& posed, const std::vector<double>& a,
                    const std::vector<double>& b) {
    return 1.0 - smoothstep01((sweep_folding(s, posed, a, b) - kFoldingFrom) / kFoldingWidth);
}

bool restore_local_volume(const Sweep& s, const SweepGeometry& posed, double strength, double hold,
                          std::vector<double>& a, std::vector<double>& b, std::vector<dvec3>& shifts) {
    // A thick chain bent by blended transforms is compressed on the inside, so its sweep is
    // shorter than at rest where it bends; each key's cross-section grows by what its two
    // spans lost (mean), so the volume comes back where it was lost, not at a few joint keys
    // (which made a ledge across a bent torso). Limbs keep the paper's controller alone: on
    // them this restoration halved the elbow's r_max but spread an edit's volume change along
    // the whole arm (tests/blender/test_key_edit.py).
    const int K = s.key_count();
    shifts.assign(K, dvec3(0.0));
    std::vector<double> ratio(K - 1);
    for (int span = 0; span < K - 1; ++span) {
        const double rest = span_thickness(s.rest_geometry, span);
        const double pose = span_thickness(posed, span);
        ratio[span] = rest > 0.0 && pose > 0.0 ? std::clamp(rest / pose, 0.5, 2.0) : 1.0;
    }
    std::vector<double> lost(K);
    for (int k = 0; k < K; ++k) {
        double r = 0.0;
        int n = 0;
        if (k > 0) r += ratio[k - 1], ++n;
        if (k < K - 1) r += ratio[k], ++n;
        lost[k] = r / n;
    }
    // Spread along the sweep: a Gaussian in rest arc length, kSpread of the sweep's length wide,
    // each key weighted by the length it stands for (keys crowd where the trunk bends). Each key
    // grown by its own spans alone raised ripples across the flanks; smoothed over two keys
    // each side (four centimetres) it came back as a belt around the waist, 2.4 cm proud at
    // the flanks (MakeHuman bent 45 degrees: skin 1.19x its rest distance from the spine,
    // Preserve Volume 1.07); spread over the trunk it is 1.11 with the same volume. Narrower
    // (0.3) it kept more of the volume but left a faint band where the belt was; wider (0.6, 1)
    // left the same band and lost more volume.
    constexpr double kSpread = 0.43;
    const std::vector<double>& along = s.rest_geometry.knots();  // rest arc length (chord) at each key
    std::vector<double> length(K);
    for (int k = 0; k < K; ++k) length[k] = 0.5 * (along[std::min(k + 1, K - 1)] - along[std::max(k - 1, 0)]);
    const double spread = kSpread * along[K - 1];
    // The share of the growth given to the inside of the bend, the outside held in place; the
    // rest goes along the bend's axis, in place. Grown about its centre, which lies in front
    // of the spine, a trunk bent forward pushed its lower back out from the spine (MakeHuman:
    // 1.54x its rest distance, Preserve Volume 1.07); grown along the bend's axis alone its
    // flanks rose in a band where it bends; all inside, the belly folded into a notch. Half,
    // since the growth is spread (0.35 before: r 1.116 against 1.109 with it spread, 0.7 1.13).
    constexpr double kInside = 0.5;
    // Where the sweep bends sharply for the body's depth (folding_hold), none goes inside:
    // growth there fills a fold that is already closing (with the hold fading over the same
    // range, MakeHuman bent 52.5 degrees: largest crease of the trunk 57 degrees with the share
    // kept, 52 faded). One share for the whole sweep, from its sharpest key (a share per key
    // rippled the belly).
    const double inside = kInside * hold;
    bool moved = false;
    for (int k = 0; k < K; ++k) {
        double r = 0.0, w = 0.0;
        for (int j = 0; j < K; ++j) {
            const double x = spread > 0.0 ? (along[j] - along[k]) / spread : 0.0;
            const double wj = length[j] * std::exp(-0.5 * x * x);
            r += wj * lost[j], w += wj;
        }
        r = w > 0.0 ? r / w : 1.0;
        // Within rounding of the rest length (the rest pose) nothing changes, bit for bit.
        if (std::abs(r - 1.0) < 1e-9) continue;
        const double area = 1.0 + strength * (r - 1.0);
        const BendAtKey bend = bend_at_key(s, posed, k);
        const dvec2 in = bend.inside();
        const double in2 = in.x * in.x + in.y * in.y;
        const double inside_a = in2 > 1e-12 ? in.x * in.x / in2 : 0.5;
        const double axis_a = bend.axis_share_a();
        shifts[k] = bend.holding_outside(a[k] * (std::pow(area, inside * inside_a) - 1.0),
                                         b[k] * (std::pow(area, inside * (1.0 - inside_a)) - 1.0));
        a[k] *= std::pow(area, inside * inside_a + (1.0 - inside) * axis_a);
        b[k] *= std::pow(area, inside * (1.0 - inside_a) + (1.0 - inside) * (1.0 - axis_a));
        moved = moved || shifts[k] != dvec3(0.0);
    }
    return moved;
}

void hold_growth_off_the_fold(const Sweep& s, const SweepGeometry& posed, const std::vector<double>& a_before,
                              const std::vector<double>& b_before, const std::vector<double>& a,
                              const std::vector<double>& b, std::vector<dvec3>& centers) {
    // The controller grows a limb's joint keys and their neighbours about their centres, so
    // half of a key's growth across went into the fold inside the bend, where the skin already
    // meets itself. Moved outwards by half its growth there, a key's inside edge moves half as
    // far into the fold (a quarter of its growth across; the outside takes three quarters):
    // MakeHuman's elbow at 150 degrees 68 -> 65 intersecting pairs (13.4K, Preserve Volume 65),
    // 142 -> 133 (53.5K, 136), region volume -0.97 -> +0.02 %; its skin-to-bone ratio on the
    // outside 1.14 -> 1.20 (Preserve Volume 1.21). Moved by all of it, the outside rose past
    // Preserve Volume's. A key the controller shrinks (the anatomical effects' volume taken out
    // of its target) shrinks about its centre: held too, CesiumMan's elbow with the effects
    // lost 56 % of its region's volume at 120 degrees instead of 19 %. Below a 45 degree bend
    // the hold fades (BendAtKey::bent_share; the trunk's restoration does not fade: its keys
    // are a few degrees apart): MakeHuman's elbow at 120 degrees 41 -> 39
    // pairs (Preserve Volume 44), its elbow at 90 degrees r_max 1.101 -> 1.093.
    for (int k = 0; k < s.key_count(); ++k) {
        if (a[k] == a_before[k] && b[k] == b_before[k]) continue;
        const BendAtKey bend = bend_at_key(s, posed, k);
        centers[k] -= 0.5 * bend.bent_share(kFullHoldBend) *
                      bend.holding_outside(std::max(0.0, a[k] - a_before[k]), std::max(0.0, b[k] - b_before[k]));
    }
}

Deformer::Deformer(Rig rig, Binding binding) : rig_(std::move(rig)), binding_(std::move(binding)) {
    binding_.check_structure();
    binding_.check_against(rig_);
    int base = 0;
    for (const Sweep& s : rig_.sweeps) {
        span_base_.push_back(base);
        base += s.span_count();
    }
    half_spans_.resize(2 * static_cast<size_t>(base));
    volume_offsets_.assign(rig_.sweeps.size(), 0.0);
    volume_before.assign(rig_.sweeps.size(), 0.0);
    volume_after.assign(rig_.sweeps.size(), 0.0);
    volume_iterations.assign(rig_.sweeps.size(), 0);
    trunk_need_.assign(rig_.sweeps.size(), 0.0);
    // The frames the binding was made in: the uncorrected sweeps at rest.
    SkeletonPose rest;
    rest.set_rest(rig_.skeleton);
    std::vector<dvec3> centers;
    std::vector<dquat> rotations;
    for (const Sweep& s : rig_.sweeps) {
        pose_keys(s, rest, centers, rotations);
        rest_key_rotations_.push_back(SweepGeometry(centers, rotations).key_rotations());
    }
    key_rotations_ = rest_key_rotations_;
    rest_inverse_ = rest_inverse_rotations(rest_key_rotations_, binding_.sweep_influences);
    // Every influence joins its vertex as a frame: where skin passes from one sweep to another
    // or to a bone it is blended as rigid frames, so a filled part (the buttock between the
    // trunk and a leg, the base of the neck, the wrist, the armpit) keeps its volume as it
    // turns; as points it cut the chord (the hip lost 4 % of its volume at 90 degrees of
    // flexion). The armpit's web joined its arm's influences partly as points until the
    // fourteenth session: seen from the side, the raised arm's skin then met the chest along
    // a horizontal line, where the chord of the points gave way to the arc of the frames
    // (docs/quality.md).
    kernel_ = SweepKernel(binding_, span_base_, rest_inverse_);
}

void Deformer::set_volume_preservation(bool enabled, double strength) {
    const std::lock_guard<std::recursive_mutex> guard(mutex_);
    if (!(strength >= 0.0 && strength <= 1.0)) throw InvalidInput("volume preservation strength must be in [0, 1]");
    volume_enabled_ = enabled;
    volume_strength_ = strength;
}

void Deformer::set_volume_offsets(const std::vector<double>& offsets) {
    const std::lock_guard<std::recursive_mutex> guard(mutex_);
    if (offsets.size() != rig_.sweeps.size()) throw InvalidInput("one volume offset per sweep is needed");
    for (size_t s = 0; s < offsets.size(); ++s) {
        // The target V0 - offset must stay a plausible volume: 10 % .. 10x the rest volume.
        const double v0 = rig_.sweeps[s].rest_volume;
        if (!(offsets[s] <= 0.9 * v0 && offsets[s] >= -9.0 * v0))
            throw InvalidInput("volume offset of sweep " + std::to_string(s) +
                               " must lie in [-9, 0.9] x its rest volume (" + std::to_string(v0) + ")");
    }
    volume_offsets_ = offsets;
}

void Deformer::set_joint_volumes(std::vector<JointVolumeTable> tables) {
    const std::lock_guard<std::recursive_mutex> guard(mutex_);
    const int S = static_cast<int>(rig_.sweeps.size()), B = rig_.skeleton.bone_count();
    for (const JointVolumeTable& t : tables) {
        if (t.sweep < 0 || t.sweep >= S || t.parent < 0 || t.parent >= B || t.child < 0 || t.child >= B || t.key < 0 ||
            t.key >= rig_.sweeps[t.sweep].key_count())
            throw InvalidInput("a joint volume table names a sweep, key or bone the rig does not have");
        if (!t.added.empty() && t.added.size() != JointVolumeTable::kSwings * JointVolumeTable::kDirections)
            throw InvalidInput("a joint volume table has the wrong size");
        const double v0 = rig_.sweeps[t.sweep].rest_volume;
        for (double v : t.added)
            if (!(std::abs(v) <= v0)) throw InvalidInput("a joint volume table adds more than its sweep's rest volume");
        if (!(t.most_added >= 0.0 && t.most_added <= v0))
            throw InvalidInput("a joint volume table's bound must lie within its sweep's rest volume");
    }
    joint_volumes_ = std::move(tables);
}

void Deformer::set_skin_triangles(const std::vector<int32_t>& triangles) {
    const std::lock_guard<std::recursive_mutex> guard(mutex_);
    trunk_fill_ = triangles.empty() ? TrunkFill() : TrunkFill(rig_, binding_, triangles);
    level_source_.reset();
    fill_levels.assign(trunk_fill_.empty() ? 0 : 1, 1.0);
}

void Deformer::fill_trunk_as(const Deformer& source) {
    const std::lock_guard<std::recursive_mutex> guard(mutex_);
    std::unique_ptr<Deformer> copy;
    TrunkFill own;
    {
        const auto lock = source.lock();
        if (rig_fingerprint(rig_) != rig_fingerprint(source.rig_))
            throw InvalidInput("the trunk is filled as another deformer's of the same rig only");
        if (!source.trunk_fill_.empty()) {
            // The source's trunk skin and the corners of its triangles, a mesh of their own.
            const std::vector<int32_t> kept = source.trunk_fill_.vertices_read();
            std::vector<int32_t> index(source.vertex_count(), -1);
            for (size_t i = 0; i < kept.size(); ++i) index[kept[i]] = static_cast<int32_t>(i);
            std::vector<int32_t> triangles = source.trunk_fill_.triangles_read();
            for (int32_t& t : triangles) t = index[t];
            copy = std::make_unique<Deformer>(source.rig_, binding_of_vertices(source.binding_, kept));
            copy->set_skin_triangles(triangles);
            own = TrunkFill(rig_, binding_, {});  // its own skin: raised at the copy's levels
        }
    }
    trunk_fill_ = std::move(own);
    level_source_ = std::move(copy);
    level_scratch_.assign(level_source_ ? 3 * static_cast<size_t>(level_source_->vertex_count()) : 0, 0.0f);
}

void Deformer::prepare_sweeps(const SkeletonPose& pose) {
    // The sweeps are independent (each writes its own keys' rotations, volumes and half-spans):
    // in parallel, since this is the frame's one serial stretch before the kernel (34 us of a
    // 450 us frame of MakeHuman's 80K vertices on two threads in sweep_bench).
    tbb::parallel_for(size_t(0), rig_.sweeps.size(), [&](size_t si) {
        const FlushDenormals flush;
        std::vector<dvec3> centers;
        std::vector<dquat> rotations;
        const Sweep& s = rig_.sweeps[si];
        pose_keys(s, pose, centers, rotations);
        // The artist's corrections (Sect. 4.2) move, turn and scale the placed keys; scaled
        // half-axes are where the volume controller starts from.
        std::vector<double> a = s.rest_half_axes.a, b = s.rest_half_axes.b;
        if (s.has_corrections) correct_keys(s, pose, centers, rotations, a, b);
        SweepGeometry g = posed_geometry(s, centers, rotations);
        key_rotations_[si] = g.key_rotations();

        // Volume control (Sect. 4.4) on the key half-axes, as far as it can be trusted in
        // this pose (control_trust: none on a crumpled sweep).
        std::vector<double> density = volume_density(s.quadrature, g);
        VolumeForm form(s.quadrature, density);
        double strength = volume_enabled_ && volume_strength_ > 0.0
                              ? volume_strength_ * control_trust(s, s.quadrature, density, form)
                              : 0.0;
        double hold = 1.0;
        // Where a thick chain bends sharply for its depth, none of its restored volume goes to
        // the inside of the bend (folding_hold, restore_local_volume): it filled a fold that
        // was already closing. The volume itself is kept: faded with the inside share, when
        // the restoration still sat where the trunk lost it, it came back as a belt across the
        // belly (MakeHuman bent 60 degrees: its skin 1.44x its rest distance from the spine,
        // linear blend skinning 1.12); spread along the trunk, 1.21 with the volume kept (the
        // 3ds Max Biped body bent 45 degrees over two bones: region -10.5 -> -0.4 %).
        if (strength > 0.0 && s.bends_smoothly) hold = folding_hold(s, g, a, b);
        if (strength > 0.0) {
            const double before = form.volume(a.data(), b.data());
            // V0 of the corrected rest pose, plus what the artist's scaling adds in this pose
            // (kept: the controller must not undo an edit).
            double edited = 0.0;
            if (s.has_corrections && (a != s.rest_half_axes.a || b != s.rest_half_axes.b))
                edited = before - form.volume(s.rest_half_axes.a.data(), s.rest_half_axes.b.data());
            double target = before + strength * (s.corrected_rest_volume + edited - volume_offsets_[si] - before);
            // A trunk whose skin is filled (trunk_fill.h) keeps its sections: its skin is given
            // what the restoration below would have put back (and the controller after it).
            const bool filled = s.bends_smoothly && trunk_fill_.fills(static_cast<int>(si));
            double restored = 0.0;
            if (filled) {
                std::vector<double> ra = a, rb = b;
                std::vector<dvec3> shifts, rc = centers;
                restore_local_volume(s, g, strength, hold, ra, rb, shifts);
                for (int k = 0; k < s.key_count(); ++k) rc[k] += shifts[k];
                const SweepGeometry rg = posed_geometry(s, rc, rotations);
                restored = VolumeForm(s.quadrature, volume_density(s.quadrature, rg)).volume(ra.data(), rb.data());
            }
            // First where it was lost, key by key; the controller corrects what is left.
            if (s.bends_smoothly && !filled) {
                std::vector<dvec3> shifts;
                if (restore_local_volume(s, g, strength, hold, a, b, shifts)) {  // keys moved: a new sweep
                    for (int k = 0; k < s.key_count(); ++k) centers[k] += shifts[k];
                    g = posed_geometry(s, centers, rotations);
                    density = volume_density(s.quadrature, g);
                    form = VolumeForm(s.quadrature, density);
                }
            }
            const std::vector<double> a_before = a, b_before = b;
            // The restoration's growth stands: spread past the bend it lifts the sweep's integral
            // above its rest volume while the mesh, compressed along the fold (a loss the
            // integral does not see), is still short of its own; shrunk back to the integral's
            // target, MakeHuman's trunk bent 45 degrees lost 2 % of its volume instead of 0.8
            // (filled, 1.3 % instead of 0.3).
            if (s.bends_smoothly) target = std::max({target, form.volume(a.data(), b.data()), restored});
            // Less the controller's own tolerance (control_volume's), so that near the rest pose,
            // whose matrices come back from a host with rounding, nothing moves, and the fill
            // grows from nothing as the bend does.
            trunk_need_[si] = filled ? std::max(0.0, target - before - kVolumeTolerance * target) : 0.0;
            if (filled) {  // (after: with what its skin is given)
                volume_before[si] = before;
                volume_after[si] = before + trunk_need_[si];
                volume_iterations[si] = 0;
            }
            VolumeControlResult r = filled ? VolumeControlResult{} : control_volume(form, s.control_keys, target, a, b);
            // Then what the mesh loses at each joint that its table says (joint_volume.h), put
            // where it is lost: at the joint's key and its neighbours. (Through the controller's
            // own keys, a hip's loss went to the knee: the demo's thigh swelled by 5 %.)
            for (const JointVolumeTable& t : joint_volumes_) {
                const double add =
                    t.sweep == static_cast<int>(si) ? strength * t.added_volume(pose, s.motions[t.key].lowering) : 0.0;
                if (!(add > 0.0)) continue;
                r.after = control_volume(form, t.keys(s.key_count()), r.after + add, a, b).after;
            }
            if (!s.bends_smoothly && (a != a_before || b != b_before)) {
                hold_growth_off_the_fold(s, g, a_before, b_before, a, b, centers);
                g = posed_geometry(s, centers, rotations);
            }
            if (!filled) {
                volume_before[si] = before;
                volume_after[si] = r.after;
                volume_iterations[si] = r.iterations;
            }
        } else {
            trunk_need_[si] = 0.0;
            volume_before[si] = volume_after[si] = form.volume(a.data(), b.data());
            volume_iterations[si] = 0;
        }

        const int K = s.key_count();
        std::vector<double> da(K), db(K);
        for (int k = 0; k < K; ++k) {
            da[k] = a[k] - s.rest_half_axes.a[k];
            db[k] = b[k] - s.rest_half_axes.b[k];
        }
        const auto& q = g.key_rotations();
        const std::vector<std::array<CubicSpan, 2>> twisted = twisted_trajectory(s, g);
        for (int span = 0; span < s.span_count(); ++span)
            for (int half = 0; half < 2; ++half) {
                HalfSpanKernel& kern = half_spans_[2 * static_cast<size_t>(span_base_[si] + span) + half];
                const CubicSpan& c = twisted.empty() ? g.center_span(span) : twisted[span][half];
                for (int i = 0; i < 4; ++i)
                    for (int j = 0; j < 3; ++j) kern.c[i][j] = static_cast<float>(c.c[i][j]);
                const dquat &q0 = q[span], &q1 = q[span + 1];
                const double v0[4] = {q0.x, q0.y, q0.z, q0.w}, v1[4] = {q1.x, q1.y, q1.z, q1.w};
                for (int i = 0; i < 4; ++i) {
                    kern.q0[i] = static_cast<float>(v0[i]);
                    kern.q1[i] = static_cast<float>(v1[i]);
                }
                for (int r = 0; r < 3; ++r) {
                    double sa = 0.0, sb = 0.0;
                    for (int k = 0; k < K; ++k) {
                        const double phi = s.rest_half_axes.basis.coefficients(span, half, k)[r];
                        sa += da[k] * phi;
                        sb += db[k] * phi;
                    }
                    kern.da[r] = static_cast<float>(sa);
                    kern.db[r] = static_cast<float>(sb);
                }
            }
    });
}

void Deformer::deform(const float* pose, float* out) {
    const std::lock_guard<std::recursive_mutex> guard(mutex_);
    const FlushDenormals flush;  // and in each of the kernel's parallel loops (flush_denormals.h)
    // Isolated: while this thread waits for the kernel's tasks it must not pick up an outer
    // task that could enter this deformer again (the lock is recursive, the scratch is not).
    tbb::this_task_arena::isolate([&] {
        pose_.set(rig_.skeleton, pose);
        prepare_sweeps(pose_);
        bones_ = bone_affines(pose_);
        bone_frames_.resize(bones_.size());
        for (size_t b = 0; b < bones_.size(); ++b) bone_frames_[b] = bone_frame(bones_[b].m);
        const bool fill = std::any_of(trunk_need_.begin(), trunk_need_.end(), [](double v) { return v > 0.0; });
        if (!fill) {
            kernel_.run(half_spans_.data(), bones_.data(), bone_frames_.data(), binding_, out, maps_);
            fill_levels.assign(fill_levels.size(), 1.0);
            return;
        }
        // The fill reads every vertex of the trunk before it moves any: the blocks' callbacks
        // (sd_deform_frame's check and sums) come after it.
        SweepKernel::LocalMaps maps = maps_;
        maps.after_block = nullptr;
        kernel_.run(half_spans_.data(), bones_.data(), bone_frames_.data(), binding_, out, maps);
        if (level_source_) {  // at the levels the source's skin reaches in this pose
            level_source_->set_volume_preservation(volume_enabled_, volume_strength_);
            level_source_->set_volume_offsets(volume_offsets_);
            level_source_->deform(pose, level_scratch_.data());
            fill_levels = level_source_->fill_levels;
            trunk_fill_.apply_levels(pose_, fill_levels, out);
        } else {
            fill_levels = trunk_fill_.apply(pose_, trunk_need_, out);
        }
        if (maps_.after_block) {
            const int blocks = (binding_.vertex_count() + SweepKernel::kVertexBlock - 1) / SweepKernel::kVertexBlock;
            tbb::parallel_for(0, blocks, [&](int block) {
                const FlushDenormals block_flush;
                (*maps_.after_block)(block);
            });
        }
    });
}

void Deformer::deform_frames(const float* pose, float* out, float* frames) {
    SweepKernel::LocalMaps maps;
    maps.jacobians = frames;
    deform_with(pose, out, maps);
}

void Deformer::deform_displaced(const float* pose, int32_t count, const int32_t* moved, const float* displacements,
                                float* out, float* turned) {
    SweepKernel::LocalMaps maps;
    maps.moved_count = count;
    maps.moved = moved;
    maps.displacements = displacements;
    maps.turned = turned;
    deform_with(pose, out, maps);
}

void Deformer::deform_in_blocks(const float* pose, int32_t count, const int32_t* moved, const float* displacements,
                                float* out, float* turned, const std::function<void(int32_t block)>& after_block) {
    SweepKernel::LocalMaps maps;
    maps.moved_count = count;
    maps.moved = moved;
    maps.displacements = displacements;
    maps.turned = turned;
    maps.after_block = &after_block;
    deform_with(pose, out, maps);
}

void Deformer::deform_with(const float* pose, float* out, const SweepKernel::LocalMaps& maps) {
    const std::lock_guard<std::recursive_mutex> guard(mutex_);
    maps_ = maps;
    try {
        deform(pose, out);
    } catch (...) {
        maps_ = {};
        throw;
    }
    maps_ = {};
}

}  // namespace sd
