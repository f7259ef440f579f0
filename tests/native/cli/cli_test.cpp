// The command-line tool's parts and the tool itself: the BVH reader (synthetic files with
// every rotation order, then every clip of ../shared/data/mocap against the data README's
// table), the retarget against the data set's own *_anims.glb, mesh and PC2 I/O, and runs of
// the built `sweepdeform` binary (outputs finite and plausible, pose files, errors and exit
// codes). Tests that need ../shared/data skip, saying so, when it is missing.
#include <sweepdeform_io/animation.h>
#include <sweepdeform_io/bvh.h>
#include <sweepdeform_io/gltf_loader.h>
#include <sweepdeform_io/mesh_io.h>

#include <glm/glm.hpp>
#include <glm/gtc/matrix_transform.hpp>
#include <glm/gtc/quaternion.hpp>
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <numeric>
#include <sstream>
#include <string>
#include <vector>

namespace {

namespace fs = std::filesystem;
using namespace sd::io;

const fs::path kData = SWEEPDEFORM_SHARED_DATA_DIR;

#define REQUIRE_DATA()                                                             \
  do {                                                                             \
    if (!fs::is_directory(kData / "mocap") || !fs::is_directory(kData / "humans")) \
      GTEST_SKIP() << "../shared/data not found: skipped";                         \
  } while (false)

glm::dmat4 mat(const float* m) {
  glm::dmat4 r;
  for (int c = 0; c < 4; ++c)
    for (int k = 0; k < 4; ++k) r[c][k] = m[4 * c + k];
  return r;
}

/// A scratch directory per test.
fs::path scratch(const std::string& name) {
  const fs::path p = fs::temp_directory_path() / ("sweepdeform_cli_test_" + std::to_string(::getpid())) / name;
  fs::remove_all(p);
  fs::create_directories(p);
  return p;
}

// ---- BVH: synthetic files ---------------------------------------------------------------

std::string two_joint_bvh(const std::string& root_channels, const std::string& child_channels,
                          const std::string& motion) {
  return "HIERARCHY\nROOT Hips\n{\n  OFFSET 1 2 3\n  CHANNELS " + root_channels +
         "\n  JOINT Arm\n  {\n"
         "    OFFSET 0 5 0\n    CHANNELS " +
         child_channels +
         "\n    End Site\n    {\n      OFFSET 0 0 4\n    }\n"
         "  }\n}\nMOTION\nFrames: 2\nFrame Time: 0.05\n" +
         motion;
}

glm::dmat4 axis_rot(char axis, double deg) {
  const glm::dvec3 a = axis == 'X' ? glm::dvec3(1, 0, 0) : axis == 'Y' ? glm::dvec3(0, 1, 0) : glm::dvec3(0, 0, 1);
  return glm::rotate(glm::dmat4(1.0), glm::radians(deg), a);
}

TEST(BvhReader, EveryRotationOrderComposesInListedOrder) {
  const std::string orders[] = {"XYZ", "XZY", "YXZ", "YZX", "ZXY", "ZYX"};
  for (const std::string& order : orders) {
    std::string ch = "3";
    for (char c : order) ch += std::string(" ") + c + "rotation";
    // Frame 1: angles 10, 20, 30 degrees on the channels in listed order.
    const std::string motion = "0 0 0 0 0 0\n10 20 30 40 -50 60\n";
    const BvhClip clip = parse_bvh(two_joint_bvh(ch, ch, motion), "order" + order);
    ASSERT_EQ(clip.joint_count(), 2);
    ASSERT_EQ(clip.frame_count, 2);
    EXPECT_DOUBLE_EQ(clip.frame_time_s, 0.05);
    const auto g = bvh_global_matrices(clip, 1);
    const glm::dmat4 root = glm::translate(glm::dmat4(1.0), glm::dvec3(1, 2, 3)) * axis_rot(order[0], 10) *
                            axis_rot(order[1], 20) * axis_rot(order[2], 30);
    const glm::dmat4 arm = root * glm::translate(glm::dmat4(1.0), glm::dvec3(0, 5, 0)) * axis_rot(order[0], 40) *
                           axis_rot(order[1], -50) * axis_rot(order[2], 60);
    for (int c = 0; c < 4; ++c)
      for (int k = 0; k < 4; ++k) {
        EXPECT_NEAR(mat(g.data())[c][k], root[c][k], 1e-6) << order;
        EXPECT_NEAR(mat(g.data() + 16)[c][k], arm[c][k], 1e-6) << order;
      }
  }
}

TEST(BvhReader, PositionChannelsRestPoseEndSitesAndWrappedRows) {
  // Root with positions (absolute local position), a child with a position channel too,
  // motion rows wrapped over lines, tabs and a missing space after ':'.
  const std::string text =
      "HIERARCHY\nROOT hip\n{\n\tOFFSET 0 0 0\n\tCHANNELS 6 Xposition Yposition Zposition Zrotation Yrotation "
      "Xrotation\n"
      "\tJOINT abdomen\n\t{\n\t\tOFFSET 0 10 0\n\t\tCHANNELS 4 Yposition Zrotation Xrotation Yrotation\n"
      "\t\tEnd Site\n\t\t{\n\t\t\tOFFSET 0 3 0\n\t\t}\n\t}\n}\nMOTION\nFrames:\t3\nFrame Time:\t0.0083333\n"
      "1 2 3 0 0 0\n 7 0 0 0\n4 5 6 90 0 0 12 0 0 0\n0 0 0 0 0 0 0 0 0 0\n";
  const BvhClip clip = parse_bvh(text, "wrapped");
  EXPECT_EQ(clip.channel_count, 10);
  EXPECT_EQ(clip.frame_count, 3);
  EXPECT_EQ(clip.find_joint("abdomen"), 1);
  EXPECT_EQ(clip.find_joint("nothing"), -1);
  ASSERT_EQ(clip.joints[1].end_sites.size(), 1u);
  const auto rest = bvh_global_matrices(clip, -1);
  EXPECT_EQ(mat(rest.data() + 16)[3], glm::dvec4(0, 10, 0, 1));  // OFFSET at rest
  const auto f0 = bvh_global_matrices(clip, 0);
  EXPECT_EQ(mat(f0.data())[3], glm::dvec4(1, 2, 3, 1));
  EXPECT_EQ(mat(f0.data() + 16)[3], glm::dvec4(1, 9, 3, 1));  // Yposition 7 replaces OFFSET y 10
  const auto f1 = bvh_global_matrices(clip, 1);
  // Root turned 90 degrees about Z: the child's local +y (12) points along -x.
  EXPECT_NEAR(mat(f1.data() + 16)[3].x, 4 - 12, 1e-6);
  EXPECT_NEAR(mat(f1.data() + 16)[3].y, 5, 1e-6);
  EXPECT_THROW(bvh_global_matrices(clip, 3), std::out_of_range);
  EXPECT_THROW(bvh_global_matrices(clip, -2), std::out_of_range);
}

std::string error_of(const std::string& text) {
  try {
    parse_bvh(text, "bad.bvh");
  } catch (const std::runtime_error& e) {
    return e.what();
  }
  return "";
}

TEST(BvhReader, ClearErrorsWithLineNumbers) {
  const std::string good =
      two_joint_bvh("3 Zrotation Yrotation Xrotation", "3 Zrotation Yrotation Xrotation", "0 0 0 0 0 0\n1 2 3 4 5 6\n");
  ASSERT_EQ(error_of(good), "");
  EXPECT_NE(error_of("").find("empty file"), std::string::npos);
  EXPECT_NE(error_of("ply\nformat ascii 1.0\n").find("not a BVH file"), std::string::npos);
  std::string s = good;
  s.replace(s.find("0 0 0 0 0 0\n1 2 3 4 5 6\n"), 24, "0 0 0 0 0 0\n1 2 3\n");
  EXPECT_NE(error_of(s).find("truncated motion: expected 12 values (2 frames x 6 channels), found 9"),
            std::string::npos)
      << error_of(s);
  s = good;
  s.replace(s.find("Xrotation"), 9, "Wrotation");
  EXPECT_NE(error_of(s).find("bad.bvh:5: unknown channel 'Wrotation'"), std::string::npos) << error_of(s);
  s = good;
  s.replace(s.find("Frame Time: 0.05"), 16, "Frame Time: 0");
  EXPECT_NE(error_of(s).find("frame time must be > 0"), std::string::npos);
  s = good;
  s.replace(s.find("1 2 3 4 5 6"), 1, "x");
  EXPECT_NE(error_of(s).find("expected a number in frame 1, found 'x'"), std::string::npos) << error_of(s);
  s = good;
  s.erase(s.rfind("}"));
  EXPECT_NE(error_of(s).find("bad.bvh:15: unexpected end of file"), std::string::npos) << error_of(s);
  s = good;
  s.replace(s.find("MOTION"), 6, "MOTON");
  EXPECT_NE(error_of(s).find("expected ROOT or MOTION, found 'MOTON'"), std::string::npos) << error_of(s);
  EXPECT_THROW(load_bvh("/nonexistent/clip.bvh"), std::runtime_error);
}

// ---- BVH: the data set -------------------------------------------------------------------

struct ClipFacts {
  const char* file;
  int joints, frames;
  const char* convention;
  int bones_driven;  // of mh_male_game_engine
};
// The table of ../shared/data/README.md Sect. 3.
const ClipFacts kClips[] = {
    {"cmu_01_01_playground_jumps.bvh", 31, 2752, "cgspeed MotionBuilder", 22},
    {"cmu_01_03_playground_climb_hang_swing.bvh", 31, 4511, "cgspeed MotionBuilder", 22},
    {"cmu_02_02_walk_daz.bvh", 43, 299, "Daz/Second Life", 19},
    {"cmu_07_01_walk.bvh", 31, 317, "cgspeed MotionBuilder", 22},
    {"cmu_09_11_run.bvh", 31, 166, "cgspeed MotionBuilder", 22},
    {"cmu_49_08_cartwheel.bvh", 31, 576, "cgspeed MotionBuilder", 22},
    {"cmu_55_01_dance_whirl.bvh", 31, 1807, "cgspeed MotionBuilder", 22},
    {"cmu_60_01_salsa_lead_daz_scaled.bvh", 43, 2242, "Daz/Second Life", 19},
};

TEST(BvhData, EveryClipParsesAsTheReadmeSays) {
  REQUIRE_DATA();
  const Character mh = load_gltf_character((kData / "humans/mh_male_game_engine.glb").string());
  size_t seen = 0;
  for (const auto& e : fs::directory_iterator(kData / "mocap"))
    if (e.path().extension() == ".bvh") ++seen;
  EXPECT_EQ(seen, std::size(kClips)) << "a clip was added or removed: update kClips from the README";
  for (const ClipFacts& f : kClips) {
    SCOPED_TRACE(f.file);
    const BvhClip clip = load_bvh((kData / "mocap" / f.file).string());
    EXPECT_EQ(clip.joint_count(), f.joints);
    EXPECT_EQ(clip.frame_count, f.frames);
    EXPECT_NEAR(1.0 / clip.frame_time_s, 120.0, 0.05);
    EXPECT_EQ(clip.motion.size(), static_cast<size_t>(clip.frame_count) * clip.channel_count);
    // Only the root has position channels (README), every joint has 3 rotations.
    for (const BvhJoint& j : clip.joints) EXPECT_EQ(j.channels.size(), j.parent < 0 ? 6u : 3u) << j.name;
    for (float v : clip.motion) ASSERT_TRUE(std::isfinite(v));
    const BvhBoneMap map = map_bvh_to_character(clip, mh);
    EXPECT_EQ(map.source_convention, f.convention);
    EXPECT_EQ(map.target_convention, "MakeHuman game_engine");
    EXPECT_EQ(map.mapped_count(), f.bones_driven);
    EXPECT_EQ(mh.bone_names[static_cast<size_t>(map.root_bone)], "pelvis");
    // Forearm bones are driven by the forearm joints, hands by the hand joints (the twist).
    const auto joint_of = [&](const char* bone) {
      const auto b = std::find(mh.bone_names.begin(), mh.bone_names.end(), bone) - mh.bone_names.begin();
      const int32_t j = map.source[static_cast<size_t>(b)];
      return j < 0 ? std::string("-") : clip.joints[static_cast<size_t>(j)].name;
    };
    EXPECT_EQ(joint_of("hand_l"), std::string(f.joints == 43 ? "lHand" : "LeftHand"));
    EXPECT_EQ(joint_of("upperarm_r"), std::string(f.joints == 43 ? "rShldr" : "RightArm"));
    EXPECT_EQ(joint_of("index_01_l"), "-");
  }
}

/// Bone i's largest column angle (degrees) and head distance between two pose arrays.
std::pair<double, double> pose_difference(const std::vector<float>& a, const std::vector<float>& b) {
  double rot = 0.0, pos = 0.0;
  for (size_t i = 0; i < a.size() / 16; ++i) {
    const glm::dmat4 A = mat(a.data() + 16 * i), B = mat(b.data() + 16 * i);
    for (int c = 0; c < 3; ++c) {
      const double cosine = glm::dot(glm::normalize(glm::dvec3(A[c])), glm::normalize(glm::dvec3(B[c])));
      rot = std::max(rot, glm::degrees(std::acos(std::clamp(cosine, -1.0, 1.0))));
    }
    pos = std::max(pos, glm::length(glm::dvec3(A[3]) - glm::dvec3(B[3])));
  }
  return {rot, pos};
}

TEST(BvhRetarget, ReproducesTheDataSetsAnimsGlb) {
  REQUIRE_DATA();
  // The README's retarget made *_anims.glb from these clips (01_03 cut to 20 s), resampled to
  // 30 fps: glTF time t is BVH frame 120 t - 4.
  const Character anims = load_gltf_character((kData / "humans/mh_male_game_engine_anims.glb").string());
  const struct {
    const char* clip;
    const char* animation;
  } pairs[] = {{"cmu_01_03_playground_climb_hang_swing.bvh", "cmu_01_03_climb_hang"},
               {"cmu_49_08_cartwheel.bvh", "cmu_49_08_cartwheel"},
               {"cmu_55_01_dance_whirl.bvh", "cmu_55_01_dance_whirl"},
               {"cmu_60_01_salsa_lead_daz_scaled.bvh", "cmu_60_01_salsa_lead"}};
  for (const auto& p : pairs) {
    SCOPED_TRACE(p.clip);
    const BvhClip clip = load_bvh((kData / "mocap" / p.clip).string());
    int anim = -1;
    for (size_t a = 0; a < anims.animations.size(); ++a)
      if (anims.animations[a].name == p.animation) anim = static_cast<int>(a);
    ASSERT_GE(anim, 0);
    const BvhBoneMap map = map_bvh_to_character(clip, anims);
    BvhRetargetOptions as_glb;
    as_glb.root_rest_from_offset = true;
    const BvhRetarget same(clip, anims, map, as_glb);
    const BvhRetarget ours(clip, anims, map);
    double worst_rot = 0.0, worst_pos = 0.0;
    for (int k : {1, 2, 30, 90, 140}) {
      const double t = k / 30.0;
      const std::vector<float> ref = sample_pose(anims, anim, t);
      const auto [rot, pos] = pose_difference(same.pose(4 * k - 4), ref);
      worst_rot = std::max(worst_rot, rot);
      worst_pos = std::max(worst_pos, pos);
      // Ours differs from the glb only by a constant vertical offset of every bone (zero for
      // clips whose root OFFSET is not (0,0,0)).
      const std::vector<float> mine = ours.pose(4 * k - 4);
      const double dz =
          mine[16 * static_cast<size_t>(map.root_bone) + 14] - ref[16 * static_cast<size_t>(map.root_bone) + 14];
      for (size_t b = 0; b < anims.bone_names.size(); ++b) {
        if (anims.bone_parents[b] < 0) continue;  // "Root", above the hips: never moves
        EXPECT_NEAR(mine[16 * b + 12], ref[16 * b + 12], 2e-4);
        EXPECT_NEAR(mine[16 * b + 13], ref[16 * b + 13], 2e-4);
        EXPECT_NEAR(mine[16 * b + 14] - dz, ref[16 * b + 14], 2e-4);
      }
    }
    std::printf("[ retarget ] %-42s vs %s: max bone rotation difference %.3f deg, head %.3f mm\n", p.clip, p.animation,
                worst_rot, 1e3 * worst_pos);
    EXPECT_LT(worst_rot, 0.1);   // float storage and quaternion sampling of the glb
    EXPECT_LT(worst_pos, 2e-4);  // 0.2 mm
  }
}

TEST(BvhRetarget, ZeroOffsetRootsStandOnTheFloor) {
  REQUIRE_DATA();
  const Character mh = load_gltf_character((kData / "humans/mh_male_game_engine.glb").string());
  const auto bone = [&](const char* n) {
    return static_cast<size_t>(std::find(mh.bone_names.begin(), mh.bone_names.end(), n) - mh.bone_names.begin());
  };
  for (const char* file : {"cmu_01_01_playground_jumps.bvh", "cmu_02_02_walk_daz.bvh",
                           "cmu_60_01_salsa_lead_daz_scaled.bvh", "cmu_07_01_walk.bvh"}) {
    SCOPED_TRACE(file);
    const BvhClip clip = load_bvh((kData / "mocap" / file).string());
    const BvhRetarget r(clip, mh, map_bvh_to_character(clip, mh));
    // The lowest foot (ankle) over the clip sits about where the rest ankles do.
    double lowest = 1e9;
    for (int f = 0; f < clip.frame_count; f += 10) {
      const auto pose = r.pose(f);
      lowest = std::min({lowest, double(pose[16 * bone("foot_l") + 14]), double(pose[16 * bone("foot_r") + 14])});
    }
    const double rest_ankle = mh.bone_heads[3 * bone("foot_l") + 2];
    std::printf("[ retarget ] %-38s lowest ankle %.3f m (rest %.3f m), scale %.5f\n", file, lowest, rest_ankle,
                r.translation_scale());
    EXPECT_NEAR(lowest, rest_ankle, 0.06);
  }
}

TEST(BvhRetarget, NoMatchingBoneIsAClearError) {
  REQUIRE_DATA();
  const Character mh = load_gltf_character((kData / "humans/mh_male_game_engine.glb").string());
  const BvhClip clip = parse_bvh(
      two_joint_bvh("3 Zrotation Yrotation Xrotation", "3 Zrotation Yrotation Xrotation", "0 0 0 0 0 0\n0 0 0 0 0 0\n"),
      "odd.bvh");
  BvhClip renamed = clip;
  renamed.joints[0].name = "Torso";
  renamed.joints[1].name = "Limb";
  try {
    map_bvh_to_character(renamed, mh);
    FAIL() << "no error";
  } catch (const std::runtime_error& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find("no bone of the character matches a joint of odd.bvh"), std::string::npos) << m;
    EXPECT_NE(m.find("Joints: Torso Limb"), std::string::npos) << m;
    EXPECT_NE(m.find("pelvis"), std::string::npos) << m;
  }
  // An override maps it; a bad override names what is missing.
  const BvhBoneMap m = map_bvh_to_character(renamed, mh, {{"pelvis", "Torso"}, {"spine_01", "Limb"}});
  EXPECT_EQ(m.mapped_count(), 2);
  EXPECT_THROW(map_bvh_to_character(renamed, mh, {{"tail", "Torso"}}), std::runtime_error);
  EXPECT_THROW(map_bvh_to_character(renamed, mh, {{"pelvis", "Wing"}}), std::runtime_error);
  // A character rigged with the BVH's own joint names maps by name.
  Character same = mh;
  same.bone_names[1] = "Hips";
  same.bone_names[2] = "arm";
  const BvhBoneMap by_name = map_bvh_to_character(clip, same);
  EXPECT_EQ(by_name.source_convention, "BVH names");
  EXPECT_EQ(by_name.mapped_count(), 2);
  EXPECT_EQ(by_name.root_bone, 1);
}

