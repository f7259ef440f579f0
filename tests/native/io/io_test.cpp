// Tests of sweepdeform_io against the shared test characters (skipped when they are absent).
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <map>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "sweepdeform_io/animation.h"
#include "sweepdeform_io/character.h"
#include "sweepdeform_io/gltf_loader.h"
#include "sweepdeform_io/refine.h"

namespace {

namespace fs = std::filesystem;
using sd::io::Character;

const fs::path kData = SWEEPDEFORM_SHARED_DATA_DIR;

#define SKIP_WITHOUT_DATA()                                \
  do {                                                     \
    if (!fs::is_directory(kData)) {                        \
      GTEST_SKIP() << "../shared/data not found: skipped"; \
    }                                                      \
  } while (false)

std::string human(const char* name) { return (kData / "humans" / name).string(); }

size_t num_vertices(const Character& c) { return c.positions.size() / 3; }

struct Box {
  std::array<double, 3> lo{1e300, 1e300, 1e300}, hi{-1e300, -1e300, -1e300};
  double diagonal() const {
    double d2 = 0;
    for (int k = 0; k < 3; ++k) d2 += (hi[k] - lo[k]) * (hi[k] - lo[k]);
    return std::sqrt(d2);
  }
};

Box bbox(const std::vector<float>& p) {
  Box b;
  for (size_t i = 0; i < p.size(); ++i) {
    b.lo[i % 3] = std::min(b.lo[i % 3], double(p[i]));
    b.hi[i % 3] = std::max(b.hi[i % 3], double(p[i]));
  }
  return b;
}

/// Edges used by exactly one triangle.
size_t boundary_edges(const std::vector<int32_t>& tris) {
  std::map<std::pair<int32_t, int32_t>, int> uses;
  for (size_t t = 0; t < tris.size(); t += 3)
    for (int k = 0; k < 3; ++k) {
      int32_t a = tris[t + k], b = tris[t + (k + 1) % 3];
      ++uses[{std::min(a, b), std::max(a, b)}];
    }
  return static_cast<size_t>(std::count_if(uses.begin(), uses.end(), [](auto& e) { return e.second == 1; }));
}

/// Column-major 4x4 product and rigid inverse helpers (double).
using M4 = std::array<double, 16>;
M4 load(const float* m) {
  M4 r;
  for (int i = 0; i < 16; ++i) r[i] = m[i];
  return r;
}
M4 mul(const M4& a, const M4& b) {
  M4 r{};
  for (int c = 0; c < 4; ++c)
    for (int k = 0; k < 4; ++k)
      for (int i = 0; i < 4; ++i) r[4 * c + k] += a[4 * i + k] * b[4 * c + i];
  return r;
}
/// General affine inverse (3x3 block by cofactors).
M4 inverse_affine(const M4& m) {
  const double a = m[0], b = m[4], c = m[8], d = m[1], e = m[5], f = m[9], g = m[2], h = m[6], i = m[10];
  const double det = a * (e * i - f * h) - b * (d * i - f * g) + c * (d * h - e * g);
  M4 r{};
  r[0] = (e * i - f * h) / det;
  r[4] = (c * h - b * i) / det;
  r[8] = (b * f - c * e) / det;
  r[1] = (f * g - d * i) / det;
  r[5] = (a * i - c * g) / det;
  r[9] = (c * d - a * f) / det;
  r[2] = (d * h - e * g) / det;
  r[6] = (b * g - a * h) / det;
  r[10] = (a * e - b * d) / det;
  for (int k = 0; k < 3; ++k) r[12 + k] = -(r[k] * m[12] + r[4 + k] * m[13] + r[8 + k] * m[14]);
  r[15] = 1;
  return r;
}

/// Linear-blend skinning of the rest mesh with pose[b] * inverse(rest[b]).
std::vector<float> skin(const Character& c, const std::vector<float>& pose) {
  const size_t nb = c.bone_names.size();
  std::vector<M4> s(nb);
  for (size_t b = 0; b < nb; ++b) s[b] = mul(load(&pose[16 * b]), inverse_affine(load(&c.bone_rest[16 * b])));
  std::vector<float> out(c.positions.size());
  for (size_t v = 0; v < num_vertices(c); ++v)
    for (int k = 0; k < 3; ++k) {
      double x = 0;
      for (int j = 0; j < 4; ++j) {
        const M4& m = s[c.skin_joints[4 * v + j]];
        const float* p = &c.positions[3 * v];
        x += c.skin_weights[4 * v + j] * (m[k] * p[0] + m[4 + k] * p[1] + m[8 + k] * p[2] + m[12 + k]);
      }
      out[3 * v + k] = float(x);
    }
  return out;
}

/// Signed volume enclosed by the triangles: > 0 when they are counter-clockwise seen from outside.
double signed_volume(const Character& c) {
  double v = 0;
  for (size_t t = 0; t < c.triangles.size(); t += 3) {
    const float* a = &c.positions[3 * c.triangles[t]];
    const float* b = &c.positions[3 * c.triangles[t + 1]];
    const float* d = &c.positions[3 * c.triangles[t + 2]];
    v +=
        (a[0] * (b[1] * d[2] - b[2] * d[1]) - a[1] * (b[0] * d[2] - b[2] * d[0]) + a[2] * (b[0] * d[1] - b[1] * d[0])) /
        6.0;
  }
  return v;
}

bool all_finite(const std::vector<float>& v) {
  return std::all_of(v.begin(), v.end(), [](float x) { return std::isfinite(x); });
}

void expect_weights_sum_to_one(const Character& c) {
  for (size_t v = 0; v < num_vertices(c); ++v) {
    double sum = 0;
    for (int k = 0; k < 4; ++k) sum += c.skin_weights[4 * v + k];
    ASSERT_NEAR(sum, 1.0, 1e-5) << "vertex " << v;
  }
}

/// Index of a bone by name, -1 when absent.
int bone(const Character& c, const std::string& name) {
  auto it = std::find(c.bone_names.begin(), c.bone_names.end(), name);
  return it == c.bone_names.end() ? -1 : int(it - c.bone_names.begin());
}

// ------------------------------------------------------------------------------------------------

TEST(GltfLoader, MakeHumanCountsAxesAndWeights) {
  SKIP_WITHOUT_DATA();
  const Character c = sd::io::load_gltf_character(human("mh_male_game_engine.glb"));
  EXPECT_EQ(sd::io::validate(c), "");
  EXPECT_EQ(num_vertices(c), 13380u);
  EXPECT_EQ(c.triangles.size() / 3, 26756u);
  EXPECT_EQ(boundary_edges(c.triangles), 0u);
  EXPECT_GT(signed_volume(c), 0.05);  // outward-facing, a ~70 litre body
  ASSERT_EQ(c.bone_names.size(), 53u);
  EXPECT_EQ(c.bone_names[0], "Root");
  EXPECT_EQ(c.bone_parents[0], -1);
  EXPECT_TRUE(c.animations.empty());
  expect_weights_sum_to_one(c);

  // Blender axes: metres, Z-up, feet on z = 0, 1.748 m tall, symmetric in x, facing -Y
  // (the nose is the most negative y of the head).
  const Box b = bbox(c.positions);
  EXPECT_NEAR(b.lo[2], 0.0, 1e-3);
  EXPECT_NEAR(b.hi[2], 1.748, 2e-3);
  EXPECT_NEAR(b.lo[0], -b.hi[0], 1e-3);
  EXPECT_LT(b.hi[1] - b.lo[1], 0.6);  // shallow in y, wide in x (A-pose arms)
  const int head = bone(c, "head");
  ASSERT_GE(head, 0);
  EXPECT_GT(c.bone_heads[3 * head + 2], 1.4f);
  // Bones point where Blender's do: thigh down, upper arm outwards and down.
  const int thigh = bone(c, "thigh_l"), arm = bone(c, "upperarm_l");
  ASSERT_GE(thigh, 0);
  ASSERT_GE(arm, 0);
  EXPECT_LT(c.bone_tails[3 * thigh + 2], c.bone_heads[3 * thigh + 2] - 0.3f);
  EXPECT_GT(c.bone_tails[3 * arm], c.bone_heads[3 * arm] + 0.1f);  // left = +x in Blender
  // Bone heads are the rest translations; the rest matrices are rigid.
  for (size_t j = 0; j < c.bone_names.size(); ++j) {
    const float* m = &c.bone_rest[16 * j];
    for (int k = 0; k < 3; ++k) {
      EXPECT_FLOAT_EQ(c.bone_heads[3 * j + k], m[12 + k]);
      double n = m[4 * k] * m[4 * k] + m[4 * k + 1] * m[4 * k + 1] + m[4 * k + 2] * m[4 * k + 2];
      EXPECT_NEAR(n, 1.0, 1e-4) << c.bone_names[j];
    }
  }
}

TEST(GltfLoader, MakeHumanWithoutAxisChangeIsYUp) {
  SKIP_WITHOUT_DATA();
  sd::io::GltfLoadOptions o;
  o.to_blender_axes = false;
  const Character c = sd::io::load_gltf_character(human("mh_male_game_engine.glb"), o);
  const Box b = bbox(c.positions);
  EXPECT_NEAR(b.lo[1], 0.0, 1e-3);
  EXPECT_NEAR(b.hi[1], 1.748, 2e-3);
}

TEST(GltfLoader, MakeHumanSubdiv1) {
  SKIP_WITHOUT_DATA();
  const Character c = sd::io::load_gltf_character(human("mh_male_game_engine_subdiv1.glb"));
  EXPECT_EQ(sd::io::validate(c), "");
  EXPECT_EQ(num_vertices(c), 53514u);
  EXPECT_EQ(c.triangles.size() / 3, 107024u);
  EXPECT_EQ(c.bone_names.size(), 53u);
}

TEST(GltfLoader, CesiumManUprightAndWelded) {
  SKIP_WITHOUT_DATA();
  const Character raw = sd::io::load_gltf_character(human("CesiumMan.glb"));
  EXPECT_EQ(sd::io::validate(raw), "");
  EXPECT_EQ(num_vertices(raw), 3273u);
  EXPECT_EQ(raw.triangles.size() / 3, 4672u);
  EXPECT_EQ(raw.bone_names.size(), 19u);
  EXPECT_EQ(raw.bone_names[0], "Skeleton_torso_joint_1");
  ASSERT_EQ(raw.animations.size(), 1u);
  EXPECT_NEAR(raw.animations[0].duration_s, 2.0, 0.01);

  sd::io::GltfLoadOptions o;
  o.weld = true;
  const Character c = sd::io::load_gltf_character(human("CesiumMan.glb"), o);
  EXPECT_EQ(sd::io::validate(c), "");
  EXPECT_EQ(num_vertices(c), 2338u);
  EXPECT_EQ(c.triangles.size() / 3, 4672u);
  EXPECT_EQ(boundary_edges(c.triangles), 0u);
  EXPECT_GT(signed_volume(c), 0.0);
  expect_weights_sum_to_one(c);

  // About 1.51 m tall, upright in Z, standing on z ~ 0.
  const Box b = bbox(c.positions);
  EXPECT_NEAR(b.hi[2] - b.lo[2], 1.51, 0.02);
  EXPECT_GT(b.hi[2] - b.lo[2], 1.5 * std::max(b.hi[0] - b.lo[0], b.hi[1] - b.lo[1]) - 0.5);
  EXPECT_NEAR(b.lo[2], 0.0, 0.05);
}

TEST(GltfLoader, MissingFileThrows) {
  EXPECT_THROW(sd::io::load_gltf_character("/nonexistent/file.glb"), std::runtime_error);
}

TEST(Animation, MakeHumanClipsGivePlausibleMeshes) {
  SKIP_WITHOUT_DATA();
  const Character c = sd::io::load_gltf_character(human("mh_male_game_engine_anims.glb"));
  EXPECT_EQ(sd::io::validate(c), "");
  EXPECT_EQ(num_vertices(c), 13380u);
  ASSERT_EQ(c.animations.size(), 4u);
  EXPECT_EQ(c.animations[0].name, "cmu_01_03_climb_hang");
  EXPECT_NEAR(c.animations[0].duration_s, 20.033, 1e-3);
  EXPECT_NEAR(c.animations[1].duration_s, 4.8, 1e-3);
  EXPECT_EQ(sd::io::rest_pose(c), c.bone_rest);

  // Skin every 0.5 s (and past the end). Real motion changes the bounding-box diagonal a lot:
  // measured at every frame it spans 0.75-1.30 x rest (climb_hang curls up, the cartwheel
  // spreads its limbs), so 20% would be too tight; a broken skin explodes far beyond 1.4.
  const double rest_diag = bbox(c.positions).diagonal();
  for (int a = 0; a < 4; ++a) {
    const double d = c.animations[a].duration_s;
    for (double t = 0.0; t <= d + 1.0; t += 0.5) {
      const std::vector<float> pose = sd::io::sample_pose(c, a, t);
      ASSERT_EQ(pose.size(), 16 * c.bone_names.size());
      ASSERT_TRUE(all_finite(pose));
      const std::vector<float> posed = skin(c, pose);
      ASSERT_TRUE(all_finite(posed));
      const double ratio = bbox(posed).diagonal() / rest_diag;
      EXPECT_GT(ratio, 0.6) << c.animations[a].name << " t=" << t;
      EXPECT_LT(ratio, 1.4) << c.animations[a].name << " t=" << t;
    }
  }
}

TEST(Animation, NodeRestPoseIsTheBindPose) {
  SKIP_WITHOUT_DATA();
  // Both files bind the mesh in their node rest pose: animation -1 gives back bone_rest.
  for (const char* file : {"mh_male_game_engine.glb", "CesiumMan.glb"}) {
    const Character c = sd::io::load_gltf_character(human(file));
    const std::vector<float> pose = sd::io::sample_pose(c, -1, 0.0);
    ASSERT_EQ(pose.size(), c.bone_rest.size());
    for (size_t i = 0; i < pose.size(); ++i) EXPECT_NEAR(pose[i], c.bone_rest[i], 1e-4) << file << " " << i;
  }
}

TEST(Animation, CesiumManWalks) {
  SKIP_WITHOUT_DATA();
  sd::io::GltfLoadOptions o;
  o.weld = true;
  const Character c = sd::io::load_gltf_character(human("CesiumMan.glb"), o);
  const Box rest = bbox(c.positions);
  for (double t = 0.0; t <= 2.0; t += 0.25) {
    const std::vector<float> posed = skin(c, sd::io::sample_pose(c, 0, t));
    ASSERT_TRUE(all_finite(posed));
    const Box b = bbox(posed);
    EXPECT_NEAR(b.diagonal(), rest.diagonal(), 0.2 * rest.diagonal()) << "t=" << t;
    EXPECT_GT(b.hi[2] - b.lo[2], 1.2) << "still upright at t=" << t;
  }
  EXPECT_THROW(sd::io::sample_pose(c, 1, 0.0), std::out_of_range);
}

TEST(GltfLoader, AxisChangeIsA) {
  SKIP_WITHOUT_DATA();
  // Blender axes = (x, -z, y) of glTF's, for points and (on the left) for bone matrices.
  sd::io::GltfLoadOptions yup;
  yup.to_blender_axes = false;
  const Character g = sd::io::load_gltf_character(human("mh_male_game_engine_anims.glb"), yup);
  const Character b = sd::io::load_gltf_character(human("mh_male_game_engine_anims.glb"));
  ASSERT_EQ(g.positions.size(), b.positions.size());
  for (size_t i = 0; i < g.positions.size(); i += 3) {
    ASSERT_FLOAT_EQ(b.positions[i], g.positions[i]);
    ASSERT_FLOAT_EQ(b.positions[i + 1], -g.positions[i + 2]);
    ASSERT_FLOAT_EQ(b.positions[i + 2], g.positions[i + 1]);
  }
  const std::vector<float> pg = sd::io::sample_pose(g, 1, 2.0), pb = sd::io::sample_pose(b, 1, 2.0);
  for (const auto& [mg, mb] : {std::pair{&g.bone_rest, &b.bone_rest}, std::pair{&pg, &pb}})
    for (size_t j = 0; j < mg->size(); j += 4) {  // each column (x, y, z, w) -> (x, -z, y, w)
      EXPECT_NEAR((*mb)[j], (*mg)[j], 1e-5);
      EXPECT_NEAR((*mb)[j + 1], -(*mg)[j + 2], 1e-5);
      EXPECT_NEAR((*mb)[j + 2], (*mg)[j + 1], 1e-5);
    }
  EXPECT_EQ(g.skin_joints, b.skin_joints);
}

TEST(GltfLoader, WeldKeepsAClosedMesh) {
  SKIP_WITHOUT_DATA();
  sd::io::GltfLoadOptions o;
  o.weld = true;
  const Character c = sd::io::load_gltf_character(human("mh_male_game_engine.glb"), o);
  EXPECT_EQ(num_vertices(c), 13380u);  // no seams to weld
  EXPECT_EQ(c.triangles.size() / 3, 26756u);
  for (size_t v = 0; v < num_vertices(c); ++v)  // weights sorted, unused slots index 0
    for (int k = 1; k < 4; ++k) {
      ASSERT_LE(c.skin_weights[4 * v + k], c.skin_weights[4 * v + k - 1]);
      if (c.skin_weights[4 * v + k] == 0.0f) {
        ASSERT_EQ(c.skin_joints[4 * v + k], 0);
      }
    }
}

/// Writes a small .gltf (JSON with an embedded base64 buffer) exercising the accessor formats
/// that the shared files do not use. Two joints listed child first: skin joint 0 = "knee"
/// (node 3, child of node 2), skin joint 1 = "hip". Two primitives of one mesh:
///   A: 3 vertices, u32 indices, JOINTS_0 u8, WEIGHTS_0 normalized u8;
///   B: 3 vertices, no indices, JOINTS_0 u16, WEIGHTS_0 normalized u16.
class TinyGltfWriter {
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
  /// The glTF text; the buffer embedded as a data: URI, or in the external file `uri`.
  std::string json(const std::string& rest, const std::string& uri = "") const {
    static const char* abc = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    std::string b64;
    for (size_t i = 0; i < data_.size(); i += 3) {
      uint32_t n = uint32_t(data_[i]) << 16;
      if (i + 1 < data_.size()) n |= uint32_t(data_[i + 1]) << 8;
      if (i + 2 < data_.size()) n |= data_[i + 2];
      for (int k = 0; k < 4; ++k) b64 += i + size_t(k) <= data_.size() ? abc[(n >> (18 - 6 * k)) & 63] : '=';
    }
    return "{\"asset\":{\"version\":\"2.0\"},\"buffers\":[{\"byteLength\":" + std::to_string(data_.size()) +
           ",\"uri\":\"" + (uri.empty() ? "data:application/octet-stream;base64," + b64 : uri) +
           "\"}],\"bufferViews\":[" + views_ + "],\"accessors\":[" + accessors_ + "]," + rest + "}";
  }
  const std::vector<uint8_t>& buffer() const { return data_; }

