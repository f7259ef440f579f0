#include "fit/key_fit.h"

#include "geometry/cross_section.h"
#include "fit/ellipse_fit.h"
#include "fit/twist_spread.h"
#include "rig/rig.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <cstdio>

namespace sd::fit {

namespace {

/// Where a key goes and how it follows the skeleton, before any fitting.
struct KeySpec {
    std::string role;
    dvec3 point{0.0};  ///< on the bone: the joint, or a point of the link
    dvec3 normal{0.0};
    int bone = -1, joint_parent = -1;
    double twist = 0.5;
    dvec3 twist_direction{0.0};  ///< KeyEllipse::twist_direction: zero, or a unit vector
    bool fixed_center = true;    ///< joint keys: center at the joint
    double link_length = 0.0;    ///< scale for tolerances
};

/// A fitted cross-section, in space.
struct Fitted {
    bool ok = false;
    dvec3 center{0.0}, axis{0.0};
    double a = 0.0, b = 0.0;
};

std::string fmt(double x) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "%.3g", x);
    return buf;
}

dvec3 unit_or(const dvec3& v, const dvec3& fallback) {
    const double len = glm::length(v);
    return len > 0.0 ? v / len : fallback;
}

double angle_between(const dvec3& a, const dvec3& b) { return std::acos(std::clamp(glm::dot(a, b), -1.0, 1.0)); }

/// The direction of the chain whose sweep starts at `bone`, joint to joint (its first link's
/// head to the next joint); the bone's own head to tail when no chain starts there or the
/// joints coincide.
dvec3 first_link_direction(const Skeleton& s, const ChainSet& set, int bone) {
    for (const Chain& c : set.chains) {
        const std::vector<int> links = c.links();
        if (links.empty() || links[0] != bone) continue;
        const dvec3 to = c.joints(s)[1];
        if (glm::length(to - s.heads[bone]) > 1e-4 * set.size) return to - s.heads[bone];
    }
    return s.tails[bone] - s.heads[bone];
}