/// A BVH whose joints form one chain with these names (only the names matter here).
std::string chain_bvh(const std::vector<std::string>& names) {
  std::string h = "HIERARCHY\n", motion;
  for (size_t i = 0; i < names.size(); ++i) {
    h += (i == 0 ? "ROOT " : "JOINT ") + names[i] + "\n{\nOFFSET 0 1 0\nCHANNELS 3 Zrotation Xrotation Yrotation\n";
    motion += "0 0 0 ";
  }
  h += "End Site\n{\nOFFSET 0 1 0\n}\n";
  for (size_t i = 0; i < names.size(); ++i) h += "}\n";
  return h + "MOTION\nFrames: 1\nFrame Time: 0.0333\n" + motion + "\n";
}

TEST(BvhRetarget, MixamoNamesKeepTheirSpine) {
  REQUIRE_DATA();
  const Character mh = load_gltf_character((kData / "humans/mh_male_game_engine.glb").string());
  std::vector<std::string> names = {"Hips",      "Spine",        "Spine1",   "Spine2",      "Neck",
                                    "Head",      "LeftShoulder", "LeftArm",  "LeftForeArm", "LeftHand",
                                    "LeftUpLeg", "LeftLeg",      "LeftFoot", "LeftToeBase"};
  for (auto& n : names) n = "mixamorig:" + n;
  const BvhClip clip = parse_bvh(chain_bvh(names), "mixamo.bvh");
  const BvhBoneMap m = map_bvh_to_character(clip, mh);
  EXPECT_EQ(m.source_convention, "Mixamo");
  const auto joint_of = [&](const char* bone) {
    const auto b =
        static_cast<size_t>(std::find(mh.bone_names.begin(), mh.bone_names.end(), bone) - mh.bone_names.begin());
    return m.source[b] < 0 ? std::string("-") : clip.joints[static_cast<size_t>(m.source[b])].name;
  };
  EXPECT_EQ(joint_of("spine_01"), "mixamorig:Spine");
  EXPECT_EQ(joint_of("spine_02"), "mixamorig:Spine1");
  EXPECT_EQ(joint_of("spine_03"), "mixamorig:Spine2");
  EXPECT_EQ(joint_of("ball_l"), "mixamorig:LeftToeBase");
  EXPECT_EQ(joint_of("thigh_r"), "-");
}

