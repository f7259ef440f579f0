// The joint volume tables as a blob, stored with a binding so that a file opened again need
// not bend every limb joint to measure them (0.3 s for a 53.5K character, at every open of the
// file: a farm's every job). Stored in .blend files, so untrusted: read through the
// bounds-checked reader (bind/blob_io.h), each table's frame checked here and the rest by
// Deformer::set_joint_volumes.
#pragma once

#include "deform/joint_volume.h"

#include <cstdint>
#include <vector>

namespace sd {

/// 2 since the twenty-fourth session: a shoulder's table reads nothing where the arm is lowered,
/// and holds up to 0.1 of its sweep's volume (joint_volume.cpp); a file's tables of version 1
/// are measured again.
constexpr uint32_t kJointVolumesFormatVersion = 2;

/// The tables of a deformer whose rig has `rig_fingerprint` (bind/serialize.h).
std::vector<uint8_t> serialize_joint_volumes(const std::vector<JointVolumeTable>& tables, uint64_t rig_fingerprint);

/// @throws CorruptData on a bad frame, a count or array out of range, or a table whose axes are
/// not finite unit vectors at right angles. `rig_fingerprint` receives the rig's.
std::vector<JointVolumeTable> deserialize_joint_volumes(const uint8_t* data, size_t size, uint64_t* rig_fingerprint);

}  // namespace sd