std::vector<KeySpec> key_specs(const Skeleton& s, const ChainSet& set, const Chain& ch, const KeyOptions& opt) {
    // A segment cut into several bones is one link, riding its first bone.
    const std::vector<int> links = ch.links();
    const int m = static_cast<int>(links.size());
    const std::vector<dvec3> joint = ch.joints(s);
    std::vector<dvec3> dir(m);
    std::vector<double> len(m);
    for (int i = 0; i < m; ++i) {
        // Joint to joint: what the sweep spans, also for disconnected bones.
        len[i] = glm::length(joint[i + 1] - joint[i]);
        if (len[i] > 1e-4 * set.size) {
            dir[i] = (joint[i + 1] - joint[i]) / len[i];
        } else {  // a joint on top of the next: use the bone itself
            dir[i] = unit_or(s.tails[links[i]] - s.heads[links[i]], dvec3(0, 0, 1));
            len[i] = glm::length(s.tails[links[i]] - s.heads[links[i]]);
        }
    }
    const auto bisector = [&](const dvec3& upper, const dvec3& lower, double max_angle) {
        if (!opt.bisect_bent_joints || angle_between(upper, lower) > max_angle) return lower;
        return glm::normalize(upper + lower);
    };
    const auto is_link = [&](int b) {
        for (const Chain& c : set.chains)
            if (std::find(c.bones.begin(), c.bones.end(), b) != c.bones.end()) return true;
        return false;
    };

    std::vector<KeySpec> specs;
    // Start: the torso's rides its first link; a limb's is the joint with its clavicle,
    // hip bone or the torso bone it hangs from.
    KeySpec start;
    start.role = "start";
    start.point = joint[0];
    start.bone = links[0];
    start.joint_parent = ch.joint_parent;
    start.fixed_center = true;
    start.link_length = len[0];
    start.normal = dir[0];
    if (ch.joint_parent >= 0) {
        const int p = ch.joint_parent;
        dvec3 pd = joint[0] - s.heads[p];
        if (!(glm::length(pd) > 1e-4 * set.size)) pd = s.tails[p] - s.heads[p];
        // Bisect only gentle starts (a clavicle, the spine into the neck); a leg leaving the
        // pelvis or an arm hanging from the chest is cut orthogonal to itself.
        start.normal = bisector(unit_or(pd, dir[0]), dir[0], glm::radians(60.0));
    }
    // The neck's first key takes the neck's whole twist against the chest (its swing stays
    // half): the twist then passes from chest to neck across the skin both sweeps share,
    // blended as frames, as Preserve Volume turns it. With half of it at the key and the rest
    // one short span up, the neck sheared there: skineval neck_twist_60 crease p99.9 43° on
    // CesiumMan (DQS 23°), 37° on the 4.7K character (49°), 23° on the 13K MakeHuman (18°).
    // The twist is the neck's turn about its own line (joint to joint), not about the key's
    // bisecting normal: see the torso's end key below.
    if (ch.kind == ChainKind::Neck) {
        start.twist = 1.0;
        start.twist_direction = dir[0];
    }
    specs.push_back(start);
    for (int i = 0; i < m; ++i) {
        if (i > 0) {
            KeySpec j;
            j.role = "joint";
            j.point = joint[i];
            j.bone = links[i];
            j.joint_parent = links[i - 1];
            j.normal = bisector(dir[i - 1], dir[i], glm::radians(120.0));
            j.link_length = std::min(len[i - 1], len[i]);
            specs.push_back(j);
        }
        // A forearm's or shin's link, which starts at an interior joint (elbow, knee), gets one
        // key more: with keys at thirds the joint's turn was spread over a third of the shin,
        // the calf's back near the knee followed a frame turned half as far as the shin and
        // folded into the thigh (its section 0.81 of rest at 135 degrees). The upper links keep
        // theirs: one more on the thigh crossed the skin at the hip's crease.
        const bool limb = ch.kind == ChainKind::Arm || ch.kind == ChainKind::Leg;
        const int count = opt.keys_per_link + (limb && i > 0 ? opt.extra_keys_after_joint : 0);
        for (int k = 1; k <= count; ++k) {
            KeySpec in;
            in.role = "intermediate";
            in.point = joint[i] + (static_cast<double>(k) / (count + 1)) * (joint[i + 1] - joint[i]);
            in.normal = dir[i];
            in.bone = links[i];
            in.fixed_center = false;
            in.link_length = len[i];
            specs.push_back(in);
        }
    }
    KeySpec end;
    end.role = "end";
    end.point = joint[m];
    end.link_length = len[m - 1];
    end.normal = dir[m - 1];
    if (ch.end_bone >= 0) {
        end.bone = ch.end_bone;
        end.joint_parent = links.back();
        if (is_link(ch.end_bone)) {
            // The torso's end is the neck's start: the same joint, bisected when gentle. The
            // neck's direction is joint to joint, as the neck's own keys take it: a glTF rig's
            // bones all point one way whatever the body does (CesiumMan's neck along the body's
            // side), and a normal from the bone's tail turned the key's plane sideways.
            const dvec3 nd = unit_or(first_link_direction(s, set, ch.end_bone), dir[m - 1]);
            end.normal = bisector(dir[m - 1], nd, glm::radians(60.0));
            // The neck's twist is the neck's start key's alone (above), and it is a turn about
            // the neck's own line: the torso's end takes none of it and only half the neck's
            // swing. So a neck turned about itself turns the skin the two sweeps share about
            // that line alone, every influence a turn about it, and the chest below stays put,
            // as under Preserve Volume. With half the twist taken about the key's normal (6-18
            // degrees off the neck), the chest's top span turned about a tilted axis and the
            // skin at the neck's base rose off the neck: skineval neck_twist_60 r_max 1.0035 on
            // the 13K MakeHuman, 1.023 on CesiumMan, now 1.0000 (math.md).
            if (ch.kind == ChainKind::Torso) {
                end.twist = 0.0;
                end.twist_direction = nd;
            }
        } else {
            // The wrist, ankle or head key takes the whole twist of the hand, foot or head,
            // spread along the forearm (shin, neck) by the sweep: no candy-wrapper.
            end.twist = 1.0;
        }
    } else {
        end.bone = links.back();
    }
    specs.push_back(end);
    if (ch.kind == ChainKind::Torso && m > 1) {
        // The spine's bones zigzag along its S-curve (by 15-20 degrees in a MakeHuman rig)
        // while the body around them is straight; planes that follow each bone cross inside
        // a body 30 cm deep only a few centimetres from the spine. Every key but the end one
        // (the neck's start) is cut square to the torso as a whole.
        const dvec3 axis = unit_or(joint[m] - joint[0], dir[0]);
        for (size_t k = 0; k + 1 < specs.size(); ++k) specs[k].normal = axis;
    }
    return specs;
}