// ---- mesh and cache files ----------------------------------------------------------------

TEST(MeshIo, ObjPlyOffXyzAndPc2RoundTrip) {
  const fs::path dir = scratch("meshio");
  const std::vector<float> p = {0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0, 0.5f, 0.5f, 1};
  const std::vector<int32_t> tris = {0, 1, 4, 1, 2, 4, 2, 3, 4, 3, 0, 4, 0, 2, 1, 0, 3, 2};
  write_obj((dir / "pyramid.obj").string(), p.data(), 5, tris);
  const MeshData m = read_mesh((dir / "pyramid.obj").string());
  EXPECT_EQ(m.positions, p);
  EXPECT_EQ(m.triangles, tris);
  // A quad in OFF becomes a fan; an XYZ file is a point cloud.
  std::ofstream((dir / "quad.off").string()) << "OFF\n4 1 0\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n4 0 1 2 3\n";
  const MeshData q = read_mesh((dir / "quad.off").string());
  EXPECT_EQ(q.triangles, (std::vector<int32_t>{0, 1, 2, 0, 2, 3}));
  std::ofstream((dir / "cloud.xyz").string()) << "# points\n1 2 3\n\n4 5 6 0.1 0.2 0.3\n";
  EXPECT_EQ(read_mesh((dir / "cloud.xyz").string()).positions, (std::vector<float>{1, 2, 3, 4, 5, 6}));
  std::ofstream((dir / "cloud.ply").string())
      << "ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty float y\nproperty float z\nend_header\n"
         "1 2 3\n4 5 6\n";
  const MeshData ply = read_mesh((dir / "cloud.ply").string());
  EXPECT_EQ(ply.positions, (std::vector<float>{1, 2, 3, 4, 5, 6}));
  EXPECT_TRUE(ply.triangles.empty());
  // Binary PLY, both byte orders (read_mesh walks the body before OpenMesh reads it): a triangle
  // with an int list size, and the same claiming a list of 2^31 entries, refused.
  for (const bool big : {false, true}) {
    const auto put = [&](std::string& out, const void* v, size_t n) {
      const auto* c = static_cast<const char*>(v);
      for (size_t k = 0; k < n; ++k) out += c[big ? n - 1 - k : k];  // the host is little-endian
    };
    const std::string head = std::string("ply\nformat ") + (big ? "binary_big_endian" : "binary_little_endian") +
                             " 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
                             "element face 1\nproperty list int int vertex_indices\nend_header\n";
    std::string body;
    for (float x : {0.0f, 0.0f, 0.0f, 1.0f, 0.0f, 0.0f, 0.0f, 1.0f, 0.0f}) put(body, &x, 4);
    for (int32_t i : {3, 0, 1, 2}) put(body, &i, 4);
    const std::string name = big ? "big.ply" : "little.ply";
    std::ofstream((dir / name).string(), std::ios::binary) << head << body;
    const MeshData b = read_mesh((dir / name).string());
    EXPECT_EQ(b.positions, (std::vector<float>{0, 0, 0, 1, 0, 0, 0, 1, 0})) << name;
    EXPECT_EQ(b.triangles, (std::vector<int32_t>{0, 1, 2})) << name;
    std::string huge = body.substr(0, 36);
    const int32_t size = 0x7fffffff;
    put(huge, &size, 4);
    std::ofstream((dir / ("huge_" + name)).string(), std::ios::binary) << head << huge;
    try {
      read_mesh((dir / ("huge_" + name)).string());
      ADD_FAILURE() << name << ": no error";
    } catch (const std::runtime_error& e) {
      EXPECT_NE(std::string(e.what()).find("PLY element 'face' item 0: list size 2147483647"), std::string::npos)
          << e.what();
    }
  }
  EXPECT_THROW(read_mesh((dir / "missing.obj").string()), std::runtime_error);
  EXPECT_THROW(read_mesh((dir / "cloud.stl").string()), std::runtime_error);
  {
    Pc2Writer w((dir / "c.pc2").string(), 5, 10.0f, 2.0f);
    w.add_frame(p.data());
    std::vector<float> q2 = p;
    for (float& x : q2) x += 1.0f;
    w.add_frame(q2.data());
  }
  const Pc2Data d = read_pc2((dir / "c.pc2").string());
  EXPECT_EQ(d.point_count, 5);
  EXPECT_EQ(d.sample_count, 2);
  EXPECT_EQ(d.start_frame, 10.0f);
  EXPECT_EQ(d.sample_rate, 2.0f);
  EXPECT_EQ(fs::file_size(dir / "c.pc2"), 32u + 2 * 5 * 12);
  EXPECT_EQ(d.samples[15], 1.0f);
  // The header bytes exactly as the format says.
  std::ifstream in((dir / "c.pc2").string(), std::ios::binary);
  char magic[12];
  in.read(magic, 12);
  EXPECT_EQ(std::string(magic, 12), std::string("POINTCACHE2\0", 12));
}