 private:
  std::vector<uint8_t> data_;
  std::string views_, accessors_;
  int count_ = 0;
};

/// external_buffer: the buffer goes into this file beside the .gltf instead of a data: URI.
/// positions_a: primitive A's three vertices (x, y, z each).
std::string write_synthetic_gltf(const std::string& name, int mode_of_b, const std::string& external_buffer = "",
                                 const std::vector<float>& positions_a = {0, 0, 0, 1, 0, 0, 0.1f, 0.4f, 0}) {
  TinyGltfWriter w;
  const int pos_a = w.add(positions_a, 5126, "VEC3", 3);
  const int idx_a = w.add(std::vector<uint32_t>{0, 1, 2}, 5125, "SCALAR", 3);
  const int jnt_a = w.add(std::vector<uint8_t>{0, 1, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0}, 5121, "VEC4", 3);
  const int wgt_a = w.add(std::vector<uint8_t>{255, 0, 0, 0, 51, 204, 0, 0, 0, 0, 0, 0}, 5121, "VEC4", 3, true);
  const int pos_b = w.add(std::vector<float>{0, 2, 0, 1, 2, 0, 0, 3, 0}, 5126, "VEC3", 3);
  const int jnt_b = w.add(std::vector<uint16_t>{0, 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0}, 5123, "VEC4", 3);
  const int wgt_b = w.add(std::vector<uint16_t>{65535, 0, 0, 0, 65535, 0, 0, 0, 32768, 0, 0, 0}, 5123, "VEC4", 3, true);
  // Column-major inverse bind matrices: knee at (0, 1, 0), hip at the origin.
  const int ibm = w.add(std::vector<float>{1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, -1, 0, 1,
                                           1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0,  0, 1},
                        5126, "MAT4", 2);
  auto attrs = [](int p, int j, int wt) {
    return "{\"POSITION\":" + std::to_string(p) + ",\"JOINTS_0\":" + std::to_string(j) +
           ",\"WEIGHTS_0\":" + std::to_string(wt) + "}";
  };
  const std::string rest =
      "\"scene\":0,\"scenes\":[{\"nodes\":[0]}],"
      "\"nodes\":[{\"name\":\"Armature\",\"children\":[1,2]},{\"name\":\"body\",\"mesh\":0,\"skin\":0},"
      "{\"name\":\"hip\",\"children\":[3]},{\"name\":\"knee\",\"translation\":[0,1,0]}],"
      "\"skins\":[{\"joints\":[3,2],\"inverseBindMatrices\":" +
      std::to_string(ibm) +
      "}],"
      "\"meshes\":[{\"name\":\"body\",\"primitives\":[{\"attributes\":" +
      attrs(pos_a, jnt_a, wgt_a) + ",\"indices\":" + std::to_string(idx_a) +
      "},{\"attributes\":" + attrs(pos_b, jnt_b, wgt_b) + ",\"mode\":" + std::to_string(mode_of_b) + "}]}]";
  const fs::path path = fs::temp_directory_path() / name;
  std::ofstream(path) << w.json(rest, external_buffer);
  if (!external_buffer.empty())
    std::ofstream(fs::temp_directory_path() / external_buffer, std::ios::binary)
        .write(reinterpret_cast<const char*>(w.buffer().data()), static_cast<std::streamsize>(w.buffer().size()));
  return path.string();
}

std::vector<uint8_t> file_bytes(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  return std::vector<uint8_t>((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
}

TEST(GltfLoader, SyntheticAccessorFormats) {
  const std::string path = write_synthetic_gltf("sweepdeform_io_test.gltf", 4);
  sd::io::GltfLoadOptions o;
  o.to_blender_axes = false;
  const Character c = sd::io::load_gltf_character(path, o);
  EXPECT_EQ(sd::io::validate(c), "");
  ASSERT_EQ(num_vertices(c), 6u);
  EXPECT_EQ(c.triangles, (std::vector<int32_t>{0, 1, 2, 3, 4, 5}));
  EXPECT_EQ(c.bone_names, (std::vector<std::string>{"hip", "knee"}));  // parents first
  EXPECT_EQ(c.bone_parents, (std::vector<int32_t>{-1, 0}));
  EXPECT_FLOAT_EQ(c.bone_heads[4], 1.0f);  // knee head at y = 1
  // Skin joint 0 (knee) is bone 1; weights normalised and sorted.
  EXPECT_EQ(c.skin_joints[0], 1);
  EXPECT_FLOAT_EQ(c.skin_weights[0], 1.0f);
  EXPECT_EQ(c.skin_joints[4], 1);  // 204/255 on the knee before 51/255 on the hip
  EXPECT_EQ(c.skin_joints[5], 0);
  EXPECT_NEAR(c.skin_weights[4], 0.8, 1e-6);
  EXPECT_NEAR(c.skin_weights[5], 0.2, 1e-6);
  EXPECT_EQ(c.skin_joints[8], 0);  // vertex 2 has no weight: nearest bone segment (hip)
  EXPECT_FLOAT_EQ(c.skin_weights[8], 1.0f);
  EXPECT_EQ(c.skin_joints[5 * 4], 0);  // u16: joint 1 (hip) = bone 0, 32768/65535 -> 1
  EXPECT_FLOAT_EQ(c.skin_weights[5 * 4], 1.0f);

  const std::string points = write_synthetic_gltf("sweepdeform_io_test_points.gltf", 0);
  try {
    sd::io::load_gltf_character(points);
    ADD_FAILURE() << "a POINTS primitive should be rejected";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("TRIANGLES"), std::string::npos) << e.what();
  }
  fs::remove(path);
  fs::remove(points);
}

TEST(GltfLoader, FromMemoryAsFromFileWithoutExternalFiles) {
  sd::io::GltfLoadOptions o;
  o.weld = true;
  const std::string path = write_synthetic_gltf("sweepdeform_io_memory.gltf", 4);
  const Character f = sd::io::load_gltf_character(path, o);
  const std::vector<uint8_t> bytes = file_bytes(path);
  const Character m = sd::io::load_gltf_character_from_memory(bytes.data(), bytes.size(), "memory.gltf", o);
  EXPECT_EQ(m.positions, f.positions);
  EXPECT_EQ(m.triangles, f.triangles);
  EXPECT_EQ(m.bone_names, f.bone_names);
  EXPECT_EQ(m.bone_rest, f.bone_rest);
  EXPECT_EQ(m.skin_joints, f.skin_joints);
  EXPECT_EQ(m.skin_weights, f.skin_weights);

  // A buffer in a file beside the .gltf: read when loading the file, refused from memory.
  const std::string external = write_synthetic_gltf("sweepdeform_io_external.gltf", 4, "sweepdeform_io_external.bin");
  EXPECT_EQ(sd::io::load_gltf_character(external, o).positions, f.positions);
  const std::vector<uint8_t> text = file_bytes(external);
  try {
    sd::io::load_gltf_character_from_memory(text.data(), text.size(), "memory.gltf", o);
    ADD_FAILURE() << "an external buffer should be refused when loading from memory";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("external file 'sweepdeform_io_external.bin' not read"), std::string::npos)
        << e.what();
  }
  EXPECT_THROW(sd::io::load_gltf_character_from_memory(nullptr, 0, "empty", o), std::runtime_error);
  EXPECT_THROW(sd::io::load_gltf_character(fs::temp_directory_path().string()), std::runtime_error);  // a directory
  fs::remove(path);
  fs::remove(external);
  fs::remove(fs::temp_directory_path() / "sweepdeform_io_external.bin");
}

/// The fuzz target's seeds (make_fuzz_seeds: first byte the options, then the file) are valid
/// characters, so that fuzz_gltf starts from inputs that reach the whole loader.
TEST(GltfLoader, FuzzSeedsLoad) {
  int seeds = 0;
  for (const auto& entry : fs::directory_iterator(SWEEPDEFORM_FUZZ_CORPUS_DIR "/fuzz_gltf")) {
    if (entry.path().filename().string().rfind("tube", 0) != 0) continue;
    SCOPED_TRACE(entry.path().string());
    ++seeds;
    const std::vector<uint8_t> b = file_bytes(entry.path().string());
    ASSERT_GT(b.size(), 1u);
    sd::io::GltfLoadOptions o;
    o.weld = (b[0] & 1) != 0;
    o.to_blender_axes = (b[0] & 2) == 0;
    const Character c = sd::io::load_gltf_character_from_memory(b.data() + 1, b.size() - 1, "seed", o);
    EXPECT_EQ(c.bone_names, (std::vector<std::string>{"hip", "knee"}));
    EXPECT_EQ(c.bone_parents, (std::vector<int32_t>{-1, 0}));
    EXPECT_EQ(num_vertices(c), 12u);  // the seam vertex of the welded seed merged
    EXPECT_EQ(c.triangles.size(), 60u);
    EXPECT_EQ(boundary_edges(c.triangles), 0u);
    ASSERT_EQ(c.animations.size(), 1u);
    EXPECT_EQ(c.animations[0].channels.size(), 3u);
    // At t = 1 the knee is turned 45 degrees about X relative to the hip, which moved by 0.1.
    const std::vector<float> pose = sd::io::sample_pose(c, 0, 1.0);
    const float up = o.to_blender_axes ? pose[16 + 13 + 1] : pose[16 + 13];  // knee head height
    EXPECT_NEAR(up, 0.6f, 1e-5f);
    const float c_y_y = pose[16 + 5], c_y_z = pose[16 + 6];  // knee's local Y axis, in Y-up axes
    const float y_y = o.to_blender_axes ? pose[16 + 6] : c_y_y, y_z = o.to_blender_axes ? -pose[16 + 5] : c_y_z;
    EXPECT_NEAR(std::atan2(y_z, y_y), 0.7853982, 1e-5);
  }
  EXPECT_EQ(seeds, 3);
}

/// Regression seeds of fuzz_gltf: an accessor without data claiming 4e9 elements asked for
/// 48 GB (found by hand before the first run of fuzz_gltf, which would have found it); a count
/// near 2^64 / 12 made (count - 1) * stride wrap around to 8, passing the bounds check (it then
/// failed with std::vector's length_error rather than a message about the file).
TEST(GltfLoader, RefusesCountsBeyondTheFile) {
  const std::pair<const char*, const char*> cases[] = {
      {"regress_zero_accessor_huge_count", "accessor 0 without data claims 4000000000 elements"},
      {"regress_accessor_count_wraps", "accessor data lies outside its buffer"}};
  for (const auto& [seed, message] : cases) {
    const std::vector<uint8_t> b = file_bytes(SWEEPDEFORM_FUZZ_CORPUS_DIR "/fuzz_gltf/" + std::string(seed));
    ASSERT_GT(b.size(), 1u) << seed;
    try {
      sd::io::load_gltf_character_from_memory(b.data() + 1, b.size() - 1, seed);
      ADD_FAILURE() << seed << " should be refused";
    } catch (const std::runtime_error& e) {
      EXPECT_NE(std::string(e.what()).find(message), std::string::npos) << e.what();
    }
  }
}

/// Welding a glTF whose vertices lie far from the origin, or are not numbers: the weld's grid
/// cell of a vertex at -8e24 (1e-6 of the bounding box wide) was undefined behaviour (fuzz_gltf's
/// 600 s pass, regress_weld_huge_coordinate; the sanitizer build catches it), and a NaN vertex
/// passed the distance test (NaN > tolerance is false): only its hash cell kept it from being
/// welded away before validate() saw it.
TEST(GltfLoader, WeldFarAndNonFiniteVertices) {
  const std::vector<uint8_t> b = file_bytes(SWEEPDEFORM_FUZZ_CORPUS_DIR "/fuzz_gltf/regress_weld_huge_coordinate");
  ASSERT_GT(b.size(), 1u);
  sd::io::GltfLoadOptions o;
  o.weld = true;
  try {
    const Character c = sd::io::load_gltf_character_from_memory(b.data() + 1, b.size() - 1, "far", o);
    EXPECT_EQ(sd::io::validate(c), "");
  } catch (const std::runtime_error&) {  // refusing it is fine too; undefined behaviour is not
  }
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const std::string path = write_synthetic_gltf("sweepdeform_io_nan.gltf", 4, "", {0, 0, 0, 1, 0, 0, nan, 0.4f, 0});
  try {
    sd::io::load_gltf_character(path, o);
    ADD_FAILURE() << "a NaN vertex should be refused, not welded away";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("inconsistent character"), std::string::npos) << e.what();
  }
  fs::remove(path);
}

