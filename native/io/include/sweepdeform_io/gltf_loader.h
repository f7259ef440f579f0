// Loading a skinned character from glTF 2.0 (.glb or .gltf).
#pragma once

#include <cstddef>
#include <string>

#include "sweepdeform_io/character.h"

namespace sd::io {

struct GltfLoadOptions {
  /// Merge vertices closer than 1e-6 x (bounding-box diagonal) into one (the lowest index keeps
  /// its skin weights), remap the triangles and drop triangles that become degenerate.
  /// Needed for files whose vertices are split at UV/normal seams (CesiumMan), so that the
  /// mesh becomes one closed surface.
  bool weld = false;
  /// Convert glTF's Y-up axes to Blender's Z-up, as Blender's importer does:
  /// a point (x, y, z) becomes (x, -z, y) (axis change A, a +90 degree turn about X).
  /// Scene-space matrices M (bone_rest, sample_pose) become A*M, so bone frames keep the
  /// file's local axes. This is what Blender's importer gives with bone_heuristic='BLENDER':
  /// it conjugates (A*M*inverse(A)) and then turns each bone frame by A. For files exported
  /// from Blender (the MakeHuman ones) it recovers the original bones: local +Y from head to
  /// tail. Skinning matrices pose * inverse(rest) are the same as with plain conjugation.
  bool to_blender_axes = true;
};

/// Loads the one skinned mesh of a glTF file and its skeleton and animations.
///
/// * Every mesh primitive whose node uses the file's skin is merged into one mesh; a second,
///   different skin is an error. Only TRIANGLES primitives; indices u8/u16/u32 or none.
/// * Rest pose = bind pose: bone_rest[b] = W * inverse(inverseBindMatrices[b]) and
///   positions = W * POSITION, with W = global(joint) * inverseBindMatrices[joint] of the
///   skeleton's root joint in the file's own node rest pose (the identity for most files).
///   So the rest mesh lies where the file's node rest pose would skin it, in world space, and
///   skinning with sample_pose(...) * inverse(bone_rest) reproduces glTF's skinning.
/// * Skin: JOINTS_n as u8/u16, WEIGHTS_n as float or normalized u8/u16; all sets are read,
///   the 4 largest influences kept and renormalised. A vertex without any weight gets
///   weight 1 on the bone whose head-tail segment is nearest.
/// * Bones: the skin's joints, in skin order when parents already come first (true for both
///   shared data sets), else in the file's depth-first node order. A bone's parent is its
///   nearest ancestor node that is a joint.
/// * Bone tails (glTF has none). Bone heads are exact; tails approximate what Blender shows:
///     - Rigs following Blender's convention of the bone's local +Y along the bone (detected:
///       >= 90% of the one-child bones have +Y pointing at their child; true for files
///       exported from Blender): tail = head + L * (+Y), L = the farthest child head's
///       projection on +Y, so bone directions are Blender's exactly.
///     - Other rigs: one child -> the child's head. Several children -> the child continuing
///       the parent -> bone direction within ~45 degrees (spine -> neck), else the children's
///       mean head if it is >= 25% of the farthest child distance away (hand -> fingers),
///       else the farthest child head (hips root -> spine, legs on both sides).
///     - Leaves (and L <= 0): half the parent bone's length, along +Y for Blender-convention
///       rigs, else continuing the parent-head -> head direction; a root without children
///       gets 5% of the mesh size.
///   Tails are never at the head (a last resort uses +Y and 1% of the mesh size).
/// Throws std::runtime_error with a message naming the file on any failure.
Character load_gltf_character(const std::string& path, const GltfLoadOptions& options = {});

/// The same from the bytes of a .glb, or of a .gltf whose buffers are embedded (data: URIs),
/// told apart by the "glTF" magic as for a file. `name` stands for the file in messages.
/// Buffers in external files are refused: there is no directory to look in, and a reader of
/// untrusted bytes (the fuzz target) must not open files named in them.
Character load_gltf_character_from_memory(const void* data, size_t size, const std::string& name,
                                          const GltfLoadOptions& options = {});

}  // namespace sd::io