TEST(MeshIo, HeaderCountsAreBoundedBeforeAllocating) {
  // Issue 15: a PLY/OFF header claiming 4e9 vertices made OpenMesh try to reserve ~100 GB.
  const fs::path dir = scratch("headers");
  const auto error = [&](const std::string& name, const std::string& text) {
    std::ofstream((dir / name).string(), std::ios::binary) << text;
    try {
      read_mesh((dir / name).string());
    } catch (const std::runtime_error& e) {
      return std::string(e.what());
    }
    return std::string("(no error)");
  };
  const std::string ply_head = "ply\nformat ascii 1.0\nelement vertex ";
  const std::string ply_tail = "\nproperty float x\nproperty float y\nproperty float z\nend_header\n1 2 3\n";
  std::string e = error("huge.ply", ply_head + "4000000000" + ply_tail);
  EXPECT_NE(e.find("declares 4000000000 vertices; at most 50000000 are read"), std::string::npos) << e;
  e = error("huge.off", "OFF\n4000000000 1 0\n0 0 0\n");
  EXPECT_NE(e.find("declares 4000000000 vertices"), std::string::npos) << e;
  e = error("faces.off", "OFF\n# a comment\n3 999999999 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n");
  EXPECT_NE(e.find("declares 999999999 faces; at most 100000000"), std::string::npos) << e;
  e = error("more_than_bytes.off", "OFF\n1000 0 0\n0 0 0\n");
  EXPECT_NE(e.find("no more than the file's"), std::string::npos) << e;
  e = error("negative.ply", ply_head + "-5" + ply_tail);
  EXPECT_NE(e.find("vertex count '-5' is not a count"), std::string::npos) << e;
  e = error("exponent.ply", ply_head + "4e9" + ply_tail);
  EXPECT_NE(e.find("is not a count"), std::string::npos) << e;
  // Bounded counts still read.
  EXPECT_EQ(error("ok.ply", ply_head + "1" + ply_tail), "(no error)");
  // Files OpenMesh 9 crashes on, loops forever on or allocates gigabytes for (found by
  // fuzz_mesh_file): refused before OpenMesh reads them. {file, content, the error says}.
  const std::vector<std::array<std::string, 3>> refused = {
      {"damaged.off", "OFF&9)" + std::string(32, '\xff') + "\n", "not a text OFF file"},  // was 4.7 GB
      {"binary.off", "OFF BINARY\n", "binary OFF files are not read"},
      {"face_size.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n-2 1 0\n", "face size count '-2' is not a count"},  // 2 GB
      {"face_index.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 7\n", "OFF face index 7 is not a vertex (item 0)"},
      // Counts on the keyword line: OpenMesh reads the next line for them (took "0-01" for -1: 17 GB).
      {"same_line.off", "OFF 4 1 0\n0-01\n0 1\n", "the OFF keyword line holds '4': the counts belong on the next line"},
      {"no_index.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf /1 2 3\n", "no_index.obj:4: a face corner without a vertex index"},
      // Indented, and so missed by the check while OpenMesh read it (an assertion failed:
      // fuzz_mesh_file's third 600 s run, regress_obj_indented_face).
      {"indented.obj", "v  3/\n f /3 3//\x02", "indented.obj:2: a face corner without a vertex index"},
      {"indented_vertices.obj", "\tv 0 0 0\n v 1 0 0\nv 0 1 0\n  f 1 2 4\n",
       "indented_vertices.obj:4: face corner '4' names no vertex defined above it"},
      {"out_of_range.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n",
       "out_of_range.obj:4: face corner '4' names no vertex defined above it"},
      {"format.ply", "ply\nformat ascii 0.\xb5" + std::string(3, '\0') + "ement vertex 6\n",
       "PLY header line 2: a NUL byte in the header"},
      {"format2.ply", "ply\nformat ascii 2.0\nelement vertex 1\nproperty float x\nend_header\n0\n",
       "PLY header line 2: unknown format 'format ascii 2.0'"},
      {"orphan.ply", "ply\nformat ascii 1.0\nproperty list uchar int vertex_indices\nend_header\n",
       "PLY header line 3: a property before any element"},
      {"no_end.ply", "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\n", "the header has no end_header"},
      {"bad_type.ply", ply_head + "1\nproperty lroperty float y\nend_header\n0 0 0\n",
       "PLY header line 4: unknown property type"},
      // OpenMesh took "end_header" for the missing name and looped forever past the end of the
      // file (fuzz_mesh_file's 600 s pass; the input itself, corpus regress_ply_property_without_name).
      {"no_name.ply",
       ply_head + "3\nproperty float\nend_header\n0 0 0\n1 0 0\n0 1 0\x1a"
                  "60.2 02\n",
       "PLY header line 4: a property without a name: 'property float'"},
      {"no_list_name.ply",
       ply_head + "1\nproperty float x\nelement face 1\nproperty list uchar int\nend_header\n0\n3 0 0 0\n",
       "PLY header line 6: a property without a name"},
      {"more_words.ply", ply_head + "1 end_header\nproperty float x\nend_header\n0\n",
       "PLY header line 3: 'end_header' after the end of 'element vertex 1 end_header'"},
      // OpenMesh took "0-1" for a face size of billions: a 2 GB allocation and more (fuzz_mesh_file's
      // 600 s pass, regress_ply_list_size_not_a_number).
      {"face_size.ply",
       ply_head + "1\nproperty float x\nproperty float y\nproperty float z\nelement face 4\nproperty list uchar int "
                  "vertex_indices\nend_header\n0 0 0\n0-1  0\n0 1 0\n3 0 1 2\n",
       "PLY element 'face' item 0: list size '0-1' is not in 0..1024"},
      {"negative_size.ply",
       ply_head + "1\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list char int "
                  "vertex_indices\nend_header\n0 0 0\n-3 0 0 0\n",
       "PLY element 'face' item 0: list size '-3' is not in 0..1024"},
      {"short.ply", ply_head + "2" + ply_tail, "PLY element 'vertex' item 1: the file ends early"},
      // A second vertex element of 9.3e9 while the check bounded the last one (OpenMesh: 2.4 GB;
      // fuzz_mesh_file's fourth 600 s run, regress_ply_second_vertex_element).
      {"two_vertex.ply", ply_head + "9299999999\nproperty float x\nelement vertex 0\nproperty float x\nend_header\n",
       "PLY header line 5: a second 'vertex' element"},
      {"huge_other.ply",
       ply_head + "1" + "\nproperty float x\nelement edge 4000000000\nproperty int a\nend_header\n0\n",
       "PLY header line 5: the element 'edge' declares 4000000000 items"},
      {"word.ply", ply_head + "1\nproperty float x\nproperty float y\nproperty float z\nend_header\n1 two 3\n",
       "PLY element 'vertex' item 0: 'two' is not a number"},
  };
  for (const auto& [name, content, says] : refused) {
    e = error(name, content);
    EXPECT_NE(e.find(says), std::string::npos) << name << ": " << e;
  }
  EXPECT_EQ(error("relative.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nf -3/1 -2/1 -1/1\n"), "(no error)");
  // XYZ: a line that is not three finite numbers is an error naming the line, never skipped.
  e = error("nan.xyz", "1 2 3\nnan 0 0\n4 5 6\n");
  EXPECT_NE(e.find("nan.xyz:2: expected 'x y z' with finite numbers"), std::string::npos) << e;
  e = error("inf.xyz", "1 2 3\n4 inf 6\n");
  EXPECT_NE(e.find("inf.xyz:2:"), std::string::npos) << e;
  e = error("huge.xyz", "1 2 3\n" + std::string(150, '9') + " 5 6\n");  // beyond float: was undefined
  EXPECT_NE(e.find("huge.xyz:2: expected 'x y z' with finite numbers"), std::string::npos) << e;
  e = error("text.xyz", "v 1 2 3\n");
  EXPECT_NE(e.find("text.xyz:1:"), std::string::npos) << e;
  // PC2: sizes against the file before allocating.
  {
    std::ofstream out((dir / "huge.pc2").string(), std::ios::binary);
    const unsigned char h[32] = {'P', 'O', 'I', 'N', 'T',  'C',  'A',  'C',  'H',  'E', '2',
                                 0,   1,   0,   0,   0,    0xFF, 0xFF, 0xFF, 0x7F, 0,   0,
                                 0,   0,   0,   0,   0x80, 0x3F, 0xFF, 0xFF, 0xFF, 0x7F};
    out.write(reinterpret_cast<const char*>(h), 32);
  }
  try {
    read_pc2((dir / "huge.pc2").string());
    ADD_FAILURE() << "no error";
  } catch (const std::runtime_error& ex) {
    EXPECT_NE(std::string(ex.what()).find("more than the file holds"), std::string::npos) << ex.what();
  }
}

