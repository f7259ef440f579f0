// sweepdeform: deforms a rigged character by a BVH clip with sweep surfaces, without Blender.
//
//   sweepdeform [options] CHARACTER MOTION -o OUTPUT
//
// The same pipeline as the add-on, through the same C ABI of libsweepdeform: the automatic
// fitting (sd_fit_rig: keys_per_link 2, 8 skin slots, bone names), sd_bind, sd_deform with
// volume preservation. Run `sweepdeform --help` for the options; docs/pipeline.md explains.
#include "sweepdeform/sweepdeform.h"

#include "dmap/displacement_map.h"
#include "bind/serialize.h"

#include <sweepdeform_io/bvh.h>
#include <sweepdeform_io/character.h>
#include <sweepdeform_io/gltf_loader.h>
#include <sweepdeform_io/mesh_io.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

namespace {

namespace fs = std::filesystem;

// Exit codes (also in --help).
enum Exit : int {
    kOk = 0,
    kUsage = 1,    // bad command line
    kInput = 2,    // a file is missing or unreadable, or not a valid character / BVH / pose file
    kMapping = 3,  // no bone of the character matches the motion
    kCore = 4,     // fitting, binding or deformation failed
    kOutput = 5,   // an output file could not be written
};

struct Failure : std::runtime_error {
    int code;
    Failure(int c, const std::string& what) : std::runtime_error(what), code(c) {}
};

const char* kUsageText = R"(usage: sweepdeform [options] CHARACTER MOTION -o OUTPUT

Deforms CHARACTER by MOTION with sweep surfaces of moving ellipses (Hyun et al. 2005), with
the same fitting, binding and deformation as the Sweep Deform Blender add-on, and writes the
deformed frames.