/// Two bones: a root at the origin and a child 1 unit up its parent's Y, with channels
/// on both nodes. No data file needed.
Character two_bone_rig() {
  Character c;
  c.bone_names = {"root", "child"};
  c.bone_parents = {-1, 0};
  sd::io::NodeTree& t = c.nodes;
  t.names = c.bone_names;
  t.parents = {-1, 0};
  t.rest_translation = {0, 0, 0, 0, 1, 0};
  t.rest_rotation = {0, 0, 0, 1, 0, 0, 0, 1};
  t.rest_scale = {1, 1, 1, 1, 1, 1};
  t.rest_matrix = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 1, 0, 1};
  t.bone_node = {0, 1};
  sd::io::Animation a;
  a.name = "test";
  a.duration_s = 1.0;
  sd::io::Channel rot;  // child: 0 -> 90 degrees about Z
  rot.node = 1;
  rot.path = sd::io::Channel::Path::Rotation;
  rot.times = {0.0f, 1.0f};
  const float h = float(std::sqrt(0.5));
  rot.values = {0, 0, 0, 1, 0, 0, h, h};
  a.channels.push_back(rot);
  sd::io::Channel move;  // root: cubic spline (0,0,0) -> (2,0,0) with zero tangents
  move.node = 0;
  move.path = sd::io::Channel::Path::Translation;
  move.interpolation = sd::io::Channel::Interpolation::CubicSpline;
  move.times = {0.0f, 1.0f};
  move.values = {0, 0, 0, 0, 0, 0, 0, 0, 0,   // key 0: in-tangent, value, out-tangent
                 0, 0, 0, 2, 0, 0, 0, 0, 0};  // key 1
  a.channels.push_back(move);
  c.animations.push_back(a);
  return c;
}