// ---- the tool ----------------------------------------------------------------------------

struct ToolRun {
  int code;
  std::string out;
};
ToolRun run_tool(const std::string& args) {
  const fs::path log = fs::temp_directory_path() / ("sweepdeform_cli_test_" + std::to_string(::getpid()) + ".log");
  const std::string cmd = std::string("'") + SWEEPDEFORM_CLI_PATH + "' " + args + " > '" + log.string() + "' 2>&1";
  const int status = std::system(cmd.c_str());
  std::ifstream in(log);
  std::stringstream ss;
  ss << in.rdbuf();
  return {WIFEXITED(status) ? WEXITSTATUS(status) : -1, ss.str()};
}

std::string human(const char* f) { return (kData / "humans" / f).string(); }
std::string clip(const char* f) { return (kData / "mocap" / f).string(); }

/// Linear blend skinning of a character by a pose (#B*16).
std::vector<float> skin(const Character& c, const float* pose) {
  const size_t B = c.bone_names.size(), V = c.positions.size() / 3;
  std::vector<glm::dmat4> m(B);
  for (size_t b = 0; b < B; ++b) m[b] = mat(pose + 16 * b) * glm::inverse(mat(c.bone_rest.data() + 16 * b));
  std::vector<float> out(3 * V);
  for (size_t v = 0; v < V; ++v) {
    glm::dvec4 p(0.0);
    for (int k = 0; k < 4; ++k)
      p += double(c.skin_weights[4 * v + k]) *
           (m[static_cast<size_t>(c.skin_joints[4 * v + k])] *
            glm::dvec4(c.positions[3 * v], c.positions[3 * v + 1], c.positions[3 * v + 2], 1.0));
    for (int k = 0; k < 3; ++k) out[3 * v + k] = static_cast<float>(p[k]);
  }
  return out;
}