  CHARACTER   .glb / .gltf with a skinned mesh and its skeleton, or .obj / .ply / .off
              together with --skeleton FILE.glb
  MOTION      .bvh clip (retargeted onto the character by bone names), or a pose file
              given with --pose-file instead

output:
  -o, --output PATH       PATH.pc2: one PC2 point cache. PATH.obj: an OBJ sequence; a run of
                          '#' in the name is replaced by the frame number (else _#### is
                          added before .obj)
  --frames A:B[:STEP]     clip frames A..B inclusive (0-based), every STEP-th (default: all)
  --up y|z                axes of OBJ/PLY/OFF/XYZ files read and written: y (default) = Y-up
                          like glTF and Blender's OBJ exporter, z = Blender's Z-up. PC2 files
                          are always in Blender's Z-up object space, as the Mesh Cache
                          modifier reads them
  --write-poses FILE      also write the bone matrices used per frame (pose-file format)
  --report FILE           write the fitting report (JSON)

character:
  --skeleton FILE.glb     skeleton for an OBJ/PLY/OFF character: bones from this glTF; skin
                          weights carried from its skinned mesh to the character's vertices
                          (closest point) unless --no-skin-weights. The character must lie
                          where that glTF's mesh lies (same body, same space)
  --no-skin-weights       fit from geometry alone (no skin weights as hints)
  --weld                  merge coincident vertices of a glTF (files split at UV seams,
                          e.g. CesiumMan); outputs then have the welded vertex count
  --keys-per-link N       intermediate key ellipses per link (default 2, as the add-on)

motion:
  --pose-file FILE        instead of a BVH: float32 little-endian, F x B x 16 column-major
                          bone matrices (Blender's pose_bone.matrix, armature space, metres),
                          bones in the character's order (see --list-bones)
  --bone-map FILE         lines "character_bone bvh_joint" overriding the automatic name
                          mapping (an empty joint unmaps the bone)
  --root-from-offset      root rest position = BVH root OFFSET always (as the data set's
                          *_anims.glb files; lifts zero-offset roots off the floor)

deformation:
  --no-volume             no volume preservation (default: on, strength 1, as the add-on)
  --volume-strength X     in [0, 1]

points (continuous displacement map, Sect. 3.4):
  --points FILE           deform FILE (.obj/.ply/.off/.xyz: a subdivided or retopologised mesh
                          of the same body, or a point cloud) instead of the character: it is
                          bound through the character's displacement map, without re-fitting;
                          the output has FILE's points (and faces, if any)
  --map-snap X            points within X x the local ellipse half-axis of the map's smooth
                          body surface take the surface's point at their (theta, t); others
                          keep their own offsets (default 0.1; 0 = all keep theirs;
                          inf = all take the map's)
  --map-grid NxM          control points around x per span (default 24x3)

other:
  --list-bones            print the character's bones (and their BVH joints) and exit
  -q, --quiet             only errors
  -h, --help              this text;  --version  the version

exit codes: 0 ok, 1 bad command line, 2 unreadable or invalid input file (missing file, bad
BVH, bad pose file), 3 no bone of the character matches the motion, 4 fitting, binding or
deformation failed, 5 an output file could not be written.
)";

struct Options {
    std::string character, motion, output, skeleton, pose_file, bone_map, write_poses, report, points;
    std::string up = "y";
    int frame_a = 0, frame_b = -1, frame_step = 1;
    bool frames_given = false, skin_weights = true, weld = false, volume = true, list_bones = false, quiet = false,
         root_from_offset = false, map_grid_given = false, map_snap_given = false;
    double volume_strength = 1.0, map_snap = sd::DisplacementMap::kDefaultSnap;
    int keys_per_link = 2, map_theta = 24, map_t = 3;
};

/// `s` safe for a terminal: printable ASCII and valid UTF-8 kept, every other byte (control
/// characters, escape sequences, broken UTF-8) written as \xNN.
std::string printable(const std::string& s) {
    std::string out;
    out.reserve(s.size());
    const auto hex = [&](unsigned char c) {
        char b[5];
        std::snprintf(b, sizeof b, "\\x%02X", c);
        out += b;
    };
    for (size_t i = 0; i < s.size();) {
        const auto c = static_cast<unsigned char>(s[i]);
        if (c >= 0x20 && c < 0x7F) {
            out += static_cast<char>(c);
            ++i;
            continue;
        }
        // A well-formed UTF-8 sequence of 2..4 bytes (no overlongs, no surrogates) is kept.
        const int n = c >= 0xC2 && c <= 0xDF ? 2 : c >= 0xE0 && c <= 0xEF ? 3 : c >= 0xF0 && c <= 0xF4 ? 4 : 0;
        bool ok = n > 0 && i + static_cast<size_t>(n) <= s.size();
        for (int k = 1; ok && k < n; ++k) ok = (static_cast<unsigned char>(s[i + k]) & 0xC0) == 0x80;
        if (ok && n == 3) {
            const auto c1 = static_cast<unsigned char>(s[i + 1]);
            ok = !(c == 0xE0 && c1 < 0xA0) && !(c == 0xED && c1 >= 0xA0);
        }
        if (ok && n == 4) {
            const auto c1 = static_cast<unsigned char>(s[i + 1]);
            ok = !(c == 0xF0 && c1 < 0x90) && !(c == 0xF4 && c1 >= 0x90);
        }
        if (ok) {
            out.append(s, i, static_cast<size_t>(n));
            i += static_cast<size_t>(n);
        } else {
            hex(c);
            ++i;
        }
    }
    return out;
}

[[noreturn]] void usage_error(const std::string& what) { throw Failure(kUsage, what + " (see sweepdeform --help)"); }

int parse_int(const std::string& s, const char* what) {
    try {
        size_t n = 0;
        const int v = std::stoi(s, &n);
        if (n != s.size()) throw std::invalid_argument(s);
        return v;
    } catch (const std::exception&) {
        usage_error(std::string(what) + ": '" + s + "' is not an integer");
    }
}

std::string lower_extension(const std::string& path) {
    std::string e = fs::path(path).extension().string();
    std::transform(e.begin(), e.end(), e.begin(), [](unsigned char c) { return std::tolower(c); });
    return e;
}

Options parse_args(int argc, char** argv) {
    Options o;
    std::vector<std::string> positional;
    for (int i = 1; i < argc; ++i) {
        const std::string a = argv[i];
        const auto value = [&](const char* name) -> std::string {
            if (i + 1 >= argc) usage_error(std::string(name) + " needs a value");
            return argv[++i];
        };
        if (a == "-h" || a == "--help") {
            std::fputs(kUsageText, stdout);
            std::exit(kOk);
        } else if (a == "--version") {
            std::printf("sweepdeform %s (libsweepdeform %s, ABI %d)\n", SWEEPDEFORM_VERSION, sd_library_version(),
                        sd_abi_version());
            std::exit(kOk);
        } else if (a == "-o" || a == "--output")
            o.output = value("--output");
        else if (a == "--frames") {
            const std::string f = value("--frames");
            std::vector<std::string> parts;
            std::stringstream ss(f);
            std::string part;
            while (std::getline(ss, part, ':')) parts.push_back(part);
            if (parts.size() < 2 || parts.size() > 3) usage_error("--frames wants A:B or A:B:STEP, got '" + f + "'");
            o.frame_a = parse_int(parts[0], "--frames");
            o.frame_b = parse_int(parts[1], "--frames");
            if (parts.size() == 3) o.frame_step = parse_int(parts[2], "--frames");
            if (o.frame_a < 0 || o.frame_b < o.frame_a || o.frame_step < 1)
                usage_error("--frames wants 0 <= A <= B and STEP >= 1, got '" + f + "'");
            o.frames_given = true;
        } else if (a == "--up") {
            o.up = value("--up");
            if (o.up != "y" && o.up != "z") usage_error("--up must be y or z");
        } else if (a == "--write-poses")
            o.write_poses = value("--write-poses");
        else if (a == "--report")
            o.report = value("--report");
        else if (a == "--skeleton")
            o.skeleton = value("--skeleton");
        else if (a == "--no-skin-weights")
            o.skin_weights = false;
        else if (a == "--weld")
            o.weld = true;
        else if (a == "--keys-per-link") {
            o.keys_per_link = parse_int(value("--keys-per-link"), "--keys-per-link");
            if (o.keys_per_link < 0 || o.keys_per_link > 16) usage_error("--keys-per-link must be in 0..16");
        } else if (a == "--pose-file")
            o.pose_file = value("--pose-file");
        else if (a == "--bone-map")
            o.bone_map = value("--bone-map");
        else if (a == "--root-from-offset")
            o.root_from_offset = true;
        else if (a == "--no-volume")
            o.volume = false;
        else if (a == "--volume-strength") {
            const std::string v = value("--volume-strength");
            char* end = nullptr;
            o.volume_strength = std::strtod(v.c_str(), &end);
            if (end == v.c_str() || *end || !(o.volume_strength >= 0.0 && o.volume_strength <= 1.0))
                usage_error("--volume-strength must be a number in [0, 1]");
        } else if (a == "--points")
            o.points = value("--points");
        else if (a == "--map-snap") {
            const std::string v = value("--map-snap");
            char* end = nullptr;
            o.map_snap = v == "inf" ? sd::DisplacementMap::kSurface : std::strtod(v.c_str(), &end);
            if ((v != "inf" && (end == v.c_str() || *end)) || !(o.map_snap >= 0.0))
                usage_error("--map-snap must be a number >= 0 or inf");
            o.map_snap_given = true;
        } else if (a == "--map-grid") {
            const std::string g = value("--map-grid");
            const size_t x = g.find('x');
            if (x == std::string::npos) usage_error("--map-grid wants NxM, e.g. 24x3");
            o.map_theta = parse_int(g.substr(0, x), "--map-grid");
            o.map_t = parse_int(g.substr(x + 1), "--map-grid");
            // The displacement map's own limits (DisplacementMapOptions), checked before anything
            // is loaded or fitted.
            if (o.map_theta < 4 || o.map_theta > 256 || o.map_t < 1 || o.map_t > 64)
                usage_error("--map-grid NxM wants N in 4..256 (around a sweep) and M in 1..64 (per span), got '" +
                            printable(g) + "'");
            o.map_grid_given = true;
        } else if (a == "--list-bones")
            o.list_bones = true;
        else if (a == "-q" || a == "--quiet")
            o.quiet = true;
        else if (a.size() > 1 && a[0] == '-')
            usage_error("unknown option '" + a + "'");
        else
            positional.push_back(a);
    }
    if (positional.empty()) usage_error("no CHARACTER given");
    o.character = positional[0];
    if (positional.size() > 2) usage_error("too many arguments: '" + positional[2] + "'");
    if (positional.size() == 2) o.motion = positional[1];
    if (o.list_bones) return o;
    if (o.motion.empty() == o.pose_file.empty()) usage_error("give either a BVH file or --pose-file");
    if (o.output.empty()) usage_error("no output (-o FILE.pc2 or -o FILE.obj)");
    if (o.points.empty() && (o.map_grid_given || o.map_snap_given))
        usage_error(std::string(o.map_grid_given ? "--map-grid" : "--map-snap") +
                    " is for --points (the displacement map binds the points); give --points FILE");
    const std::string ext = lower_extension(o.output);
    if (ext != ".pc2" && ext != ".obj") usage_error("output '" + o.output + "' must end in .pc2 or .obj");
    return o;
}

void require_file(const std::string& path, const char* what) {
    std::error_code ec;
    const fs::file_status st = fs::status(path, ec);
    const std::string name = std::string(what) + " '" + printable(path) + "'";
    if (fs::is_regular_file(st)) return;
    if (fs::is_directory(st)) throw Failure(kInput, name + " is a directory, not a file");
    if (fs::exists(st)) throw Failure(kInput, name + " is not a regular file");
    throw Failure(kInput, name + " does not exist");
}

/// Blender Z-up <-> Y-up file axes (glTF's and Blender's OBJ exporter's): (x,y,z)_Z = (x,-z,y)_Y.
void file_to_scene(std::vector<float>& p, const std::string& up) {
    if (up != "y") return;
    for (size_t i = 0; i + 2 < p.size(); i += 3) {
        const float y = p[i + 1], z = p[i + 2];
        p[i + 1] = -z;
        p[i + 2] = y;
    }
}
void scene_to_file(const float* in, float* out, size_t n, const std::string& up) {
    for (size_t i = 0; i < n; ++i) {
        out[3 * i] = in[3 * i];
        out[3 * i + 1] = up == "y" ? in[3 * i + 2] : in[3 * i + 1];
        out[3 * i + 2] = up == "y" ? -in[3 * i + 1] : in[3 * i + 2];
    }
}

/// Calls a libsweepdeform function; a failure becomes Failure(kCore) with its message.
void check(sd_status s, const char* what) {
    if (s != SD_OK) throw Failure(kCore, std::string(what) + " failed: " + sd_last_error());
}

struct Handles {
    sd_fit_result* fit = nullptr;
    sd_rig* rig = nullptr;
    sd_binding* binding = nullptr;
    sd_deformer* deformer = nullptr;
    ~Handles() {
        sd_deformer_destroy(deformer);
        sd_binding_destroy(binding);
        sd_rig_destroy(rig);
        sd_fit_result_destroy(fit);
    }
};

/// The blob of a handle through its sd_*_serialize (`what` names it in errors): the size first,
/// then the bytes.
template <class Handle>
std::vector<uint8_t> blob_of(const Handle* h, sd_status (*serialize)(const Handle*, uint8_t*, int64_t, int64_t*),
                             const char* what) {
    int64_t n = 0;
    check(serialize(h, nullptr, 0, &n), what);
    std::vector<uint8_t> b(static_cast<size_t>(n));
    check(serialize(h, b.data(), n, &n), what);
    return b;
}
std::vector<uint8_t> rig_blob(const sd_rig* rig) { return blob_of(rig, sd_rig_serialize, "sd_rig_serialize"); }
std::vector<uint8_t> binding_blob(const sd_binding* binding) {
    return blob_of(binding, sd_binding_serialize, "sd_binding_serialize");
}

double ms_since(std::chrono::steady_clock::time_point t0) {
    return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

/// The character: a glTF, or a mesh file plus a glTF skeleton (skin weights carried over).
sd::io::Character load_character(const Options& o, bool quiet) {
    require_file(o.character, "character");
    const std::string ext = lower_extension(o.character);
    sd::io::GltfLoadOptions gopt;
    gopt.weld = o.weld;
    if (ext == ".glb" || ext == ".gltf") {
        if (!o.skeleton.empty()) throw Failure(kUsage, "--skeleton is for OBJ/PLY/OFF characters; a glTF has its own");
        try {
            return sd::io::load_gltf_character(o.character, gopt);
        } catch (const std::exception& e) {
            throw Failure(kInput, e.what());
        }
    }
    if (ext != ".obj" && ext != ".ply" && ext != ".off")
        throw Failure(kInput, "character '" + o.character + "': unknown format (use .glb, .gltf, .obj, .ply or .off)");
    if (o.skeleton.empty())
        throw Failure(kUsage, "an " + ext.substr(1) + " character has no skeleton: give --skeleton FILE.glb");
    require_file(o.skeleton, "skeleton");
    sd::io::Character skel;
    sd::io::MeshData mesh;
    int dropped = 0;
    try {
        skel = sd::io::load_gltf_character(o.skeleton, gopt);
        mesh = sd::io::read_mesh(o.character, &dropped);
    } catch (const std::exception& e) {
        throw Failure(kInput, e.what());
    }
    if (mesh.triangles.empty())
        throw Failure(kInput, "character '" + o.character + "' has no faces (a point cloud? use --points)");
    if (dropped > 0 && !quiet)
        std::fprintf(stderr, "warning: %s: %d non-manifold faces were dropped by OpenMesh\n", o.character.c_str(),
                     dropped);
    file_to_scene(mesh.positions, o.up);
    sd::io::Character c = skel;  // bones, nodes, animations
    c.positions = mesh.positions;
    c.triangles = mesh.triangles;
    const size_t V = c.positions.size() / 3;
    c.skin_joints.assign(4 * V, 0);
    c.skin_weights.assign(4 * V, 0.0f);
    if (o.skin_weights) {
        // Closest point on the skeleton file's mesh, barycentric blend of its 4 influences.
        std::vector<sd::dvec3> p(skel.positions.size() / 3);
        for (size_t i = 0; i < p.size(); ++i)
            p[i] = sd::dvec3(skel.positions[3 * i], skel.positions[3 * i + 1], skel.positions[3 * i + 2]);
        const sd::ClosestPoint closest(p, skel.triangles);
        double far = 0.0;
        for (size_t v = 0; v < V; ++v) {
            int t = 0;
            sd::dvec3 bary;
            far = std::max(
                far, closest.query(sd::dvec3(c.positions[3 * v], c.positions[3 * v + 1], c.positions[3 * v + 2]), &t,
                                   &bary));
            std::map<int32_t, double> w;
            for (int k = 0; k < 3; ++k) {
                const auto src = static_cast<size_t>(skel.triangles[3 * static_cast<size_t>(t) + k]);
                for (int s = 0; s < 4; ++s)
                    w[skel.skin_joints[4 * src + s]] += bary[k] * skel.skin_weights[4 * src + s];
            }
            std::vector<std::pair<double, int32_t>> sorted;
            for (const auto& [b, x] : w)
                if (x > 0.0) sorted.emplace_back(x, b);
            std::sort(sorted.rbegin(), sorted.rend());
            double sum = 0.0;
            for (size_t s = 0; s < std::min<size_t>(4, sorted.size()); ++s) sum += sorted[s].first;
            for (size_t s = 0; s < std::min<size_t>(4, sorted.size()); ++s) {
                c.skin_joints[4 * v + s] = sorted[s].second;
                c.skin_weights[4 * v + s] = static_cast<float>(sorted[s].first / sum);
            }
        }
        double diag = 0.0;
        {
            float lo[3] = {1e30f, 1e30f, 1e30f}, hi[3] = {-1e30f, -1e30f, -1e30f};
            for (size_t i = 0; i < skel.positions.size(); ++i) {
                lo[i % 3] = std::min(lo[i % 3], skel.positions[i]);
                hi[i % 3] = std::max(hi[i % 3], skel.positions[i]);
            }
            for (int k = 0; k < 3; ++k) diag += double(hi[k] - lo[k]) * (hi[k] - lo[k]);
            diag = std::sqrt(diag);
        }
        if (far > 0.1 * diag)
            throw Failure(kInput, "character '" + o.character + "' does not lie on the mesh of '" + o.skeleton +
                                      "' (a vertex is " + std::to_string(far) + " away; wrong --up, or another body?)");
    }
    return c;
}

/// The bone map override file: "character_bone bvh_joint" per line ('#' comments).
std::vector<std::pair<std::string, std::string>> read_bone_map(const std::string& path) {
    require_file(path, "bone map");
    std::ifstream in(path);
    std::vector<std::pair<std::string, std::string>> m;
    std::string line;
    while (std::getline(in, line)) {
        const size_t hash = line.find('#');
        if (hash != std::string::npos) line.resize(hash);
        std::istringstream ss(line);
        std::string bone, joint;
        if (!(ss >> bone)) continue;
        ss >> joint;
        m.emplace_back(bone, joint);
    }
    return m;
}

/// OBJ frame path: the run of '#' replaced by the frame number.
std::string frame_path(const std::string& pattern, int frame) {
    std::string p = pattern;
    size_t a = p.find('#');
    if (a == std::string::npos) {
        const size_t dot = p.size() - 4;  // ".obj"
        p.insert(dot, "_####");
        a = dot + 1;
    }
    size_t b = a;
    while (b < p.size() && p[b] == '#') ++b;
    char num[32];
    std::snprintf(num, sizeof num, "%0*d", static_cast<int>(b - a), frame);
    return p.substr(0, a) + num + p.substr(b);
}

int run(const Options& o) {
    const auto log = [&](const char* fmt, auto... args) {
        if (!o.quiet) std::printf(fmt, args...);
    };
    if (sd_abi_version() != SD_ABI_VERSION)
        throw Failure(kCore, "libsweepdeform has ABI " + std::to_string(sd_abi_version()) + ", this tool wants " +
                                 std::to_string(SD_ABI_VERSION));
    auto t0 = std::chrono::steady_clock::now();
    const sd::io::Character c = load_character(o, o.quiet);
    const int V = static_cast<int>(c.positions.size() / 3), T = static_cast<int>(c.triangles.size() / 3),
              B = static_cast<int>(c.bone_names.size());
    log("character  %s: %d vertices, %d triangles, %d bones (%.0f ms)\n", o.character.c_str(), V, T, B, ms_since(t0));

    // ---- motion -------------------------------------------------------------------------
    std::unique_ptr<sd::io::BvhClip> clip;
    std::unique_ptr<sd::io::BvhRetarget> retarget;
    std::vector<float> pose_file;
    int frame_count = 0;
    double frame_time = 1.0 / 30.0;
    if (!o.motion.empty()) {
        require_file(o.motion, "motion");
        if (lower_extension(o.motion) != ".bvh")
            throw Failure(kInput, "motion '" + o.motion + "' is not a .bvh file (use --pose-file for poses)");
        t0 = std::chrono::steady_clock::now();
        try {
            clip = std::make_unique<sd::io::BvhClip>(sd::io::load_bvh(o.motion));
        } catch (const std::exception& e) {
            throw Failure(kInput, std::string("bad BVH: ") + e.what());
        }
        sd::io::BvhBoneMap map;
        try {
            std::vector<std::pair<std::string, std::string>> overrides;
            if (!o.bone_map.empty()) overrides = read_bone_map(o.bone_map);
            map = sd::io::map_bvh_to_character(*clip, c, overrides);
        } catch (const Failure&) {
            throw;
        } catch (const std::exception& e) {
            throw Failure(kMapping, e.what());
        }
        sd::io::BvhRetargetOptions ropt;
        ropt.root_rest_from_offset = o.root_from_offset;
        retarget = std::make_unique<sd::io::BvhRetarget>(*clip, c, map, ropt);
        frame_count = clip->frame_count;
        frame_time = clip->frame_time_s;
        log("motion     %s: %d joints, %d frames at %.1f fps (%.0f ms); %s -> %s, %d of %d bones driven, "
            "root translation x%.5f\n",
            o.motion.c_str(), clip->joint_count(), clip->frame_count, 1.0 / clip->frame_time_s, ms_since(t0),
            map.source_convention.c_str(), map.target_convention.c_str(), map.mapped_count(), B,
            retarget->translation_scale());
        if (o.list_bones) {
            for (int b = 0; b < B; ++b)
                std::printf(
                    "%3d %-24s %s\n", b, printable(c.bone_names[static_cast<size_t>(b)]).c_str(),
                    map.source[static_cast<size_t>(b)] >= 0
                        ? printable(clip->joints[static_cast<size_t>(map.source[static_cast<size_t>(b)])].name).c_str()
                        : "-");
            return kOk;
        }
    } else if (!o.pose_file.empty()) {
        require_file(o.pose_file, "pose file");
        const auto bytes = fs::file_size(o.pose_file);
        const size_t per_frame = static_cast<size_t>(B) * 16 * sizeof(float);
        if (bytes == 0 || bytes % per_frame != 0)
            throw Failure(kInput, "pose file '" + o.pose_file + "' has " + std::to_string(bytes) +
                                      " bytes, not a multiple of " + std::to_string(per_frame) + " (" +
                                      std::to_string(B) + " bones x 16 float32)");
        pose_file.resize(bytes / sizeof(float));
        std::ifstream in(o.pose_file, std::ios::binary);
        if (!in.read(reinterpret_cast<char*>(pose_file.data()), static_cast<std::streamsize>(bytes)))
            throw Failure(kInput, "pose file '" + o.pose_file + "': read error");
        frame_count = static_cast<int>(bytes / per_frame);
        log("poses      %s: %d frames\n", o.pose_file.c_str(), frame_count);
    }
    if (o.list_bones) {
        for (int b = 0; b < B; ++b) std::printf("%3d %s\n", b, printable(c.bone_names[static_cast<size_t>(b)]).c_str());
        return kOk;
    }
    if (frame_count < 1) throw Failure(kInput, "the motion has no frames");
    const int a = o.frame_a, last = o.frames_given ? o.frame_b : frame_count - 1, step = o.frame_step;
    if (a >= frame_count || last >= frame_count)
        throw Failure(kUsage, "--frames " + std::to_string(a) + ":" + std::to_string(last) +
                                  " outside the motion's 0.." + std::to_string(frame_count - 1));

    // ---- fit and bind (as the add-on: sd_fit_rig with 8 skin slots, keys_per_link, names) ----
    Handles h;
    t0 = std::chrono::steady_clock::now();
    constexpr int kSkinSlots = 8;
    std::vector<int32_t> skin_bones(static_cast<size_t>(V) * kSkinSlots, -1);
    std::vector<float> skin_weights(static_cast<size_t>(V) * kSkinSlots, 0.0f);
    for (size_t v = 0; v < static_cast<size_t>(V); ++v)
        for (size_t s = 0; s < 4; ++s)
            if (c.skin_weights[4 * v + s] > 0.0f) {
                skin_bones[v * kSkinSlots + s] = c.skin_joints[4 * v + s];
                skin_weights[v * kSkinSlots + s] = c.skin_weights[4 * v + s];
            }
    std::vector<const char*> names;
    for (const auto& n : c.bone_names) names.push_back(n.c_str());
    const bool use_skin = o.skin_weights;
    check(sd_fit_rig(V, c.positions.data(), T, c.triangles.data(), B, c.bone_parents.data(), c.bone_rest.data(),
                     c.bone_heads.data(), c.bone_tails.data(), names.data(), use_skin ? kSkinSlots : 0,
                     use_skin ? skin_bones.data() : nullptr, use_skin ? skin_weights.data() : nullptr, o.keys_per_link,
                     0, nullptr, nullptr, &h.fit),
          "fitting (sd_fit_rig)");
    check(sd_fit_result_rig(h.fit, &h.rig), "sd_fit_result_rig");
    int32_t sweep_slots = 0, bone_slots = 0;
    check(sd_fit_result_slot_counts(h.fit, &sweep_slots, &bone_slots), "sd_fit_result_slot_counts");
    std::vector<int32_t> sid(static_cast<size_t>(V) * sweep_slots), bid(static_cast<size_t>(V) * bone_slots);
    std::vector<float> sw(sid.size()), bw(bid.size());
    check(sd_fit_result_weights(h.fit, V, sweep_slots, sid.data(), sw.data(), bone_slots, bid.data(), bw.data()),
          "sd_fit_result_weights");
    const double fit_ms = ms_since(t0);
    if (!o.report.empty()) {
        int64_t size = 0;
        check(sd_fit_result_report(h.fit, nullptr, 0, &size), "sd_fit_result_report");
        std::vector<char> text(static_cast<size_t>(size));
        check(sd_fit_result_report(h.fit, text.data(), size, &size), "sd_fit_result_report");
        std::ofstream rep(o.report);
        rep << text.data();
        if (!rep) throw Failure(kOutput, "cannot write the report '" + o.report + "'");
    }
    t0 = std::chrono::steady_clock::now();
    check(sd_bind(h.rig, V, c.positions.data(), sweep_slots, sid.data(), sw.data(), bone_slots, bid.data(), bw.data(),
                  &h.binding),
          "binding (sd_bind)");
    log("fit        %d sweeps in %.0f ms; bind %.0f ms\n", sd_rig_sweep_count(h.rig), fit_ms, ms_since(t0));

    // ---- what gets deformed: the character, or points bound through the displacement map ----
    std::vector<float> out_rest = c.positions;
    std::vector<int32_t> out_triangles = c.triangles;
    sd_binding* deformed_binding = h.binding;
    sd_binding* points_binding = nullptr;
    struct BindingGuard {
        sd_binding*& b;
        ~BindingGuard() { sd_binding_destroy(b); }
    } points_guard{points_binding};
    if (!o.points.empty()) {
        require_file(o.points, "points");
        sd::io::MeshData pts;
        int dropped = 0;
        try {
            pts = sd::io::read_mesh(o.points, &dropped);
        } catch (const std::exception& e) {
            throw Failure(kInput, e.what());
        }
        // Every point is bound; faces OpenMesh could not add are only missing from an OBJ
        // output, so they are counted and told, never dropped in silence.
        if (dropped > 0)
            std::fprintf(stderr,
                         "sweepdeform: warning: points '%s': %d of its faces were dropped by OpenMesh "
                         "(non-manifold); every point is deformed, the output OBJ lacks those faces\n",
                         printable(o.points).c_str(), dropped);
        file_to_scene(pts.positions, o.up);
        t0 = std::chrono::steady_clock::now();
        try {
            const std::vector<uint8_t> rb = rig_blob(h.rig), bb = binding_blob(h.binding);
            const sd::Rig rig = sd::deserialize_rig(rb.data(), rb.size());
            const sd::Binding binding = sd::deserialize_binding(bb.data(), bb.size());
            sd::DisplacementMapOptions mo;
            mo.theta_cells = o.map_theta;
            mo.t_cells_per_span = o.map_t;
            const sd::DisplacementMap dmap = sd::DisplacementMap::fit(rig, binding, T, c.triangles.data(), mo);
            double worst = 0.0;
            for (int s = 0; s < dmap.sweep_count(); ++s) worst = std::max(worst, dmap.stats(s).rms);
            const double fit_map_ms = ms_since(t0);
            t0 = std::chrono::steady_clock::now();
            int snapped = 0, influences = 0;
            const sd::Binding pb = dmap.bind(rig, static_cast<int>(pts.positions.size() / 3), pts.positions.data(),
                                             o.map_snap, &snapped, &influences);
            const std::vector<uint8_t> pbb = sd::serialize_binding(pb);
            check(sd_binding_deserialize(pbb.data(), static_cast<int64_t>(pbb.size()), &points_binding),
                  "sd_binding_deserialize");
            log("map        %d sweeps, %dx%d control points per span, worst sweep rms %.2g (%.0f ms); "
                "%zu points bound, %d of %d sweep influences on the map's surface (snap %g, %.0f ms)\n",
                dmap.sweep_count(), o.map_theta, o.map_t, worst, fit_map_ms, pts.positions.size() / 3, snapped,
                influences, o.map_snap, ms_since(t0));
        } catch (const Failure&) {
            throw;
        } catch (const std::exception& e) {
            throw Failure(kCore, std::string("displacement map: ") + e.what());
        }
        deformed_binding = points_binding;
        out_rest = pts.positions;
        out_triangles = pts.triangles;
    }
    const int N = static_cast<int>(out_rest.size() / 3);
    check(sd_deformer_create(h.rig, deformed_binding, &h.deformer), "sd_deformer_create");
    check(sd_deformer_set_volume_preservation(h.deformer, o.volume ? 1 : 0, static_cast<float>(o.volume_strength)),
          "sd_deformer_set_volume_preservation");
    // The mesh's volume at the limb joints, as the extension holds it: measured on the
    // character's own triangles, also for points bound through its map (they follow its sweeps).
    // And the trunk's volume given back to its skin (the same fill for points bound through the map).
    if (deformed_binding == h.binding) {
        check(sd_deformer_hold_joint_volumes(h.deformer, V, T, c.triangles.data(), nullptr),
              "sd_deformer_hold_joint_volumes");
        check(sd_deformer_set_skin_triangles(h.deformer, V, T, c.triangles.data()), "sd_deformer_set_skin_triangles");
    } else {
        sd_deformer* measured = nullptr;
        check(sd_deformer_create(h.rig, h.binding, &measured), "sd_deformer_create");
        struct DeformerGuard {
            sd_deformer* d;
            ~DeformerGuard() { sd_deformer_destroy(d); }
        } measured_guard{measured};
        check(sd_deformer_hold_joint_volumes(measured, V, T, c.triangles.data(), nullptr),
              "sd_deformer_hold_joint_volumes");
        check(sd_deformer_hold_joint_volumes_of(h.deformer, measured, nullptr), "sd_deformer_hold_joint_volumes_of");
        check(sd_deformer_set_skin_triangles(measured, V, T, c.triangles.data()), "sd_deformer_set_skin_triangles");
        check(sd_deformer_fill_trunk_as(h.deformer, measured), "sd_deformer_fill_trunk_as");
    }

    // ---- frames -------------------------------------------------------------------------
    const std::string out_ext = lower_extension(o.output);
    const fs::path out_dir = fs::path(o.output).parent_path();
    if (!out_dir.empty() && !fs::is_directory(out_dir)) {
        std::error_code ec;
        fs::create_directories(out_dir, ec);
        if (ec) throw Failure(kOutput, "cannot create the output directory '" + out_dir.string() + "'");
    }
    std::unique_ptr<sd::io::Pc2Writer> pc2;
    std::unique_ptr<std::ofstream> poses_out;
    try {
        if (out_ext == ".pc2")
            pc2 = std::make_unique<sd::io::Pc2Writer>(o.output, N, static_cast<float>(a), static_cast<float>(step));
    } catch (const std::exception& e) {
        throw Failure(kOutput, e.what());
    }
    if (!o.write_poses.empty()) {
        poses_out = std::make_unique<std::ofstream>(o.write_poses, std::ios::binary);
        if (!*poses_out) throw Failure(kOutput, "cannot write '" + o.write_poses + "'");
    }
    std::vector<float> deformed(static_cast<size_t>(N) * 3), file_axes(deformed.size());
    std::vector<double> deform_ms;
    double pose_ms = 0.0, write_ms = 0.0;
    double max_move = 0.0;
    for (int f = a; f <= last; f += step) {
        t0 = std::chrono::steady_clock::now();
        std::vector<float> pose = retarget ? retarget->pose(f)
                                           : std::vector<float>(pose_file.begin() + static_cast<long>(f) * B * 16,
                                                                pose_file.begin() + static_cast<long>(f + 1) * B * 16);
        pose_ms += ms_since(t0);
        t0 = std::chrono::steady_clock::now();
        check(sd_deform(h.deformer, B, pose.data(), N, deformed.data()),
              ("sd_deform (frame " + std::to_string(f) + ")").c_str());
        deform_ms.push_back(ms_since(t0));
        for (float x : deformed)
            if (!std::isfinite(x)) throw Failure(kCore, "frame " + std::to_string(f) + ": non-finite position");
        for (size_t i = 0; i < deformed.size(); ++i)
            max_move = std::max(max_move, double(std::abs(deformed[i] - out_rest[i])));
        t0 = std::chrono::steady_clock::now();
        try {
            if (pc2) {
                pc2->add_frame(deformed.data());
            } else {
                scene_to_file(deformed.data(), file_axes.data(), static_cast<size_t>(N), o.up);
                sd::io::write_obj(frame_path(o.output, f), file_axes.data(), static_cast<size_t>(N), out_triangles);
            }
            if (poses_out)
                poses_out->write(reinterpret_cast<const char*>(pose.data()),
                                 static_cast<std::streamsize>(pose.size() * sizeof(float)));
        } catch (const std::exception& e) {
            throw Failure(kOutput, e.what());
        }
        write_ms += ms_since(t0);
    }
    try {
        if (pc2) pc2->close();
    } catch (const std::exception& e) {
        throw Failure(kOutput, e.what());
    }
    if (poses_out && !*poses_out) throw Failure(kOutput, "cannot write '" + o.write_poses + "'");
    const size_t n = deform_ms.size();
    std::vector<double> sorted = deform_ms;
    std::sort(sorted.begin(), sorted.end());
    double sum = 0.0;
    for (double x : deform_ms) sum += x;
    log("deform     %zu frames (%d..%d step %d) of %d points: %.2f ms per frame (median %.2f, min %.2f, max %.2f); "
        "retarget %.2f ms, write %.2f ms per frame; largest displacement from rest %.3f\n",
        n, a, last, step, N, sum / double(n), sorted[n / 2], sorted.front(), sorted.back(), pose_ms / double(n),
        write_ms / double(n), max_move);
    log("output     %s\n",
        pc2 ? o.output.c_str() : (frame_path(o.output, a) + " .. " + frame_path(o.output, last)).c_str());
    (void)frame_time;
    return kOk;
}

}  // namespace

int main(int argc, char** argv) {
    try {
        const Options o = parse_args(argc, argv);
        return run(o);
    } catch (const Failure& e) {
        std::fprintf(stderr, "sweepdeform: error: %s\n", printable(e.what()).c_str());
        return e.code;
    } catch (const std::bad_alloc&) {
        std::fprintf(stderr, "sweepdeform: error: out of memory (an input larger than this machine can hold)\n");
        return kInput;
    } catch (const std::exception& e) {
        std::fprintf(stderr, "sweepdeform: error: %s\n", printable(e.what()).c_str());
        return kCore;
    }
}
