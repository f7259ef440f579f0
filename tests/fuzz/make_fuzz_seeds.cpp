// Writes the seed corpora of every fuzz target from the native tests' synthetic arm (the
// cases the unit tests use: rest, bent 90 and 170 degrees, the ring mesh, its fitting input):
//   make_fuzz_seeds <corpus dir>      (scripts/fuzz runs it; the output is in the repository)
// The readers' seeds (BVH, OBJ/PLY/OFF/XYZ, glTF) are small files of each format written here.
// Each seed follows its target's byte layout (sdfuzz::Bytes), so the fuzzer starts from
// inputs that reach deep into the code instead of failing the first check.
#include "fuzz_fixture.h"

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <string>

namespace {

std::string g_dir;

void write(const std::string& target, const std::string& name, const std::vector<uint8_t>& bytes) {
    std::filesystem::create_directories(g_dir + "/" + target);
    const std::string path = g_dir + "/" + target + "/" + name;
    FILE* f = std::fopen(path.c_str(), "wb");
    if (!f) {
        std::fprintf(stderr, "make_fuzz_seeds: cannot write %s\n", path.c_str());
        std::exit(1);
    }
    std::fwrite(bytes.data(), 1, bytes.size(), f);
    std::fclose(f);
}

struct Out {
    std::vector<uint8_t> b;
    template <class T>
    Out& put(T v) {
        const auto* p = reinterpret_cast<const uint8_t*>(&v);
        b.insert(b.end(), p, p + sizeof(T));
        return *this;
    }
    Out& text(const std::string& s) {
        b.insert(b.end(), s.begin(), s.end());
        return *this;
    }
};

std::vector<float> ring_mesh(int rings) {
    std::vector<float> mesh;
    for (int r = 0; r < rings; ++r)
        for (int s = 0; s < 8; ++s)
            mesh.insert(mesh.end(), {r / 5.0f, 0.1f * std::cos(s * 0.785f), 0.07f * std::sin(s * 0.785f)});
    return mesh;
}

void deform_seeds() {
    // volume flag, strength, offset, then per matrix value: mode >= 128 and the float itself.
    const float angles[] = {0.0f, 1.5708f, 2.967f};
    const char* names[] = {"rest", "bent90", "bent170"};
    for (int i = 0; i < 3; ++i)
        for (int vol = 0; vol < 2; ++vol) {
            Out o;
            o.put<uint8_t>(vol).put<float>(1.0f).put<float>(0.0f);
            for (float x : sdfuzz::bent_pose(angles[i])) o.put<uint8_t>(200).put<float>(x);
            write("fuzz_deform", std::string(names[i]) + (vol ? "_volume" : ""), o.b);
        }
}

void bind_seeds() {
    // V-1, S, K, positions, S*V sweep ids + weights, K*V bone ids + weights.
    const std::vector<float> mesh = ring_mesh(8);  // 64 points
    for (int slots = 1; slots <= 2; ++slots) {
        Out o;
        o.put<uint8_t>(63).put<uint8_t>(1).put<uint8_t>(static_cast<uint8_t>(slots));
        for (float x : mesh) o.put<float>(x);
        for (int v = 0; v < 64; ++v) o.put<int8_t>(0);
        for (int v = 0; v < 64; ++v) o.put<float>(1.0f);
        for (int s = 0; s < slots; ++s)
            for (int v = 0; v < 64; ++v) o.put<int8_t>(static_cast<int8_t>(std::min(2, v / 24 + s)));
        for (int s = 0; s < slots; ++s)
            for (int v = 0; v < 64; ++v) o.put<float>(1.0f / static_cast<float>(slots));
        write("fuzz_bind", "ring_" + std::to_string(slots) + "bones", o.b);
    }
}

void fit_seeds() {
    // V-3, T-1, scale mode (< 200: 0.05), per vertex mode < 220 and two jitters, triangles
    // int16, keys per link.
    for (int keys = 1; keys <= 2; ++keys) {
        const int V = 92, T = 200;
        Out o;
        o.put<uint8_t>(V - 3).put<uint8_t>(T - 1).put<uint8_t>(0);
        for (int v = 0; v < V; ++v) o.put<uint8_t>(0).put<int8_t>(static_cast<int8_t>(v % 7 - 3)).put<int8_t>(0);
        for (int t = 0; t < T; ++t) {  // neighbours along the tube and around it
            const int a = t % (V - 24);
            o.put<int16_t>(static_cast<int16_t>(a))
                .put<int16_t>(static_cast<int16_t>(a + 1 + (t & 1) * 22))
                .put<int16_t>(static_cast<int16_t>(a + 23));
        }
        o.put<uint8_t>(static_cast<uint8_t>(keys));
        write("fuzz_fit", "tube_keys" + std::to_string(keys), o.b);
    }
}

void rig_array_seeds(const sdfuzz::Arm& arm) {
    // B-1, parents, rest, heads, tails, K, per key: center, quaternion, half axes, fractions,
    // bone, joint parent (the arm of fuzz_fixture.h exactly).
    Out o;
    o.put<uint8_t>(2);
    for (int32_t p : arm.parents) o.put<int8_t>(static_cast<int8_t>(p));
    for (float x : arm.rest) o.put<float>(x);
    for (float x : arm.heads) o.put<float>(x);
    for (float x : arm.tails) o.put<float>(x);
    const int32_t bones[7] = {0, 0, 0, 1, 1, 1, 2}, joint_parents[7] = {-1, -1, -1, 0, -1, -1, 1};
    o.put<uint8_t>(7);
    for (int k = 0; k < 7; ++k) {
        o.put<float>(k / 3.0f).put<float>(0.01f).put<float>(0.0f);
        for (int i = 0; i < 4; ++i) o.put<float>(0.5f);
        o.put<float>(0.1f).put<float>(0.07f).put<float>(0.5f).put<float>(k == 6 ? 1.0f : 0.5f);
        o.put<int8_t>(static_cast<int8_t>(bones[k])).put<int8_t>(static_cast<int8_t>(joint_parents[k]));
    }
    write("fuzz_rig_arrays", "arm", o.b);
}

void correction_seeds() {
    // count, then per correction: sweep, key, angle, 8 values, op; then a key and angle to
    // evaluate, the bend (int8 / 40 rad).
    Out o;
    o.put<uint8_t>(2);
    const float values[2][8] = {{0.01f, 0.0f, 0.0f, 0.0f, 0.0f, 0.2f, 1.2f, 0.9f}, {0, 0.02f, 0, 0.1f, 0, 0, 1, 1.1f}};
    const float angle[2] = {1.5708f, 2.5f};
    for (int c = 0; c < 2; ++c) {
        o.put<int8_t>(0).put<int8_t>(3).put<float>(angle[c]);
        for (float v : values[c]) o.put<float>(v);
        o.put<uint8_t>(0);
    }
    o.put<uint8_t>(3).put<float>(2.0f).put<int8_t>(80);
    write("fuzz_corrections", "elbow_two", o.b);
}

void joint_volume_seeds() {
    // edits, (at, corner)*, fewer triangles, vertex count flag, then the pose as fuzz_deform.
    Out plain, bent;
    plain.put<uint8_t>(0).put<uint8_t>(0).put<uint8_t>(0);
    bent.put<uint8_t>(0).put<uint8_t>(0).put<uint8_t>(0);
    for (int i = 0; i < 48; ++i) bent.put<uint8_t>(0).put<int8_t>(i == 16 + 13 ? 20 : 0);
    write("fuzz_joint_volumes", "rest", plain.b);
    write("fuzz_joint_volumes", "bent", bent.b);
}

void anatomy_seeds() {
    // joints, per joint: 3 x (mode < 200, int8 / 64), bone, kind, effects, params, proxy flag;
    // feedback mode, restore, bend.
    for (int kind = 0; kind < 3; ++kind) {
        Out o;
        o.put<uint8_t>(1);
        for (int8_t d : {0, 64, 0}) o.put<uint8_t>(0).put<int8_t>(d);
        o.put<int8_t>(1).put<int8_t>(static_cast<int8_t>(kind)).put<int8_t>(7).put<uint8_t>(1);
        o.put<int8_t>(2).put<float>(0.15f).put<uint8_t>(0);
        o.put<int8_t>(1).put<uint8_t>(1).put<int8_t>(100);
        write("fuzz_anatomy", "joint_kind" + std::to_string(kind), o.b);
    }
}

void measure_seeds() {
    // A sheet (mode 0) of 6 x 1 quads, per vertex dx, dy (int8 / 32), z (int8 / 16): flat, and
    // folded back over itself from the fifth column on, passing down through the first part.
    for (int folded = 0; folded < 2; ++folded) {
        Out o;
        o.put<uint8_t>(0).put<uint8_t>(5).put<uint8_t>(0);
        const int8_t dx[7] = {0, 0, 0, 0, -48, -112, -125}, dz[7] = {0, 0, 0, 0, 8, -8, -16};
        for (int j = 0; j < 2; ++j)
            for (int i = 0; i < 7; ++i)
                o.put<int8_t>(folded ? dx[i] : 0).put<int8_t>(0).put<int8_t>(folded ? dz[i] : 0);
        write("fuzz_measure", folded ? "sheet_folded" : "sheet_flat", o.b);
    }
    // A soup (mode 1): two triangles crossing.
    Out o;
    o.put<uint8_t>(1).put<uint8_t>(3).put<uint8_t>(1);  // 6 points, 2 triangles
    const int8_t pts[18] = {0, 0, 0, 4, 0, 0, 0, 4, 0, 1, 1, -2, 1, 1, 2, 2, 2, 0};
    for (int8_t x : pts) o.put<int8_t>(x);
    for (uint8_t x : {0, 1, 2, 3, 4, 5}) o.put<uint8_t>(x);
    write("fuzz_measure", "soup_crossing", o.b);
}

void dmap_seeds() {
    // flips, theta cells, t cells, smoothing mode, N-1, per point: mode < 230 and x, y, z
    // (u8 / 110, int8 / 1000, int8 / 1000), snap.
    for (int snap = 0; snap < 2; ++snap) {
        Out o;
        o.put<uint8_t>(0).put<int16_t>(0).put<int8_t>(0).put<uint8_t>(0).put<uint8_t>(15);
        for (int i = 0; i < 16; ++i)
            o.put<uint8_t>(0).put<uint8_t>(static_cast<uint8_t>(12 * i + 6)).put<int8_t>(90).put<int8_t>(-40);
        o.put<float>(snap ? 1e30f : 0.1f);
        write("fuzz_dmap", snap ? "points_surface" : "points", o.b);
    }
}

/// A small skinned glTF: buffer views and accessors over one buffer, which goes into a .glb's
/// BIN chunk or a .gltf's data: URI.
class Gltf {
public:
    template <class T>
    int add(const std::vector<T>& values, int component_type, const char* type, size_t count, bool normalized = false) {
        while (data_.size() % 4) data_.push_back(0);
        const size_t offset = data_.size();
        const auto* bytes = reinterpret_cast<const uint8_t*>(values.data());
        data_.insert(data_.end(), bytes, bytes + values.size() * sizeof(T));
        const int index = count_++;
        views_ += std::string(index ? "," : "") + "{\"buffer\":0,\"byteOffset\":" + std::to_string(offset) +
                  ",\"byteLength\":" + std::to_string(values.size() * sizeof(T)) + "}";
        accessors_ += std::string(index ? "," : "") + "{\"bufferView\":" + std::to_string(index) +
                      ",\"componentType\":" + std::to_string(component_type) + ",\"count\":" + std::to_string(count) +
                      ",\"type\":\"" + type + "\"" + (normalized ? ",\"normalized\":true" : "") + "}";
        return index;
    }
    std::string json(const std::string& rest, bool embedded) const {
        std::string buffer = "{\"byteLength\":" + std::to_string(data_.size());
        if (embedded) {
            static const char* abc = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
            buffer += ",\"uri\":\"data:application/octet-stream;base64,";
            for (size_t i = 0; i < data_.size(); i += 3) {
                uint32_t n = uint32_t(data_[i]) << 16;
                if (i + 1 < data_.size()) n |= uint32_t(data_[i + 1]) << 8;
                if (i + 2 < data_.size()) n |= data_[i + 2];
                for (size_t k = 0; k < 4; ++k) buffer += i + k <= data_.size() ? abc[(n >> (18 - 6 * k)) & 63] : '=';
            }
            buffer += "\"";
        }
        return "{\"asset\":{\"version\":\"2.0\"},\"buffers\":[" + buffer + "}],\"bufferViews\":[" + views_ +
               "],\"accessors\":[" + accessors_ + "]," + rest + "}";
    }
    /// glTF 2.0 binary: 12-byte header, the JSON chunk (padded with spaces), the BIN chunk.
    std::vector<uint8_t> glb(const std::string& rest) const {
        std::string text = json(rest, false);
        while (text.size() % 4) text += ' ';
        std::vector<uint8_t> bin = data_;
        while (bin.size() % 4) bin.push_back(0);
        Out o;
        o.text("glTF").put<uint32_t>(2).put<uint32_t>(static_cast<uint32_t>(12 + 8 + text.size() + 8 + bin.size()));
        o.put<uint32_t>(static_cast<uint32_t>(text.size())).put<uint32_t>(0x4E4F534Au).text(text);
        o.put<uint32_t>(static_cast<uint32_t>(bin.size())).put<uint32_t>(0x004E4942u);
        o.b.insert(o.b.end(), bin.begin(), bin.end());
        return o.b;
    }

private:
    std::vector<uint8_t> data_;
    std::string views_, accessors_;
    int count_ = 0;
};

/// A closed square tube 1 unit long along +Y (three rings of four vertices, end caps) skinned
/// to a hip and a knee, with an animation using every interpolation. Variants: the skin's
/// joints listed child first (the loader reorders them), the knee's rest as a matrix, u16
/// joints with normalized u16 weights, a seam vertex to weld.
std::vector<uint8_t> tube_gltf(bool binary, bool child_first, bool knee_matrix, bool u16_skin, bool seam) {
    std::vector<float> pos;
    for (int r = 0; r < 3; ++r)
        for (int s = 0; s < 4; ++s)
            pos.insert(pos.end(), {0.1f * std::cos(1.5708f * s), 0.5f * r, 0.1f * std::sin(1.5708f * s)});
    std::vector<uint16_t> idx;
    for (int r = 0; r < 2; ++r)
        for (int s = 0; s < 4; ++s) {
            const auto a = static_cast<uint16_t>(4 * r + s), b = static_cast<uint16_t>(4 * r + (s + 1) % 4);
            idx.insert(idx.end(), {a, static_cast<uint16_t>(b + 4), b, a, static_cast<uint16_t>(a + 4),
                                   static_cast<uint16_t>(b + 4)});
        }
    idx.insert(idx.end(), {0, 1, 2, 0, 2, 3, 8, 10, 9, 8, 11, 10});
    if (seam) {  // vertex 12 duplicates vertex 0 and takes its place in the first triangle
        pos.insert(pos.end(), {pos[0], pos[1], pos[2]});
        idx[0] = 12;
    }
    const size_t V = pos.size() / 3;
    const int hip = child_first ? 1 : 0, knee = 1 - hip;  // skin joint indices
    std::vector<float> weights;                           // per vertex: hip weight, knee weight
    for (size_t v = 0; v < V; ++v) {
        const int ring = v == 12 ? 0 : static_cast<int>(v) / 4;
        const float k = 0.5f * ring;
        weights.insert(weights.end(), {1.0f - k, k});
    }
    Gltf g;
    const int a_pos = g.add(pos, 5126, "VEC3", V);
    const int a_idx = g.add(idx, 5123, "SCALAR", idx.size());
    int a_jnt, a_wgt;
    if (u16_skin) {
        std::vector<uint16_t> j, w;
        for (size_t v = 0; v < V; ++v) {
            j.insert(j.end(), {static_cast<uint16_t>(hip), static_cast<uint16_t>(knee), 0, 0});
            w.insert(w.end(), {static_cast<uint16_t>(65535 * weights[2 * v]),
                               static_cast<uint16_t>(65535 * weights[2 * v + 1]), 0, 0});
        }
        a_jnt = g.add(j, 5123, "VEC4", V);
        a_wgt = g.add(w, 5123, "VEC4", V, true);
    } else {
        std::vector<uint8_t> j;
        std::vector<float> w;
        for (size_t v = 0; v < V; ++v) {
            j.insert(j.end(), {static_cast<uint8_t>(hip), static_cast<uint8_t>(knee), 0, 0});
            w.insert(w.end(), {weights[2 * v], weights[2 * v + 1], 0.0f, 0.0f});
        }
        a_jnt = g.add(j, 5121, "VEC4", V);
        a_wgt = g.add(w, 5126, "VEC4", V);
    }
    // Column-major inverse bind matrices in skin joint order: hip at the origin, knee at y = 0.5.
    std::vector<float> ibm;
    for (int j = 0; j < 2; ++j)
        ibm.insert(ibm.end(), {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, j == knee ? -0.5f : 0, 0, 1});
    const int a_ibm = g.add(ibm, 5126, "MAT4", 2);
    const int a_time = g.add(std::vector<float>{0.0f, 1.0f}, 5126, "SCALAR", 2);
    const int a_rot = g.add(std::vector<float>{0, 0, 0, 1, 0.3826834f, 0, 0, 0.9238795f}, 5126, "VEC4", 2);
    const int a_move = g.add(std::vector<float>{0, 0, 0, 0, 0.1f, 0}, 5126, "VEC3", 2);
    const int a_scale =
        g.add(std::vector<float>{0, 0, 0, 1, 1, 1, 0, 0.5f, 0, 0, 0, 0, 1, 1.2f, 1, 0, 0, 0}, 5126, "VEC3", 6);
    const std::string knee_rest =
        knee_matrix ? "\"matrix\":[1,0,0,0,0,1,0,0,0,0,1,0,0,0.5,0,1]" : "\"translation\":[0,0.5,0]";
    const auto n = [](int i) { return std::to_string(i); };
    const std::string rest =
        "\"scene\":0,\"scenes\":[{\"nodes\":[0]}],"
        "\"nodes\":[{\"name\":\"Armature\",\"children\":[1,2]},{\"name\":\"leg\",\"mesh\":0,\"skin\":0},"
        "{\"name\":\"hip\",\"children\":[3]},{\"name\":\"knee\"," +
        knee_rest + "}],\"skins\":[{\"joints\":" + (child_first ? "[3,2]" : "[2,3]") +
        ",\"inverseBindMatrices\":" + n(a_ibm) +
        "}],\"meshes\":[{\"name\":\"leg\",\"primitives\":[{\"attributes\":{\"POSITION\":" + n(a_pos) +
        ",\"JOINTS_0\":" + n(a_jnt) + ",\"WEIGHTS_0\":" + n(a_wgt) + "},\"indices\":" + n(a_idx) +
        ",\"mode\":4}]}],\"animations\":[{\"name\":\"bend\",\"samplers\":[{\"input\":" + n(a_time) +
        ",\"output\":" + n(a_rot) + "},{\"input\":" + n(a_time) + ",\"output\":" + n(a_move) +
        ",\"interpolation\":\"STEP\"},{\"input\":" + n(a_time) + ",\"output\":" + n(a_scale) +
        ",\"interpolation\":\"CUBICSPLINE\"}],\"channels\":[{\"sampler\":0,\"target\":{\"node\":3,\"path\":"
        "\"rotation\"}},{\"sampler\":1,\"target\":{\"node\":2,\"path\":\"translation\"}},{\"sampler\":2,"
        "\"target\":{\"node\":3,\"path\":\"scale\"}}]}]";
    if (binary) return g.glb(rest);
    const std::string text = g.json(rest, true);
    return std::vector<uint8_t>(text.begin(), text.end());
}

void reader_seeds() {
    Out bvh;
    bvh.text(
        "HIERARCHY\nROOT Hips\n{\n  OFFSET 1 2 3\n  CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation "
        "Yrotation\n  JOINT Arm\n  {\n    OFFSET 0 5 0\n    CHANNELS 3 Zrotation Xrotation Yrotation\n    End Site\n"
        "    {\n      OFFSET 0 0 4\n    }\n  }\n}\nMOTION\nFrames: 2\nFrame Time: 0.05\n0 0 0 0 0 0 0 0 0\n"
        "1 2 3 10 20 30 40 -50 60\n");
    write("fuzz_bvh", "two_joints.bvh", bvh.b);
    // First byte: the extension (0 obj, 1 ply, 2 off, 3 xyz).
    write("fuzz_mesh_file", "pyramid.obj",
          Out()
              .put<uint8_t>(0)
              .text("v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0.5 0.5 1\nf 1 2 5\nf 2 3 5\nf 3 4 5\nf 4 1 5\nf 1 3 2\nf 1 "
                    "4 3\n")
              .b);
    write(
        "fuzz_mesh_file", "cloud.ply",
        Out()
            .put<uint8_t>(1)
            .text("ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
                  "element face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n")
            .b);
    write("fuzz_mesh_file", "quad.off",
          Out().put<uint8_t>(2).text("OFF\n4 1 0\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n4 0 1 2 3\n").b);
    write("fuzz_mesh_file", "points.xyz", Out().put<uint8_t>(3).text("# points\n1 2 3\n\n4 5 6 0.1 0.2 0.3\n").b);
    // First byte: the loader's options (bit 0 weld, bit 1 keep Y up), then the file.
    const auto gltf = [](uint8_t options, const std::vector<uint8_t>& file) {
        Out o;
        o.put<uint8_t>(options);
        o.b.insert(o.b.end(), file.begin(), file.end());
        return o.b;
    };
    write("fuzz_gltf", "tube.glb", gltf(0, tube_gltf(true, false, false, false, false)));
    write("fuzz_gltf", "tube_embedded.gltf", gltf(1, tube_gltf(false, false, false, false, true)));
    write("fuzz_gltf", "tube_child_first_matrix.glb", gltf(2, tube_gltf(true, true, true, true, false)));
}

}  // namespace