TEST(Tool, DeformsMakeHumanByARunClipIntoPlausibleFrames) {
  REQUIRE_DATA();
  const fs::path dir = scratch("run");
  const std::string pc2 = (dir / "run.pc2").string(), poses = (dir / "run.poses").string();
  const ToolRun r =
      run_tool("'" + human("mh_male_game_engine.glb") + "' '" + clip("cmu_09_11_run.bvh") + "' -o '" + pc2 +
               "' --frames 0:160:8 --write-poses '" + poses + "' --report '" + (dir / "fit.json").string() + "'");
  std::printf("%s", r.out.c_str());
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("ms per frame"), std::string::npos);
  EXPECT_NE(r.out.find("cgspeed MotionBuilder -> MakeHuman game_engine, 22 of 53 bones driven"), std::string::npos);
  const Pc2Data d = read_pc2(pc2);
  ASSERT_EQ(d.point_count, 13380);
  ASSERT_EQ(d.sample_count, 21);
  EXPECT_EQ(d.start_frame, 0.0f);
  EXPECT_EQ(d.sample_rate, 8.0f);
  for (float x : d.samples) ASSERT_TRUE(std::isfinite(x));
  // Plausible: close to linear blend skinning of the same poses (the sweeps differ from it at
  // the joints by design, by centimetres), the body keeps its height, and it runs forward.
  const Character mh = load_gltf_character(human("mh_male_game_engine.glb"));
  std::ifstream pin(poses, std::ios::binary);
  std::vector<float> pose_data(fs::file_size(poses) / 4);
  pin.read(reinterpret_cast<char*>(pose_data.data()), static_cast<std::streamsize>(4 * pose_data.size()));
  ASSERT_EQ(pose_data.size(), 21u * 53 * 16);
  double worst_mean = 0.0, worst_p99 = 0.0;
  for (int f = 0; f < d.sample_count; ++f) {
    const std::vector<float> lbs = skin(mh, pose_data.data() + 53 * 16 * f);
    const float* s = d.samples.data() + static_cast<size_t>(f) * 13380 * 3;
    std::vector<double> e(13380);
    float zmin = 1e9f, zmax = -1e9f;
    for (size_t v = 0; v < 13380; ++v) {
      e[v] = std::sqrt(std::pow(s[3 * v] - lbs[3 * v], 2) + std::pow(s[3 * v + 1] - lbs[3 * v + 1], 2) +
                       std::pow(s[3 * v + 2] - lbs[3 * v + 2], 2));
      zmin = std::min(zmin, s[3 * v + 2]);
      zmax = std::max(zmax, s[3 * v + 2]);
    }
    const double mean = std::accumulate(e.begin(), e.end(), 0.0) / e.size();
    std::sort(e.begin(), e.end());
    worst_mean = std::max(worst_mean, mean);
    worst_p99 = std::max(worst_p99, e[e.size() * 99 / 100]);
    EXPECT_GT(zmax - zmin, 1.2f) << "frame " << f;  // 1.75 m tall, running
    EXPECT_LT(zmax - zmin, 2.0f) << "frame " << f;
  }
  std::printf(
      "[ tool ] 21 frames of 09_11 vs linear blend skinning of the same poses: worst frame mean %.1f mm, "
      "p99 %.1f mm\n",
      1e3 * worst_mean, 1e3 * worst_p99);
  EXPECT_LT(worst_mean, 0.015);
  EXPECT_LT(worst_p99, 0.06);
  const float* first = d.samples.data();
  const float* last = d.samples.data() + static_cast<size_t>(20) * 13380 * 3;
  EXPECT_GT(std::abs(last[1] - first[1]), 1.0f) << "the runner travels along -y (forward)";

  // The same poses from the pose file give the same frames (the add-on's tests feed Blender's
  // pose_bone.matrix this way).
  const std::string pc2b = (dir / "from_poses.pc2").string();
  const ToolRun r2 =
      run_tool("'" + human("mh_male_game_engine.glb") + "' --pose-file '" + poses + "' -o '" + pc2b + "' -q");
  ASSERT_EQ(r2.code, 0) << r2.out;
  EXPECT_EQ(r2.out, "");
  const Pc2Data d2 = read_pc2(pc2b);
  ASSERT_EQ(d2.sample_count, 21);
  EXPECT_EQ(d2.samples, d.samples);
}

