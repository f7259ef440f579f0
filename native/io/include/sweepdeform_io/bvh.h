// BVH motion capture: reading a clip, and retargeting it onto a Character's skeleton.
//
// Reading follows the BVH format as the CMU / cgspeed, Daz and Blender exporters write it:
//   * HIERARCHY with one or more ROOTs, nested JOINTs and End Sites, each joint with an
//     OFFSET (its rest position relative to its parent) and CHANNELS in any order and any
//     subset of Xposition Yposition Zposition Xrotation Yrotation Zrotation.
//   * A joint's local matrix in a frame is T * R, with T = its position channels when it has
//     them (the absolute local position, as Blender's importer reads them), else its OFFSET,
//     and R = the product of its rotation channels *in the order they are listed*
//     ("Zrotation Yrotation Xrotation" is Rz * Ry * Rx), angles in degrees.
//   * The rest pose ("frame" -1 below) has every rotation channel at 0 and every position
//     channel at the joint's OFFSET.
//   * MOTION with "Frames:" and "Frame Time:" (seconds), then Frames rows of all channels in
//     hierarchy order; rows may wrap over lines.
//
// Retargeting (BvhRetarget) does what the data README (../shared/data/README.md, Sect. 2.3)
// describes for the *_anims.glb files, see the class.
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "sweepdeform_io/character.h"

namespace sd::io {

enum class BvhChannel : uint8_t { Xposition, Yposition, Zposition, Xrotation, Yrotation, Zrotation };

struct BvhJoint {
  std::string name;
  int32_t parent = -1;                           ///< index into BvhClip::joints, -1 for a root
  std::array<double, 3> offset{};                ///< rest position relative to the parent (file units)
  std::vector<BvhChannel> channels;              ///< in file order
  int32_t first_channel = 0;                     ///< column of channels[0] in a motion row
  std::vector<int32_t> children;                 ///< joint indices
  std::vector<std::array<double, 3>> end_sites;  ///< End Site offsets (usually 0 or 1)
};

struct BvhClip {
  std::string source;            ///< file name (for messages)
  std::vector<BvhJoint> joints;  ///< file order: a parent comes before its children
  int32_t frame_count = 0;
  double frame_time_s = 0.0;  ///< seconds per frame (> 0)
  int32_t channel_count = 0;  ///< values per frame
  std::vector<float> motion;  ///< #frame_count * channel_count