TEST(Animation, InterpolationModes) {
  Character c = two_bone_rig();
  const double pi = std::acos(-1.0);
  auto child_angle = [&](const std::vector<float>& p) { return std::atan2(p[16 + 1], p[16 + 0]); };

  std::vector<float> p = sd::io::sample_pose(c, 0, 0.5);
  EXPECT_NEAR(child_angle(p), pi / 4, 1e-6);  // slerp halfway
  EXPECT_NEAR(p[12], 1.0, 1e-6);              // Hermite midpoint
  EXPECT_NEAR(p[16 + 13], 1.0, 1e-6);         // child stays 1 up from the root
  p = sd::io::sample_pose(c, 0, 0.25);
  EXPECT_NEAR(p[12], 2.0 * (3 * 0.0625 - 2 * 0.015625), 1e-6);             // smoothstep(0.25) * 2
  EXPECT_NEAR(child_angle(sd::io::sample_pose(c, 0, -1.0)), 0.0, 1e-6);    // clamped
  EXPECT_NEAR(child_angle(sd::io::sample_pose(c, 0, 7.0)), pi / 2, 1e-6);  // clamped
  EXPECT_NEAR(child_angle(sd::io::sample_pose(c, -1, 0.5)), 0.0, 1e-6);    // no animation

  c.animations[0].channels[0].interpolation = sd::io::Channel::Interpolation::Step;
  EXPECT_NEAR(child_angle(sd::io::sample_pose(c, 0, 0.99)), 0.0, 1e-6);
  EXPECT_NEAR(child_angle(sd::io::sample_pose(c, 0, 1.0)), pi / 2, 1e-6);

  // root_transform applies on the left: the glTF -> Blender axis change moves +Y to +Z.
  c.nodes.root_transform = {1, 0, 0, 0, 0, 0, 1, 0, 0, -1, 0, 0, 0, 0, 0, 1};
  p = sd::io::sample_pose(c, -1, 0.0);
  EXPECT_NEAR(p[16 + 14], 1.0, 1e-6);
  EXPECT_NEAR(p[16 + 13], 0.0, 1e-6);
}

