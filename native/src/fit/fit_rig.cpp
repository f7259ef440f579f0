#include "fit/fit_rig.h"

#include "fit/deform_hierarchy.h"
#include "fit/spine_skin.h"

#include <nlohmann/json.hpp>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>

namespace sd::fit {

namespace {

/// The report keeps the order in which its fields are written (easier to read).
using Json = nlohmann::ordered_json;

Json json_vec(const dvec3& v) { return Json::array({v.x, v.y, v.z}); }

std::string bone_name(const FitInput& in, int b) {
    return b >= 0 && b < static_cast<int>(in.bone_names.size()) ? in.bone_names[b] : std::string();
}

/// The fitting's report as JSON (see docs): mesh checks, body frame, chains with their key
/// ellipses, region statistics, notes and warnings. Lengths in the caller's units; NaN and
/// infinite figures become null; bone names that are not UTF-8 get U+FFFD.
std::string make_report(const FitInput& in, const FitResult& r) {
    Json chains = Json::array();
    for (size_t c = 0; c < r.chains.chains.size(); ++c) {
        const Chain& ch = r.chains.chains[c];
        const ChainFit& fit = r.fits[c];
        Json names = Json::array(), link_names = Json::array();
        for (int b : ch.bones) names.push_back(bone_name(in, b));
        for (int b : ch.links()) link_names.push_back(bone_name(in, b));
        Json j = {{"name", ch.name},
                  {"kind", chain_kind_name(ch.kind)},
                  {"side", ch.side},
                  {"bones", ch.bones},
                  {"bone_names", names},
                  {"link_names", link_names},  // the swept links: a limb bone cut in two is one
                  {"first_swept_bone", ch.bones[ch.first_swept]},
                  {"end_bone", ch.end_bone},
                  {"end_bone_name", bone_name(in, ch.end_bone)},
                  {"parent_chain", ch.parent_chain},
                  {"sweep", r.chain_sweep[c]}};
        if (!fit.error.empty()) j["error"] = fit.error;
        j["notes"] = fit.notes;
        Json keys = Json::array();
        for (const KeyReport& k : fit.reports)
            keys.push_back({{"role", k.role},
                            {"bone", k.bone},
                            {"joint_parent", k.joint_parent},
                            {"center", json_vec(k.center)},
                            {"normal", json_vec(k.normal)},
                            {"first_axis", json_vec(k.first_axis)},
                            {"half_axes", {k.a, k.b}},
                            {"section_area", k.section_area},
                            {"fitted_ellipse_area", k.ellipse_area},
                            {"ellipse_area", M_PI * k.a * k.b},
                            {"fit_rms", k.fit_rms},
                            {"owned_fraction", k.owned_fraction},
                            {"fallback", k.fallback},
                            {"notes", k.notes}});
        j["keys"] = keys;
        chains.push_back(j);
    }
    const Json report = {{"version", 1},
                         {"mesh",
                          {{"vertices", r.mesh.vertices},
                           {"triangles", r.mesh.triangles},
                           {"components", r.mesh.components},
                           {"boundary_edges", r.mesh.boundary_edges},
                           {"nonmanifold_faces", r.mesh.nonmanifold_faces},
                           {"degenerate_triangles", r.mesh.degenerate_triangles},
                           {"unused_vertices", r.mesh.unused_vertices}}},
                         {"body",
                          {{"up", json_vec(r.chains.frame.up)},
                           {"left", json_vec(r.chains.frame.left)},
                           {"forward", json_vec(r.chains.frame.forward)},
                           {"sides_known", r.chains.frame.sides_known}}},
                         {"chains", chains},
                         {"regions",
                          {{"source", r.weights.source},
                           {"sweep_slots", r.weights.sweep_slots},
                           {"bone_slots", r.weights.bone_slots},
                           {"vertices_bound", r.weights.vertices_bound},
                           {"vertices_on_sweeps", r.weights.vertices_on_sweeps},
                           {"vertices_rigid_only", r.weights.vertices_rigid_only},
                           {"vertices_blended", r.weights.vertices_blended},
                           {"vertices_from_nearest_bone", r.weights.vertices_from_nearest_bone},
                           {"vertices_beside_spine", r.weights.vertices_beside_spine}}},
                         {"notes", r.chains.notes},
                         {"warnings", r.warnings}};
    return report.dump(-1, ' ', false, Json::error_handler_t::replace);
}

void validate_skin(const FitInput& in) {
    if (in.skin_slots == 0) return;
    if (in.skin_slots < 0 || in.skin_slots > 64) throw InvalidInput("skin_slots must be in 0..64");
    if (!in.skin_bones || !in.skin_weights) throw InvalidInput("skin bones or weights is NULL");
    const int B = in.skeleton.bone_count();
    for (int v = 0; v < in.vertex_count; ++v)
        for (int i = 0; i < in.skin_slots; ++i) {
            const int b = in.skin_bones[static_cast<size_t>(v) * in.skin_slots + i];
            const float w = in.skin_weights[static_cast<size_t>(v) * in.skin_slots + i];
            if (b < -1 || b >= B)
                throw InvalidInput("vertex " + std::to_string(v) + ": skin bone " + std::to_string(b) +
                                   " is out of range -1.." + std::to_string(B - 1));
            if (b >= 0 && (!std::isfinite(w) || w < 0.0f))
                throw InvalidInput("vertex " + std::to_string(v) + ": skin weight is negative or not finite");
        }
}

std::string fmt(double x) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "%.3g", x);
    return buf;
}

}  // namespace