/// The polygon with points inserted along edges longer than `max_edge` (the chords that
/// close a section where other parts were cut away), so a fit sees them as boundary too.
std::vector<dvec2> densify(const std::vector<dvec2>& p, double max_edge) {
    std::vector<dvec2> out;
    for (size_t i = 0; i < p.size(); ++i) {
        const dvec2 a = p[i], b = p[(i + 1) % p.size()];
        out.push_back(a);
        const int extra = static_cast<int>(std::ceil(glm::length(b - a) / max_edge)) - 1;
        for (int k = 1; k <= extra && extra < 10000; ++k)
            out.push_back(a + (b - a) * (static_cast<double>(k) / (extra + 1)));
    }
    return out;
}

/// Which part of a cut counts as the chain's own.
struct Ownership {
    int chain = -1;
    int also = -1;             ///< another chain whose part counts too (the neck, for the torso's end), or -1
    double clip_radius = 0.0;  ///< > 0: points farther from the bone are not the chain's (the foot at the ankle)
};

/// Cuts the mesh at a spec, picks the chain's loop, keeps the chain's own part of it and
/// fits the ellipse (optionally scaled so that π a b is the section's area).
Fitted fit_section(const FitMesh& mesh, const KeySpec& spec, const Ownership& own, const PartShares& shares,
                   const KeyOptions& opt, KeyReport* rep) {
    Fitted out;
    rep->notes.clear();
    const PlaneFrame frame(spec.point, spec.normal, dvec3(1, 0, 0));
    const std::vector<SectionLoop> loops = cut_mesh(mesh, spec.point, spec.normal);
    std::vector<std::vector<dvec2>> polygons(loops.size());
    for (size_t i = 0; i < loops.size(); ++i)
        for (const SectionPoint& p : loops[i].points) polygons[i].push_back(frame.to_plane(p.p));
    const LoopPick pick = pick_loop(polygons, dvec2(0.0), 0.15 * spec.link_length);
    if (pick.loop < 0) {
        rep->notes.push_back(loops.empty() ? "the cut misses the mesh" : "no section loop around the bone");
        return out;
    }
    if (!pick.contains) rep->notes.push_back("the bone lies outside its section (by " + fmt(pick.distance) + ")");
    const SectionLoop& loop = loops[pick.loop];
    const std::vector<dvec2>& poly = polygons[pick.loop];
    const size_t n = poly.size();
    rep->loop_points = static_cast<int>(n);
    std::vector<double> w = arc_length_weights(poly);
    if (!loop.closed) {
        // The chord closing an open section is not surface: it carries no weight.
        const double chord = glm::length(poly.front() - poly.back());
        w.front() = std::max(0.0, w.front() - 0.5 * chord);
        w.back() = std::max(0.0, w.back() - 0.5 * chord);
        rep->notes.push_back("the section is open (mesh border); closed by a chord of " + fmt(chord));
    }
    // Keep the part of the loop that belongs to this chain.
    std::vector<dvec2> kept;
    double total = 0.0, kept_length = 0.0;
    std::vector<double> edges;
    for (size_t i = 0; i < n; ++i) {
        const SectionPoint& p = loop.points[i];
        const auto share_of = [&](int c) { return (1.0 - p.t) * shares.at(p.v0, c) + p.t * shares.at(p.v1, c); };
        double share = share_of(own.chain);
        if (own.also >= 0) share += share_of(own.also);
        const bool near = own.clip_radius <= 0.0 || glm::length(poly[i]) <= own.clip_radius;
        total += w[i];
        edges.push_back(glm::length(poly[(i + 1) % n] - poly[i]));
        if (share >= 0.5 && near) {
            kept_length += w[i];
            kept.push_back(poly[i]);
        }
    }
    rep->owned_fraction = total > 0.0 ? kept_length / total : 0.0;
    if (rep->owned_fraction < opt.min_owned_fraction || kept.size() < 3) {
        rep->notes.push_back("only " + fmt(100.0 * rep->owned_fraction) +
                             " % of the section belongs to this chain (the rest to other parts)");
        return out;
    }
    if (rep->owned_fraction < 0.999)
        rep->notes.push_back("the section runs into other parts: fitted to its own " +
                             fmt(100.0 * rep->owned_fraction) + " %, closed by chords");
    std::nth_element(edges.begin(), edges.begin() + edges.size() / 2, edges.end());
    const std::vector<dvec2> section = densify(kept, 2.0 * std::max(edges[edges.size() / 2], 1e-300));
    const std::vector<double> weights = arc_length_weights(section);
    rep->section_area = std::abs(polygon_area(section));
    const double r_eq = std::sqrt(rep->section_area / M_PI);
    const dvec2 centroid = polygon_centroid(section);

    // Intermediate keys: centered at the centroid. Joint keys: centered at the joint, fitted
    // there (Sect. 3.2) when the joint is near the section's center. A joint far off it (the
    // spine near the back) would get a distorted, oversized ellipse that reaches out behind
    // the body, and a sweep zigzagging between the back and the middle: such a key is
    // centered at the centroid too, and turns about its joint in a pose (rig/key_motion.h).
    dvec2 center = spec.fixed_center ? dvec2(0.0) : centroid;
    if (spec.fixed_center && (!polygon_contains(section, dvec2(0.0)) || glm::length(centroid) > 0.15 * r_eq)) {
        center = centroid;
        rep->notes.push_back("the joint lies " + fmt(glm::length(centroid) / std::max(r_eq, 1e-300)) +
                             " radii off the section's center: the key is centered at the centroid");
    }
    const Ellipse2 e = fit_ellipse_fixed_center(section, weights, center);
    if (!e.valid || !(std::max(e.a, e.b) < 10.0 * std::max(r_eq, 1e-300))) {
        rep->notes.push_back("no ellipse fits the section");
        return out;
    }
    rep->fit_rms = e.rms;
    rep->ellipse_area = e.area();
    // Optionally the same area as the section, so the sweep's volume is the body's.
    const double scale = opt.match_section_area ? std::sqrt(rep->section_area / e.area()) : 1.0;
    out.ok = true;
    out.center = frame.to_space(center);
    out.axis = glm::normalize(e.axis.x * frame.u + e.axis.y * frame.v);
    out.a = e.a * scale;
    out.b = e.b * scale;
    return out;
}