TEST(Refine, MakeHumanOneLevel) {
  SKIP_WITHOUT_DATA();
  const Character c = sd::io::load_gltf_character(human("mh_male_game_engine_anims.glb"));
  const Character r = sd::io::refine_catmull_clark(c, 1);
  EXPECT_EQ(sd::io::validate(r), "");
  EXPECT_EQ(num_vertices(r), 13380u + 40134u + 26756u);  // V + E + F = 80,270
  EXPECT_EQ(r.triangles.size() / 3, 2u * 3u * 26756u);   // 3 quads per triangle, 2 triangles each
  EXPECT_EQ(boundary_edges(r.triangles), 0u);
  EXPECT_NEAR(signed_volume(r), signed_volume(c), 0.02 * signed_volume(c));  // same orientation
  expect_weights_sum_to_one(r);
  // Smoothing moves the surface inwards a little; the height barely changes.
  const Box b0 = bbox(c.positions), b1 = bbox(r.positions);
  EXPECT_NEAR(b1.hi[2] - b1.lo[2], b0.hi[2] - b0.lo[2], 0.02);
  EXPECT_EQ(r.bone_rest, c.bone_rest);
  EXPECT_EQ(r.animations.size(), c.animations.size());
  const std::vector<float> posed = skin(r, sd::io::sample_pose(r, 2, 5.0));
  EXPECT_TRUE(all_finite(posed));

  EXPECT_EQ(num_vertices(sd::io::refine_catmull_clark(c, 0)), 13380u);
  EXPECT_THROW(sd::io::refine_catmull_clark(c, -1), std::invalid_argument);
}

TEST(Validate, ReportsProblems) {
  Character c;
  EXPECT_EQ(sd::io::validate(c), "");  // empty is consistent
  c.positions = {0, 0, 0, 1, 0, 0, 0, 1, 0};
  c.triangles = {0, 1, 3};
  c.skin_joints = {0, 0, 0, 0};
  c.skin_weights = {0.5f, 0, 0, 0};
  const std::string msg = sd::io::validate(c);
  EXPECT_NE(msg.find("triangles"), std::string::npos) << msg;
  EXPECT_NE(msg.find("skin_joints"), std::string::npos) << msg;
}

}  // namespace
