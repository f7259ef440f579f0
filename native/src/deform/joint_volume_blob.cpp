#include "deform/joint_volume_blob.h"

#include "bind/blob_io.h"

#include <cmath>

namespace sd {

namespace {

constexpr char kJointVolumesMagic[4] = {'S', 'D', 'J', 'V'};
constexpr uint32_t kMostTables = 1u << 16;

bool unit(const dvec3& v) { return std::isfinite(v.x + v.y + v.z) && std::abs(glm::length(v) - 1.0) < 1e-9; }

}  // namespace

std::vector<uint8_t> serialize_joint_volumes(const std::vector<JointVolumeTable>& tables, uint64_t rig_fingerprint) {
    blob::Writer w;
    w.put<uint64_t>(rig_fingerprint);
    w.put<uint32_t>(static_cast<uint32_t>(tables.size()));
    for (const JointVolumeTable& t : tables) {
        w.put<int32_t>(t.sweep);
        w.put<int32_t>(t.key);
        w.put<int32_t>(t.parent);
        w.put<int32_t>(t.child);
        w.put_glm(t.axis);
        w.put_glm(t.e1);
        w.put_glm(t.e2);
        w.put_array(t.added);
        w.put<double>(t.most_added);
    }
    return blob::frame(kJointVolumesMagic, kJointVolumesFormatVersion, w.bytes);
}

std::vector<JointVolumeTable> deserialize_joint_volumes(const uint8_t* data, size_t size, uint64_t* rig_fingerprint) {
    blob::Reader r = blob::unframe(data, size, kJointVolumesMagic, kJointVolumesFormatVersion, "joint volumes");
    const uint64_t fingerprint = r.get<uint64_t>();
    const uint32_t n = r.get<uint32_t>();
    if (n > kMostTables) throw CorruptData("joint volumes blob has too many tables");
    std::vector<JointVolumeTable> tables(n);
    for (JointVolumeTable& t : tables) {
        t.sweep = r.get<int32_t>();
        t.key = r.get<int32_t>();
        t.parent = r.get<int32_t>();
        t.child = r.get<int32_t>();
        t.axis = r.get_glm<dvec3>();
        t.e1 = r.get_glm<dvec3>();
        t.e2 = r.get_glm<dvec3>();
        // (the indices, the table's size and its values: Deformer::set_joint_volumes)
        t.added = r.get_array<double>(JointVolumeTable::kSwings * JointVolumeTable::kDirections);
        t.most_added = r.get<double>();
        if (!unit(t.axis) || !unit(t.e1) || !unit(t.e2) || std::abs(glm::dot(t.axis, t.e1)) > 1e-9 ||
            std::abs(glm::dot(t.axis, t.e2)) > 1e-9 || std::abs(glm::dot(t.e1, t.e2)) > 1e-9)
            throw CorruptData("a joint volume table's axes are not unit vectors at right angles");
    }
    if (r.left() != 0) throw CorruptData("joint volumes blob has trailing bytes");
    if (rig_fingerprint) *rig_fingerprint = fingerprint;
    return tables;
}

}  // namespace sd