int main(int argc, char** argv) {
    if (argc < 2) {
        std::fprintf(stderr, "usage: make_fuzz_seeds <corpus dir>\n");
        return 2;
    }
    g_dir = argv[1];
    sdfuzz::Arm arm;
    write("fuzz_rig_blob", "arm.bin", arm.rig_blob());
    write("fuzz_binding_blob", "arm.bin", arm.binding_blob());
    {  // a rig carrying corrections (blob format with the correction section)
        sd_rig* rig = nullptr;
        const std::vector<uint8_t> blob = arm.rig_blob();
        sd_rig_deserialize(blob.data(), static_cast<int64_t>(blob.size()), &rig);
        const float values[8] = {0.01f, 0, 0, 0, 0, 0.2f, 1.2f, 0.9f};
        if (sd_rig_set_key_correction(rig, 0, 3, 1.5708f, values, 0, nullptr) != SD_OK) return 1;
        int64_t n = 0;
        sd_rig_serialize(rig, nullptr, 0, &n);
        std::vector<uint8_t> b(static_cast<size_t>(n));
        sd_rig_serialize(rig, b.data(), n, &n);
        write("fuzz_rig_blob", "arm_corrected.bin", b);
        sd_rig_destroy(rig);
    }
    deform_seeds();
    bind_seeds();
    fit_seeds();
    rig_array_seeds(arm);
    correction_seeds();
    anatomy_seeds();
    joint_volume_seeds();
    measure_seeds();
    dmap_seeds();
    reader_seeds();
    return 0;
}