std::vector<std::string> names_from_c(int count, const char* const* names) {
    std::vector<std::string> out;
    if (!names) return out;
    out.resize(static_cast<size_t>(count));
    for (int b = 0; b < count; ++b)
        if (const char* name = names[b]) out[b].assign(name, strnlen(name, 1024));
    return out;
}

std::vector<std::vector<int>> chains_from_offsets(int chain_count, const int32_t* offsets, const int32_t* bones) {
    std::vector<std::vector<int>> chains;
    if (chain_count == 0) return chains;
    if (chain_count < 0 || chain_count > 1024) throw InvalidInput("chain_count must be in 0..1024");
    if (!offsets || !bones) throw InvalidInput("chain_offsets or chain_bones is NULL");
    if (offsets[0] != 0) throw InvalidInput("chain_offsets[0] must be 0");
    for (int c = 0; c < chain_count; ++c) {
        if (!(offsets[c + 1] > offsets[c] && offsets[c + 1] - offsets[c] <= 100000))
            throw InvalidInput("chain_offsets must increase (chain " + std::to_string(c) + " is empty or too long)");
        chains.emplace_back(bones + offsets[c], bones + offsets[c + 1]);
    }
    return chains;
}

FitResult fit_rig(const FitInput& in, const FitOptions& options) {
    const Skeleton& s = in.skeleton;
    const int B = s.bone_count();
    if (B < 1) throw InvalidInput("the skeleton has no bones");
    if (!in.bone_names.empty() && static_cast<int>(in.bone_names.size()) != B)
        throw InvalidInput("bone names: " + std::to_string(in.bone_names.size()) + " names for " + std::to_string(B) +
                           " bones");
    if (options.keys.keys_per_link < 0 || options.keys.keys_per_link > 16)
        throw InvalidInput("keys_per_link must be in 0..16");
    const FitMesh mesh(in.vertex_count, in.positions, in.triangle_count, in.triangles);
    validate_skin(in);
    FitResult r;
    r.mesh = mesh.stats();

    // Same space? A mesh in centimetres with a skeleton in metres (unapplied object scale)
    // cannot be fitted; say so instead of failing somewhere deep. Bones far outside the mesh
    // (IK targets, props) do not count.
    const double mesh_size = mesh.diagonal();
    const dvec3 margin(0.25 * mesh_size);
    dvec3 lo(std::numeric_limits<double>::infinity()), hi = -lo;
    int inside = 0;
    for (int b = 0; b < B; ++b) {
        const dvec3& h = s.heads[b];
        if (glm::any(glm::lessThan(h, mesh.bbox_min() - margin)) ||
            glm::any(glm::greaterThan(h, mesh.bbox_max() + margin)))
            continue;
        ++inside;
        lo = glm::min(lo, glm::min(h, s.tails[b]));
        hi = glm::max(hi, glm::max(h, s.tails[b]));
    }
    if (2 * inside < B)
        throw InvalidInput("only " + std::to_string(inside) + " of " + std::to_string(B) +
                           " bone heads lie within the mesh's bounds (size " + fmt(mesh_size) +
                           "): the skeleton and the mesh must both be in armature space (apply the "
                           "object transforms and scale)");
    const double ratio = glm::length(hi - lo) / mesh_size;
    if (!(ratio > 0.1 && ratio < 10.0))
        throw InvalidInput("the skeleton (size " + fmt(glm::length(hi - lo)) + ") and the mesh (size " +
                           fmt(mesh_size) + ") differ in scale by a factor of " +
                           fmt(ratio > 1.0 ? ratio : 1.0 / ratio) +
                           ": both must be in armature space (apply the object scale)");

    if (r.mesh.nonmanifold_faces > 0)
        r.warnings.push_back(std::to_string(r.mesh.nonmanifold_faces) +
                             " non-manifold face(s): cuts across them are closed over the gap");
    if (r.mesh.degenerate_triangles > 0)
        r.warnings.push_back(std::to_string(r.mesh.degenerate_triangles) + " degenerate triangle(s) skipped");
    if (r.mesh.boundary_edges > 0)
        r.warnings.push_back(std::to_string(r.mesh.boundary_edges) +
                             " border edge(s): the mesh is open (holes, or vertices split at UV seams: weld them)");

    const bool skinned = in.skin_slots > 0;
    std::vector<double> mass;
    if (skinned) {
        mass.assign(B, 0.0);
        for (int v = 0; v < in.vertex_count; ++v)
            for (int i = 0; i < in.skin_slots; ++i) {
                const int b = in.skin_bones[static_cast<size_t>(v) * in.skin_slots + i];
                if (b >= 0) mass[b] += in.skin_weights[static_cast<size_t>(v) * in.skin_slots + i];
            }
        double total = 0.0;
        for (double m : mass) total += m;
        if (!(total > 0.0)) {
            r.warnings.push_back("the skin weights are all zero: regions from geometry");
            mass.clear();
        }
    }
    // The chains are read from the skinned bones' hierarchy (a Rigify rig's deform bones hang
    // from its mechanism bones); the rig keeps the skeleton as it is.
    Skeleton deforming = s;
    if (in.chains.empty()) {
        std::vector<std::string> hung;
        deforming = deform_hierarchy(s, mass, in.bone_names, &hung);
        r.chains = find_chains(deforming, in.bone_names, mass);
        r.chains.notes.insert(r.chains.notes.begin(), hung.begin(), hung.end());
    } else {
        r.chains = chains_from_lists(s, in.chains);
    }
    const int C = static_cast<int>(r.chains.chains.size());
    const BoneOwners owners = bone_owners(deforming, r.chains);
    const bool use_skin = skinned && !mass.empty();
    PartShares shares =
        use_skin ? shares_from_skin(in.vertex_count, in.skin_slots, in.skin_bones, in.skin_weights, owners, C)
                 : shares_from_nearest_bones(mesh, s, owners, C);
    const auto fit_all = [&] {
        r.rig = Rig();
        r.rig.skeleton = s;
        r.chain_sweep.assign(C, -1);
        r.fits.assign(C, ChainFit());
        for (int c = 0; c < C; ++c) {
            r.fits[c] = fit_chain(mesh, s, r.chains, c, shares, options.keys);
            if (r.fits[c].error.empty()) r.chain_sweep[c] = r.rig.add_sweep(r.fits[c].keys);
        }
    };
    fit_all();
    if (!use_skin && !r.rig.sweeps.empty()) {
        // Without skin weights the first regions come from nearest bones, which give the
        // hips to the legs and the chest beside the arms to the arms; the first sweeps tell
        // better, so the keys are fitted once more with the regions they give.
        shares = shares_from_sweeps(mesh, r.rig, owners, r.chain_sweep);
        fit_all();
    }
    for (int c = 0; c < C; ++c)
        if (!r.fits[c].error.empty())
            r.warnings.push_back("chain " + r.chains.chains[c].name + " got no sweep (" + r.fits[c].error +
                                 "): its bones drive their vertices directly");
    if (r.rig.sweeps.empty())
        throw InvalidInput("no chain could be fitted: " +
                           (r.fits.empty() ? std::string("no chains") : r.fits[0].error));

    r.weights = use_skin ? weights_from_skin(mesh, s, owners, r.chain_sweep, in.skin_slots, in.skin_bones,
                                             in.skin_weights, options.regions)
                         : weights_from_geometry(mesh, r.rig, r.chains, owners, r.chain_sweep, options.regions);
    if (use_skin) {
        r.weights.vertices_beside_spine = give_spine_skin_to_bones(mesh, r.rig, r.chains, r.chain_sweep, in.skin_slots,
                                                                   in.skin_bones, in.skin_weights, r.weights);
        count_region(r.weights, in.vertex_count);
    }
    const double bound = static_cast<double>(r.weights.vertices_bound) / in.vertex_count;
    if (bound < 1.0) r.warnings.push_back(fmt(100.0 * (1.0 - bound)) + " % of the vertices got no weight");
    r.report = make_report(in, r);
    return r;
}

}  // namespace sd::fit