dvec3 project_to_plane(const dvec3& v, const dvec3& n) { return v - glm::dot(v, n) * n; }

/// Builds the sweep's keys; smooths the half-axes while their quadratic interpolation
/// overshoots below zero. Returns "" or the reason the keys make no sweep.
std::string finish_keys(const Skeleton& s, std::vector<KeyEllipse>& keys, std::vector<std::string>& notes) {
    for (int attempt = 0; attempt < 24; ++attempt) {
        try {
            make_sweep(keys, s);
            if (attempt > 0)
                notes.push_back("half-axes smoothed " + std::to_string(attempt) +
                                " time(s) to keep their interpolation positive");
            return "";
        } catch (const InvalidInput& e) {
            const std::string what = e.what();
            if (what.find("half-axes become") == std::string::npos) return what;
        }
        std::vector<KeyEllipse> old = keys;
        for (size_t k = 1; k + 1 < keys.size(); ++k) {
            keys[k].a = 0.5 * old[k].a + 0.25 * (old[k - 1].a + old[k + 1].a);
            keys[k].b = 0.5 * old[k].b + 0.25 * (old[k - 1].b + old[k + 1].b);
        }
    }
    return "the half-axes of neighbouring keys differ too much even after smoothing";
}

}  // namespace

ChainFit fit_chain(const FitMesh& mesh, const Skeleton& s, const ChainSet& set, int chain_index,
                   const PartShares& shares, const KeyOptions& opt) {
    ChainFit out;
    const Chain& ch = set.chains[chain_index];
    const std::vector<KeySpec> specs = key_specs(s, set, ch, opt);
    const int K = static_cast<int>(specs.size());
    std::vector<Fitted> fits(K);
    out.reports.resize(K);
    // The torso's end is the neck's start: the neck's part of that section counts too.
    int next_chain = -1;
    for (size_t c = 0; c < set.chains.size(); ++c)
        if (ch.end_bone >= 0 && set.chains[c].bones[0] == ch.end_bone) next_chain = static_cast<int>(c);
    const auto ownership = [&](int k) {
        Ownership o;
        o.chain = chain_index;
        if (k == K - 1) o.also = next_chain;
        return o;
    };
    tbb::parallel_for(0, K, [&](int k) {
        KeyReport& r = out.reports[k];
        r.role = specs[k].role;
        r.bone = specs[k].bone;
        r.joint_parent = specs[k].joint_parent;
        r.normal = specs[k].normal;
        fits[k] = fit_section(mesh, specs[k], ownership(k), shares, opt, &r);
    });
    // A wrist or ankle cut may run into the hand or foot (a low ankle joint cuts the heel):
    // keep the part near the bone, judged by the key before it.
    if (K >= 2 && ch.end_bone >= 0 && next_chain < 0 && fits[K - 2].ok) {
        const double before = std::max(fits[K - 2].a, fits[K - 2].b);
        if (!fits[K - 1].ok || std::max(fits[K - 1].a, fits[K - 1].b) > 1.5 * before) {
            Ownership o = ownership(K - 1);
            o.clip_radius = 1.6 * before;
            KeyReport r = out.reports[K - 1];
            const Fitted f = fit_section(mesh, specs[K - 1], o, shares, opt, &r);
            if (f.ok) {
                r.notes.push_back("the section runs into the " +
                                  std::string(ch.kind == ChainKind::Leg ? "foot" : "end part") + ": kept within " +
                                  fmt(o.clip_radius) + " of the joint");
                fits[K - 1] = f;
                out.reports[K - 1] = r;
            }
        }
    }

    // Keys without a usable section: interpolate from the nearest fitted neighbours.
    int fitted = 0;
    for (const Fitted& f : fits) fitted += f.ok ? 1 : 0;
    if (fitted == 0) {
        out.error = "no cross-section of the chain could be fitted";
        return out;
    }
    std::vector<Fitted> final_fits = fits;
    for (int k = 0; k < K; ++k) {
        if (fits[k].ok) continue;
        int p = k - 1, q = k + 1;
        while (p >= 0 && !fits[p].ok) --p;
        while (q < K && !fits[q].ok) ++q;
        double wq = 0.0;
        if (p >= 0 && q < K) {
            const double dp = glm::length(specs[k].point - specs[p].point),
                         dq = glm::length(specs[q].point - specs[k].point);
            wq = dp / std::max(dp + dq, 1e-300);
        } else if (q < K) {
            wq = 1.0;
        }
        const Fitted& fp = p >= 0 ? fits[p] : fits[q];
        const Fitted& fq = q < K ? fits[q] : fits[p];
        Fitted& f = final_fits[k];
        f.ok = true;
        f.center = specs[k].point;
        f.a = (1.0 - wq) * fp.a + wq * fq.a;
        f.b = (1.0 - wq) * fp.b + wq * fq.b;
        f.axis = wq < 0.5 ? fp.axis : fq.axis;
        out.reports[k].fallback = true;
        std::string from = "half-axes from key";
        if (p >= 0) from += " " + std::to_string(p);
        if (p >= 0 && q < K) from += " and";
        if (q < K) from += " " + std::to_string(q);
        out.reports[k].notes.push_back("fallback: " + from);
    }

    // Orientation: columns (first axis, second axis, normal). Consecutive keys take the
    // axis assignment closest to the previous key's, so the sweep's frame does not spin.
    const BodyFrame& body = set.frame;
    dvec3 reference = ch.kind == ChainKind::Torso || ch.kind == ChainKind::Neck ? body.left : body.forward;
    for (int k = 0; k < K; ++k) {
        const dvec3 n = specs[k].normal;
        Fitted& f = final_fits[k];
        dvec3 u = project_to_plane(f.axis, n);
        if (!(glm::length(u) > 1e-9)) u = project_to_plane(body.up, n);
        if (!(glm::length(u) > 1e-9)) u = project_to_plane(body.left, n);
        u = glm::normalize(u);
        dvec3 ref = project_to_plane(reference, n);
        if (!(glm::length(ref) > 1e-6)) ref = project_to_plane(body.up, n);
        const dvec3 w = glm::cross(n, u);
        const dvec3 options[4] = {u, -u, w, -w};
        int best = 0;
        for (int i = 1; i < 4; ++i)
            if (glm::dot(options[i], ref) > glm::dot(options[best], ref)) best = i;
        const dvec3 first = options[best];
        double a = f.a, b = f.b;
        if (best >= 2) std::swap(a, b);
        reference = first;
        KeyEllipse e;
        e.center = f.center;
        e.orientation = glm::normalize(glm::quat_cast(dmat3(first, glm::cross(n, first), n)));
        e.a = a;
        e.b = b;
        e.bone = specs[k].bone;
        e.joint_parent = specs[k].joint_parent;
        e.swing_fraction = 0.5;
        e.twist_fraction = specs[k].twist;
        e.twist_direction = specs[k].twist_direction;
        out.keys.push_back(e);
        KeyReport& r = out.reports[k];
        r.center = e.center;
        r.first_axis = first;
    }
    // A wrist's, ankle's or head's twist spreads along the last link as fast as its rings allow.
    const KeySpec& last = specs[K - 1];
    if (last.twist == 1.0 && last.joint_parent >= 0) {
        const double rings = rings_along(mesh, shares, chain_index, s.heads[last.joint_parent], last.point);
        out.keys.back().twist_spread = twist_spread_for(rings);
        if (rings > 0.0)
            out.reports[K - 1].notes.push_back("twist spread " + fmt(out.keys.back().twist_spread) + " (" + fmt(rings) +
                                               " rings along the link)");
    }
    std::string error = finish_keys(s, out.keys, out.notes);
    if (!error.empty()) {
        // Intermediate keys off the link (centroids) may make the sweep double back; put
        // them on the link and try once more.
        std::vector<KeyEllipse> on_link = out.keys;
        for (int k = 0; k < K; ++k)
            if (!specs[k].fixed_center) on_link[k].center = specs[k].point;
        if (finish_keys(s, on_link, out.notes).empty()) {
            out.keys = on_link;
            out.notes.push_back("intermediate keys moved onto their links (" + error + ")");
            error.clear();
        }
    }
    if (!error.empty()) {
        out.error = error;
        return out;
    }
    for (int k = 0; k < K; ++k) {
        out.reports[k].center = out.keys[k].center;
        out.reports[k].a = out.keys[k].a;
        out.reports[k].b = out.keys[k].b;
    }
    return out;
}

}  // namespace sd::fit