TEST(Tool, ObjSequenceAndObjCharacterWithASkeleton) {
  REQUIRE_DATA();
  const fs::path dir = scratch("obj");
  // The character as an OBJ (Y-up, as Blender exports it) and the glb as its skeleton.
  const ToolRun r = run_tool("'" + human("mh_male_game_engine.glb") + "' '" + clip("cmu_07_01_walk.bvh") + "' -o '" +
                             (dir / "walk_###.obj").string() + "' --frames 0:100:50 -q");
  ASSERT_EQ(r.code, 0) << r.out;
  for (const char* f : {"walk_000.obj", "walk_050.obj", "walk_100.obj"}) EXPECT_TRUE(fs::exists(dir / f)) << f;
  const MeshData frame0 = read_mesh((dir / "walk_000.obj").string());
  EXPECT_EQ(frame0.positions.size(), 13380u * 3);
  EXPECT_EQ(frame0.triangles.size(), 26756u * 3);
  // Rest mesh as OBJ: the tool's own output axes (Y-up).
  const Character mh = load_gltf_character(human("mh_male_game_engine.glb"));
  std::vector<float> yup(mh.positions.size());
  for (size_t i = 0; i < mh.positions.size(); i += 3) {
    yup[i] = mh.positions[i];
    yup[i + 1] = mh.positions[i + 2];
    yup[i + 2] = -mh.positions[i + 1];
  }
  write_obj((dir / "body.obj").string(), yup.data(), yup.size() / 3, mh.triangles);
  const ToolRun a = run_tool("'" + human("mh_male_game_engine.glb") + "' '" + clip("cmu_07_01_walk.bvh") + "' -o '" +
                             (dir / "glb.pc2").string() + "' --frames 0:100:25 -q");
  const ToolRun b =
      run_tool("'" + (dir / "body.obj").string() + "' --skeleton '" + human("mh_male_game_engine.glb") + "' '" +
               clip("cmu_07_01_walk.bvh") + "' -o '" + (dir / "obj.pc2").string() + "' --frames 0:100:25 -q");
  ASSERT_EQ(a.code, 0) << a.out;
  ASSERT_EQ(b.code, 0) << b.out;
  const Pc2Data da = read_pc2((dir / "glb.pc2").string()), db = read_pc2((dir / "obj.pc2").string());
  ASSERT_EQ(da.samples.size(), db.samples.size());
  double worst = 0.0;
  for (size_t i = 0; i < da.samples.size(); ++i)
    worst = std::max(worst, double(std::abs(da.samples[i] - db.samples[i])));
  EXPECT_LT(worst, 1e-4) << "OBJ + skeleton must deform like the glTF it came from";
}

TEST(Tool, PointsThroughTheDisplacementMap) {
  REQUIRE_DATA();
  const fs::path dir = scratch("points");
  // Points on the body: every vertex, moved 1 mm along x (off the vertices), as XYZ, Y-up.
  const Character mh = load_gltf_character(human("mh_male_game_engine.glb"));
  {
    std::ofstream out((dir / "cloud.xyz").string());
    for (size_t i = 0; i < mh.positions.size(); i += 3 * 7)
      out << mh.positions[i] + 0.001f << ' ' << mh.positions[i + 2] << ' ' << -mh.positions[i + 1] << '\n';
  }
  const ToolRun r =
      run_tool("'" + human("mh_male_game_engine.glb") + "' '" + clip("cmu_09_11_run.bvh") + "' --points '" +
               (dir / "cloud.xyz").string() + "' -o '" + (dir / "cloud.pc2").string() + "' --frames 0:40:20");
  std::printf("%s", r.out.c_str());
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("sweep influences on the map's surface"), std::string::npos);
  const Pc2Data d = read_pc2((dir / "cloud.pc2").string());
  EXPECT_EQ(d.point_count, static_cast<int32_t>((mh.positions.size() / 3 + 6) / 7));
  EXPECT_EQ(d.sample_count, 3);
  for (float x : d.samples) ASSERT_TRUE(std::isfinite(x));
}

TEST(Tool, ErrorsAndExitCodes) {
  const fs::path dir = scratch("errors");
  EXPECT_EQ(run_tool("").code, 1);
  const ToolRun help = run_tool("--help");
  EXPECT_EQ(help.code, 0);
  EXPECT_NE(help.out.find("exit codes"), std::string::npos);
  EXPECT_EQ(run_tool("--frobnicate x.glb y.bvh -o z.pc2").code, 1);
  const ToolRun missing = run_tool("/nonexistent/char.glb /nonexistent/clip.bvh -o " + (dir / "x.pc2").string());
  EXPECT_EQ(missing.code, 2);
  EXPECT_NE(missing.out.find("character '/nonexistent/char.glb' does not exist"), std::string::npos) << missing.out;
  if (!fs::is_directory(kData / "humans")) GTEST_SKIP() << "../shared/data not found: the rest skipped";
  std::ofstream((dir / "bad.bvh").string())
      << "HIERARCHY\nROOT Hips\n{\n OFFSET 0 0 0\n CHANNELS 3 Xrotation Yrotation Zrotation\n}\n"
         "MOTION\nFrames: 3\nFrame Time: 0.01\n0 0 0\n1 1\n";
  const ToolRun bad = run_tool("'" + human("mh_male_game_engine.glb") + "' '" + (dir / "bad.bvh").string() + "' -o '" +
                               (dir / "x.pc2").string() + "'");
  EXPECT_EQ(bad.code, 2);
  EXPECT_NE(bad.out.find("bad BVH"), std::string::npos) << bad.out;
  EXPECT_NE(bad.out.find("truncated motion"), std::string::npos) << bad.out;
  std::ofstream((dir / "odd.bvh").string())
      << "HIERARCHY\nROOT Torso\n{\n OFFSET 0 0 0\n CHANNELS 3 Xrotation Yrotation Zrotation\n"
         " End Site\n {\n  OFFSET 0 1 0\n }\n}\nMOTION\nFrames: 1\nFrame Time: 0.01\n0 0 0\n";
  const ToolRun odd = run_tool("'" + human("mh_male_game_engine.glb") + "' '" + (dir / "odd.bvh").string() + "' -o '" +
                               (dir / "x.pc2").string() + "'");
  EXPECT_EQ(odd.code, 3);
  EXPECT_NE(odd.out.find("no bone of the character matches"), std::string::npos) << odd.out;
  const ToolRun frames = run_tool("'" + human("mh_male_game_engine.glb") + "' '" + clip("cmu_09_11_run.bvh") +
                                  "' -o '" + (dir / "x.pc2").string() + "' --frames 100:900");
  EXPECT_EQ(frames.code, 1);
  EXPECT_NE(frames.out.find("outside the motion's 0..165"), std::string::npos) << frames.out;
  std::ofstream((dir / "short.poses").string()) << "0123456789";
  const ToolRun pf = run_tool("'" + human("mh_male_game_engine.glb") + "' --pose-file '" +
                              (dir / "short.poses").string() + "' -o '" + (dir / "x.pc2").string() + "'");
  EXPECT_EQ(pf.code, 2);
  EXPECT_NE(pf.out.find("not a multiple of 3392 (53 bones x 16 float32)"), std::string::npos) << pf.out;
  const ToolRun obj = run_tool("'" + (dir / "x.obj").string() + "' '" + clip("cmu_09_11_run.bvh") + "' -o '" +
                               (dir / "x.pc2").string() + "'");
  EXPECT_EQ(obj.code, 2);
  const ToolRun noskel =
      run_tool("'" + human("mh_male_game_engine.glb") + "' '" + clip("cmu_09_11_run.bvh") + "' -o '/proc/x/y.pc2'");
  EXPECT_EQ(noskel.code, 5) << noskel.out;
  const ToolRun list =
      run_tool("'" + human("mh_male_game_engine.glb") + "' '" + clip("cmu_02_02_walk_daz.bvh") + "' --list-bones");
  EXPECT_EQ(list.code, 0);
  EXPECT_NE(list.out.find("upperarm_l               lShldr"), std::string::npos) << list.out;
}