  int32_t joint_count() const { return static_cast<int32_t>(joints.size()); }
  /// Index of the joint named `name` (exact match), or -1.
  int32_t find_joint(std::string_view name) const;
  /// One channel value; frame -1 is the rest pose.
  double value(int32_t frame, int32_t joint, size_t channel) const;
};

/// Reads a BVH file. Throws std::runtime_error naming the file and line on any problem
/// (missing file, unknown keyword or channel, unbalanced braces, fewer values than
/// Frames x channels, non-positive frame time).
BvhClip load_bvh(const std::string& path);
/// Same from text in memory; `source` names it in messages.
BvhClip parse_bvh(std::string_view text, const std::string& source = "<memory>");

/// #J*16 column-major global joint matrices at `frame` (-1 = rest), in BVH space (file axes
/// and units). Throws std::out_of_range for a frame outside [-1, frame_count).
std::vector<float> bvh_global_matrices(const BvhClip& clip, int32_t frame);

// ---- retargeting ---------------------------------------------------------------------------

/// Which BVH joint drives which bone of a character.
struct BvhBoneMap {
  std::vector<int32_t> source;    ///< #B: the BVH joint driving bone b, or -1 (b keeps its
                                  ///< rest pose relative to its parent)
  int32_t root_bone = -1;         ///< the hips bone: it takes the root translation
  int32_t root_joint = -1;        ///< the BVH hips joint
  std::string source_convention;  ///< "cgspeed MotionBuilder", "Daz/Second Life", "Mixamo", "BVH names", "custom"
  std::string target_convention;  ///< "MakeHuman game_engine", "Mixamo", "CesiumMan", ...
  int32_t mapped_count() const;
};

/// Maps BVH joints onto the character's bones by name. Both sides are recognised by their
/// naming convention: the BVH side as cgspeed "MotionBuilder-friendly" (Hips, LeftUpLeg, ...;
/// LFingers/LeftHandIndex1 variants), Daz / Second Life (hip, abdomen, lShldr, ...), Mixamo
/// (Spine, Spine1, Spine2) or plain BVH-style names; the character side as MakeHuman "game_engine" / Unreal (pelvis,
/// upperarm_l, ...), Mixamo / BVH-style (Hips, LeftArm, ...; "mixamorig:" prefixes are
/// dropped), CesiumMan's joints, or bones named exactly like the BVH joints.
/// `overrides` (character bone, BVH joint) pairs replace or add entries; an empty joint name
/// unmaps the bone.
/// Throws std::runtime_error when no bone can be matched (the message lists both sides'
/// names) or when an override names a bone or joint that does not exist.
BvhBoneMap map_bvh_to_character(const BvhClip& clip, const Character& character,
                                const std::vector<std::pair<std::string, std::string>>& overrides = {});

struct BvhRetargetOptions {
  /// The character's space is Blender's Z-up (true: load_gltf_character's default) or the
  /// BVH's own Y-up (false). BVH axes are turned like Blender's BVH importer does:
  /// (x, y, z) -> (x, -z, y).
  bool character_z_up = true;
  /// BVH units -> character units for the root translation; 0 = ratio of the character's leg
  /// length (thigh + shin) to the BVH's, or of the hips-to-head heights without legs.
  double translation_scale = 0.0;
  /// The BVH rest position of the root. true: its OFFSET, always (the *_anims.glb files).
  /// false (default): its OFFSET, unless that is (0,0,0) (cgspeed's 01_xx originals, Daz),
  /// where the OFFSET would lift the character by the whole hip height (the *_anims.glb clips
  /// of 01_03 and 60_01 float 1.0 m and 0.86 m above the floor); there the rest height is the
  /// root's height above the lowest rest joint plus the lowest height any joint reaches in
  /// the clip (the floor).
  bool root_rest_from_offset = false;
};

/// Poses a character from a BVH clip: the retarget of ../shared/data/README.md Sect. 2.3,
/// which reproduces the *_anims.glb files' bone matrices to 0.02 degrees and 0.05 mm (see
/// tests/native/cli/cli_test.cpp), with one deliberate difference (root_rest_from_offset).
///  * Every mapped bone b driven by joint j gets j's world rotation change relative to the
///    BVH rest pose, applied after a per-bone swing S_b that turns b's rest direction (head
///    to tail; the character's A-pose) onto the direction of the bone Blender's BVH importer
///    makes for j (the BVH's T-pose; towards its only child, the mean of its children or its
///    End Site; a zero-length bone continues its parent):
///        R_b(f) = Delta_j(f) * S_b * R_b(rest),   Delta_j(f) = G_j(f) * G_j(rest)^-1.
///    The hips bone gets no swing.
///  * Unmapped bones (fingers, toes, twist bones, Root) keep their rest pose relative to
///    their parent; every bone's head follows its parent (bone lengths are the character's).
///  * The hips bone's head moves by the BVH root's translation from its rest position times
///    a scale: the character's hip-to-ankle distance over the BVH's (left leg). The source
///    facing direction and root motion are kept, so the character travels.
class BvhRetarget {
 public:
  /// Keeps references to `clip` and `character`: both must outlive the retarget.
  /// Throws std::invalid_argument when `map` is not for this clip and character.
  BvhRetarget(const BvhClip& clip, const Character& character, BvhBoneMap map, const BvhRetargetOptions& options = {});

  /// #B*16 column-major posed bone matrices (armature space; the same space and bone frames
  /// as Character::bone_rest and sample_pose) at BVH frame `frame` (-1 = the BVH rest pose,
  /// i.e. the character in its rest pose turned by the swings).
  std::vector<float> pose(int32_t frame) const;

  const BvhBoneMap& map() const { return map_; }
  double translation_scale() const { return scale_; }
  int32_t frame_count() const { return clip_->frame_count; }

 private:
  const BvhClip* clip_;
  const Character* character_;
  BvhBoneMap map_;
  bool z_up_ = true;
  double scale_ = 1.0;
  std::array<double, 3> root_rest_{};         ///< BVH space
  std::vector<std::array<double, 4>> swing_;  ///< #B quaternions (w, x, y, z), character space
};

}  // namespace sd::io
