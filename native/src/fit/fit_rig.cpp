#include "fit/fit_rig.h"

#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>

namespace sd::fit {

namespace {

/// A tiny JSON writer: enough for the report.
class Json {
public:
    std::string text;
    void str(const std::string& s) {
        text += '"';
        for (char c : s) {
            switch (c) {
                case '"':
                    text += "\\\"";
                    break;
                case '\\':
                    text += "\\\\";
                    break;
                case '\n':
                    text += "\\n";
                    break;
                case '\t':
                    text += "\\t";
                    break;
                default:
                    if (static_cast<unsigned char>(c) < 0x20) {
                        char buf[8];
                        std::snprintf(buf, sizeof buf, "\\u%04x", c);
                        text += buf;
                    } else {
                        text += c;
                    }
            }
        }
        text += '"';
    }
    void num(double x) {
        if (!std::isfinite(x)) {
            text += "null";
            return;
        }
        char buf[32];
        std::snprintf(buf, sizeof buf, "%.7g", x);
        text += buf;
    }
    void vec(const dvec3& v) {
        text += '[';
        for (int i = 0; i < 3; ++i) {
            if (i) text += ',';
            num(v[i]);
        }
        text += ']';
    }
    void key(const char* k) {
        comma();
        str(k);
        text += ':';
        fresh_ = true;
    }
    void open(char c) {
        comma();
        text += c;
        fresh_ = true;
    }
    void close(char c) {
        text += c;
        fresh_ = false;
    }
    void value_str(const std::string& s) {
        comma();
        str(s);
        fresh_ = false;
    }
    void value_num(double x) {
        comma();
        num(x);
        fresh_ = false;
    }
    void value_vec(const dvec3& v) {
        comma();
        vec(v);
        fresh_ = false;
    }
    void value_raw(const char* raw) {
        comma();
        text += raw;
        fresh_ = false;
    }
    void strings(const std::vector<std::string>& list) {
        open('[');
        for (const std::string& s : list) value_str(s);
        close(']');
    }

private:
    void comma() {
        if (!fresh_ && !text.empty()) text += ',';
        fresh_ = false;
    }
    bool fresh_ = true;
};

std::string bone_name(const FitInput& in, int b) {
    return b >= 0 && b < static_cast<int>(in.bone_names.size()) ? in.bone_names[b] : std::string();
}

std::string make_report(const FitInput& in, const FitResult& r) {
    Json j;
    j.open('{');
    j.key("version");
    j.value_num(1);
    j.key("mesh");
    j.open('{');
    j.key("vertices");
    j.value_num(r.mesh.vertices);
    j.key("triangles");
    j.value_num(r.mesh.triangles);
    j.key("components");
    j.value_num(r.mesh.components);
    j.key("boundary_edges");
    j.value_num(r.mesh.boundary_edges);
    j.key("nonmanifold_faces");
    j.value_num(r.mesh.nonmanifold_faces);
    j.key("degenerate_triangles");
    j.value_num(r.mesh.degenerate_triangles);
    j.key("unused_vertices");
    j.value_num(r.mesh.unused_vertices);
    j.close('}');
    j.key("body");
    j.open('{');
    j.key("up");
    j.value_vec(r.chains.frame.up);
    j.key("left");
    j.value_vec(r.chains.frame.left);
    j.key("forward");
    j.value_vec(r.chains.frame.forward);
    j.key("sides_known");
    j.value_raw(r.chains.frame.sides_known ? "true" : "false");
    j.close('}');
    j.key("chains");
    j.open('[');
    for (size_t c = 0; c < r.chains.chains.size(); ++c) {
        const Chain& ch = r.chains.chains[c];
        const ChainFit& fit = r.fits[c];
        j.open('{');
        j.key("name");
        j.value_str(ch.name);
        j.key("kind");
        j.value_str(chain_kind_name(ch.kind));
        j.key("side");
        j.value_num(ch.side);
        j.key("bones");
        j.open('[');
        for (int b : ch.bones) j.value_num(b);
        j.close(']');
        j.key("bone_names");
        j.open('[');
        for (int b : ch.bones) j.value_str(bone_name(in, b));
        j.close(']');
        j.key("first_swept_bone");
        j.value_num(ch.bones[ch.first_swept]);
        j.key("end_bone");
        j.value_num(ch.end_bone);
        j.key("end_bone_name");
        j.value_str(bone_name(in, ch.end_bone));
        j.key("parent_chain");
        j.value_num(ch.parent_chain);
        j.key("sweep");
        j.value_num(r.chain_sweep[c]);
        if (!fit.error.empty()) {
            j.key("error");
            j.value_str(fit.error);
        }
        j.key("notes");
        j.strings(fit.notes);
        j.key("keys");
        j.open('[');
        for (const KeyReport& k : fit.reports) {
            j.open('{');
            j.key("role");
            j.value_str(k.role);
            j.key("bone");
            j.value_num(k.bone);
            j.key("joint_parent");
            j.value_num(k.joint_parent);
            j.key("center");
            j.value_vec(k.center);
            j.key("normal");
            j.value_vec(k.normal);
            j.key("first_axis");
            j.value_vec(k.first_axis);
            j.key("half_axes");
            j.open('[');
            j.value_num(k.a);
            j.value_num(k.b);
            j.close(']');
            j.key("section_area");
            j.value_num(k.section_area);
            j.key("fitted_ellipse_area");
            j.value_num(k.ellipse_area);
            j.key("ellipse_area");
            j.value_num(M_PI * k.a * k.b);
            j.key("fit_rms");
            j.value_num(k.fit_rms);
            j.key("owned_fraction");
            j.value_num(k.owned_fraction);
            j.key("fallback");
            j.value_raw(k.fallback ? "true" : "false");
            j.key("notes");
            j.strings(k.notes);
            j.close('}');
        }
        j.close(']');
        j.close('}');
    }
    j.close(']');
    j.key("regions");
    j.open('{');
    j.key("source");
    j.value_str(r.weights.source);
    j.key("sweep_slots");
    j.value_num(r.weights.sweep_slots);
    j.key("bone_slots");
    j.value_num(r.weights.bone_slots);
    j.key("vertices_bound");
    j.value_num(r.weights.vertices_bound);
    j.key("vertices_on_sweeps");
    j.value_num(r.weights.vertices_on_sweeps);
    j.key("vertices_rigid_only");
    j.value_num(r.weights.vertices_rigid_only);
    j.key("vertices_blended");
    j.value_num(r.weights.vertices_blended);
    j.key("vertices_from_nearest_bone");
    j.value_num(r.weights.vertices_from_nearest_bone);
    j.close('}');
    j.key("notes");
    j.strings(r.chains.notes);
    j.key("warnings");
    j.strings(r.warnings);
    j.close('}');
    return j.text;
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

std::vector<std::vector<int>> chains_from_offsets(int chain_count, const int32_t* offsets,
                                                  const int32_t* bones) {
    std::vector<std::vector<int>> chains;
    if (chain_count == 0) return chains;
    if (chain_count < 0 || chain_count > 1024) throw InvalidInput("chain_count must be in 0..1024");
    if (!offsets || !bones) throw InvalidInput("chain_offsets or chain_bones is NULL");
    if (offsets[0] != 0) throw InvalidInput("chain_offsets[0] must be 0");
    for (int c = 0; c < chain_count; ++c) {
        if (!(offsets[c + 1] > offsets[c] && offsets[c + 1] - offsets[c] <= 100000))
            throw InvalidInput("chain_offsets must increase (chain " + std::to_string(c) +
                               " is empty or too long)");
        chains.emplace_back(bones + offsets[c], bones + offsets[c + 1]);
    }
    return chains;
}

FitResult fit_rig(const FitInput& in, const FitOptions& options) {
    const Skeleton& s = in.skeleton;
    const int B = s.bone_count();
    if (B < 1) throw InvalidInput("the skeleton has no bones");
    if (!in.bone_names.empty() && static_cast<int>(in.bone_names.size()) != B)
        throw InvalidInput("bone names: " + std::to_string(in.bone_names.size()) + " names for " +
                           std::to_string(B) + " bones");
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
        r.warnings.push_back(
            std::to_string(r.mesh.boundary_edges) +
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
    r.chains = in.chains.empty() ? find_chains(s, in.bone_names, mass) : chains_from_lists(s, in.chains);
    const int C = static_cast<int>(r.chains.chains.size());
    const BoneOwners owners = bone_owners(s, r.chains);
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

    r.weights = use_skin
                    ? weights_from_skin(mesh, s, owners, r.chain_sweep, in.skin_slots, in.skin_bones,
                                        in.skin_weights, options.regions)
                    : weights_from_geometry(mesh, r.rig, r.chains, owners, r.chain_sweep, options.regions);
    const double bound = static_cast<double>(r.weights.vertices_bound) / in.vertex_count;
    if (bound < 1.0) r.warnings.push_back(fmt(100.0 * (1.0 - bound)) + " % of the vertices got no weight");
    r.report = make_report(in, r);
    return r;
}

}  // namespace sd::fit