TEST(Tool, ArgumentsAreCheckedBeforeLoading) {
  // Issue 15: exit codes and messages of the checks that need no character.
  const fs::path dir = scratch("arguments");
  EXPECT_EQ(run_tool("--help").code, 0);
  EXPECT_EQ(run_tool("--version").code, 0);
  // A directory as the character: said so (exit 2), not "does not exist".
  const ToolRun d = run_tool("'" + dir.string() + "' x.bvh -o '" + (dir / "x.pc2").string() + "'");
  EXPECT_EQ(d.code, 2) << d.out;
  EXPECT_NE(d.out.find("character '" + dir.string() + "' is a directory, not a file"), std::string::npos) << d.out;
  // --map-grid out of range: refused (exit 1) before the missing character is even looked at.
  const ToolRun g = run_tool("/nonexistent/char.glb /nonexistent/clip.bvh --points p.xyz --map-grid 2x3 -o " +
                             (dir / "x.pc2").string());
  EXPECT_EQ(g.code, 1) << g.out;
  EXPECT_NE(g.out.find("--map-grid NxM wants N in 4..256 (around a sweep) and M in 1..64 (per span), got '2x3'"),
            std::string::npos)
      << g.out;
  EXPECT_EQ(run_tool("/nonexistent/char.glb /nonexistent/clip.bvh --points p.xyz --map-grid 24x65 -o x.pc2").code, 1);
  EXPECT_EQ(run_tool("/nonexistent/char.glb /nonexistent/clip.bvh --points p.xyz --map-grid 24x -o x.pc2").code, 1);
  // --map-grid / --map-snap without --points would be ignored: refused instead.
  const ToolRun np = run_tool("/nonexistent/char.glb /nonexistent/clip.bvh --map-grid 24x3 -o x.pc2");
  EXPECT_EQ(np.code, 1) << np.out;
  EXPECT_NE(np.out.find("--map-grid is for --points"), std::string::npos) << np.out;
  EXPECT_EQ(run_tool("/nonexistent/char.glb /nonexistent/clip.bvh --map-snap 0.01 -o x.pc2").code, 1);
  // Non-printable bytes in an argument are escaped in the message, never sent to the terminal.
  const ToolRun esc = run_tool("\"$(printf '/nonexistent/\\033[31mred\\007.glb')\" x.bvh -o x.pc2");
  EXPECT_EQ(esc.code, 2) << esc.out;
  EXPECT_EQ(esc.out.find('\x1b'), std::string::npos) << esc.out;
  EXPECT_EQ(esc.out.find('\x07'), std::string::npos) << esc.out;
  EXPECT_NE(esc.out.find("\\x1B[31mred\\x07.glb"), std::string::npos) << esc.out;
}

TEST(Tool, BadInputFilesAreNamedNeverDropped) {
  REQUIRE_DATA();
  const fs::path dir = scratch("bad_inputs");
  const std::string mh = human("mh_male_game_engine.glb"), run = clip("cmu_09_11_run.bvh");
  // A PLY character whose header claims 4e9 vertices: refused with the limit (exit 2), no bad_alloc.
  std::ofstream((dir / "huge.ply").string())
      << "ply\nformat ascii 1.0\nelement vertex 4000000000\nproperty float x\nproperty float y\nproperty float z\n"
         "end_header\n0 0 0\n";
  const ToolRun huge = run_tool("'" + (dir / "huge.ply").string() + "' --skeleton '" + mh + "' '" + run + "' -o '" +
                                (dir / "x.pc2").string() + "'");
  EXPECT_EQ(huge.code, 2) << huge.out;
  EXPECT_NE(huge.out.find("at most 50000000 are read"), std::string::npos) << huge.out;
  EXPECT_EQ(huge.out.find("bad_alloc"), std::string::npos) << huge.out;
  // A garbage bone map: the message escapes its bytes (exit 3: nothing maps).
  {
    std::ofstream map((dir / "garbage.map").string(), std::ios::binary);
    map << "\x1b]0;pwned\x07\xff\xfe lShldr\n";
  }
  const ToolRun bm = run_tool("'" + mh + "' '" + clip("cmu_02_02_walk_daz.bvh") + "' --bone-map '" +
                              (dir / "garbage.map").string() + "' -o '" + (dir / "x.pc2").string() + "'");
  EXPECT_EQ(bm.code, 3) << bm.out;
  EXPECT_NE(bm.out.find("bone map: the character has no bone '\\x1B]0;pwned\\x07\\xFF\\xFE'"), std::string::npos)
      << bm.out;
  EXPECT_EQ(bm.out.find('\x1b'), std::string::npos);
  // --points: a NaN point is refused naming its line (exit 2), not skipped.
  std::ofstream((dir / "nan.xyz").string()) << "0 0 1\nnan 0 1\n";
  const ToolRun nan = run_tool("'" + mh + "' '" + run + "' --points '" + (dir / "nan.xyz").string() + "' -o '" +
                               (dir / "x.pc2").string() + "' --frames 0:0");
  EXPECT_EQ(nan.code, 2) << nan.out;
  EXPECT_NE(nan.out.find("nan.xyz:2: expected 'x y z' with finite numbers"), std::string::npos) << nan.out;
  // --points: faces OpenMesh cannot add (three triangles on one edge, the last two the same way
  // round) are counted and told, the copies of vertices OpenMesh makes for them never output;
  // every point is still deformed (exit 0).
  const Character c = load_gltf_character(mh);
  {
    std::ofstream obj((dir / "fan.obj").string());
    for (int v = 0; v < 5; ++v)  // Y-up, as the tool reads OBJ files
      obj << "v " << c.positions[3 * v] << ' ' << c.positions[3 * v + 2] << ' ' << -c.positions[3 * v + 1] << '\n';
    obj << "f 1 2 3\nf 1 2 4\nf 1 2 5\n";
  }
  const ToolRun fan = run_tool("'" + mh + "' '" + run + "' --points '" + (dir / "fan.obj").string() + "' -o '" +
                               (dir / "fan.pc2").string() + "' --frames 0:0");
  EXPECT_EQ(fan.code, 0) << fan.out;
  EXPECT_NE(fan.out.find("warning: points '" + (dir / "fan.obj").string() + "': 2 of its faces were dropped"),
            std::string::npos)
      << fan.out;
  EXPECT_EQ(read_pc2((dir / "fan.pc2").string()).point_count, 5);
}

}  // namespace
