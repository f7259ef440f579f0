// Plain data of a rigged character: rest mesh, skeleton, skin weights and animations.
//
// Conventions used by every sd::io function:
//   * Units are those of the source file (metres for glTF). "Scene space" is the space of
//     `positions`: Blender's Z-up armature space when loaded with to_blender_axes = true,
//     the glTF Y-up world space otherwise.
//   * Matrices are 4x4, column-major (OpenGL / glm / Eigen default), 16 floats each, so the
//     translation is elements [12], [13], [14].
//   * Quaternions are stored x, y, z, w (glTF order).
//   * Arrays are flat; "#V*3" means V rows of 3 values, row-major.
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

namespace sd::io {

/// The node hierarchy that poses the bones. It holds the skin's joint nodes and all their
/// ancestors (e.g. glTF's "Armature" or "Z_UP" nodes), ordered so that a parent comes before
/// its children. A node's global matrix is
///   root_transform * local(root ancestor) * ... * local(parent) * local(node).
struct NodeTree {
  std::vector<std::string> names;       ///< #N node names (may be empty strings)
  std::vector<int32_t> parents;         ///< #N, index into this tree, -1 for a root; parents[n] < n
  std::vector<float> rest_translation;  ///< #N*3, local rest translation (file units)
  std::vector<float> rest_rotation;     ///< #N*4, local rest rotation quaternion x, y, z, w
  std::vector<float> rest_scale;        ///< #N*3, local rest scale
  /// #N*16 local rest matrix. Equals T*R*S, except for nodes given as a matrix in the file
  /// (glTF forbids animating those), whose exact matrix is kept here.
  std::vector<float> rest_matrix;
  std::vector<int32_t> bone_node;  ///< #B, node of each bone
  /// Applied on the left of every global matrix: the glTF -> Blender axis change, or identity.
  std::array<float, 16> root_transform{1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
};

/// One animated property of one node.
struct Channel {
  enum class Path : int32_t { Translation, Rotation, Scale };
  /// CubicSpline keys store 3 values per key: in-tangent, value, out-tangent.
  enum class Interpolation : int32_t { Linear, Step, CubicSpline };
  int32_t node = -1;  ///< index into Character::nodes
  Path path = Path::Translation;
  Interpolation interpolation = Interpolation::Linear;
  std::vector<float> times;  ///< #K key times in seconds, ascending
  /// #K*C values (C = 3 for translation/scale, 4 for rotation x,y,z,w); #K*3*C for CubicSpline.
  /// They are local node values in file axes: the axis change is applied by root_transform.
  std::vector<float> values;
};

/// A clip. Sample it on [0, duration_s]; before its first key (first_key_s) and after its
/// last key every channel holds its first/last value.
struct Animation {
  std::string name;
  double duration_s = 0.0;   ///< time of the last key of any channel, seconds
  double first_key_s = 0.0;  ///< time of the first key of any channel, seconds
  std::vector<Channel> channels;
};

/// A skinned character. V = vertices, T = triangles, B = bones.
/// Bones are ordered so that bone_parents[b] < b (parents first).
struct Character {
  std::vector<float> positions;         ///< #V*3, rest mesh vertex positions in scene space
  std::vector<int32_t> triangles;       ///< #T*3 vertex indices, counter-clockwise = outward
  std::vector<std::string> bone_names;  ///< #B
  std::vector<int32_t> bone_parents;    ///< #B, -1 for a root
  /// #B*16 rest (bind) matrix of each bone: maps bone space to scene space (rigid in practice).
  std::vector<float> bone_rest;
  std::vector<float> bone_heads;  ///< #B*3, = translation of bone_rest
  /// #B*3, estimated bone ends (glTF stores none): see load_gltf_character. Never = head.
  std::vector<float> bone_tails;
  std::vector<int32_t> skin_joints;  ///< #V*4 bone indices; unused slots: index 0, weight 0
  /// #V*4, >= 0, each row sums to 1 (loaders and refinement also sort each row decreasing)
  std::vector<float> skin_weights;
  std::vector<Animation> animations;
  NodeTree nodes;  ///< hierarchy used by sample_pose
};

/// Checks that `c` is consistent: array sizes, index ranges, parents before children,
/// finite values, weight rows summing to 1 (within 1e-4), bone_heads = rest translations,
/// non-degenerate bones, animation channels well-formed.
/// Returns "" when valid, otherwise a human-readable list of problems (one per line, the
/// first few of each kind).
std::string validate(const Character& c);

}  // namespace sd::io
