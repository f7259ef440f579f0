// Versioned, checksummed byte blobs of a rig and of a binding (stored in .blend files, so
// they are untrusted input: every read is bounds-checked and every value re-validated).
//
// Layout: magic (4 bytes) | format version u32 | payload size u64 | payload | CRC-32 u32,
// little-endian. The payload of a rig is rebuilt through the same validation as the ABI.
#pragma once

#include "bind/bind.h"
#include "rig/rig.h"

#include <cstdint>
#include <vector>

namespace sd {

/// Rig blobs: version 2 adds the key-ellipse corrections (Sect. 4.2) after the version 1
/// payload, version 3 the keys' twist spreads after them, version 4 their twist directions;
/// version 1 blobs are still read (as rigs without corrections), versions 1 and 2 with the
/// default twist spread, versions 1 to 3 with every twist about the key's normal.
constexpr uint32_t kRigFormatVersion = 4;
constexpr uint32_t kBindingFormatVersion = 1;

std::vector<uint8_t> serialize_rig(const Rig& rig);
/// @throws CorruptData on a bad magic, version, size or checksum; InvalidInput if the
/// decoded rig does not validate.
Rig deserialize_rig(const uint8_t* data, size_t size);

std::vector<uint8_t> serialize_binding(const Binding& binding);
/// @throws CorruptData
Binding deserialize_binding(const uint8_t* data, size_t size);

/// A 64-bit fingerprint of the rig's content (FNV-1a of its payload), so a binding can
/// tell whether it was made with this rig.
uint64_t rig_fingerprint(const Rig& rig);

}  // namespace sd
