#include "bind/serialize.h"

#include "bind/blob_io.h"

#include <glm/gtc/type_ptr.hpp>

#include <array>
#include <cstring>

namespace sd {

namespace {

using blob::frame;
using blob::Reader;
using blob::unframe;
using blob::Writer;

/// The version 1 payload: skeleton and key ellipses. The fingerprint hashes only this part,
/// so editing corrections keeps a binding valid.
std::vector<uint8_t> rig_payload(const Rig& rig) {
    Writer w;
    const Skeleton& s = rig.skeleton;
    w.put<int32_t>(s.bone_count());
    for (int b = 0; b < s.bone_count(); ++b) {
        w.put<int32_t>(s.parents[b]);
        w.put_glm(s.rest[b]);
        w.put_glm(s.heads[b]);
        w.put_glm(s.tails[b]);
    }
    w.put<int32_t>(static_cast<int32_t>(rig.sweeps.size()));
    for (const Sweep& sw : rig.sweeps) {
        w.put<int32_t>(sw.key_count());
        for (const KeyEllipse& k : sw.keys) {
            w.put_glm(k.center);
            w.put_glm(k.orientation);
            w.put(k.a);
            w.put(k.b);
            w.put<int32_t>(k.bone);
            w.put<int32_t>(k.joint_parent);
            w.put(k.swing_fraction);
            w.put(k.twist_fraction);
        }
    }
    return w.bytes;
}

/// Version 2 appends, per sweep and key: int32 count, then per correction the angle, the
/// center offset (3), the rotation vector (3), scale_a, scale_b (doubles) and int32 muted.
void put_corrections(Writer& w, const Rig& rig) {
    for (const Sweep& sw : rig.sweeps)
        for (const KeyEllipse& k : sw.keys) {
            w.put<int32_t>(static_cast<int32_t>(k.corrections.size()));
            for (const KeyCorrection& c : k.corrections) {
                w.put(c.angle);
                w.put_glm(c.delta_center);
                w.put_glm(c.delta_rotation);
                w.put(c.scale_a);
                w.put(c.scale_b);
                w.put<int32_t>(c.muted ? 1 : 0);
            }
        }
}

std::vector<CorrectionRecord> get_corrections(Reader& r, const std::vector<std::vector<KeyEllipse>>& sweeps) {
    std::vector<CorrectionRecord> records;
    for (size_t s = 0; s < sweeps.size(); ++s)
        for (int k = 0; k < static_cast<int>(sweeps[s].size()); ++k) {
            const int32_t n = r.get<int32_t>();
            if (n < 0 || n > kMaxCorrectionsPerKey) throw CorruptData("rig blob has an invalid correction count");
            for (int i = 0; i < n; ++i) {
                CorrectionRecord rec;
                rec.sweep = static_cast<int>(s);
                rec.key = k;
                KeyCorrection& c = rec.correction;
                c.angle = r.get<double>();
                c.delta_center = r.get_glm<dvec3>();
                c.delta_rotation = r.get_glm<dvec3>();
                c.scale_a = r.get<double>();
                c.scale_b = r.get<double>();
                const int32_t muted = r.get<int32_t>();
                if (muted != 0 && muted != 1) throw CorruptData("rig blob has an invalid muted flag");
                c.muted = muted != 0;
                records.push_back(rec);
            }
        }
    return records;
}

/// Version 3 appends, per sweep and key, its twist spread (double); version 4 then, per sweep
/// and key, its twist direction (3 doubles; zero: the key's normal). Both validated by add_sweep.
void put_twist_sections(Writer& w, const Rig& rig) {
    for (const Sweep& sw : rig.sweeps)
        for (const KeyEllipse& k : sw.keys) w.put(k.twist_spread);
    for (const Sweep& sw : rig.sweeps)
        for (const KeyEllipse& k : sw.keys) w.put_glm(k.twist_direction);
}

void get_twist_sections(Reader& r, uint32_t version, std::vector<std::vector<KeyEllipse>>& sweeps) {
    if (version >= 3)
        for (std::vector<KeyEllipse>& keys : sweeps)
            for (KeyEllipse& k : keys) k.twist_spread = r.get<double>();
    if (version >= 4)
        for (std::vector<KeyEllipse>& keys : sweeps)
            for (KeyEllipse& k : keys) k.twist_direction = r.get_glm<dvec3>();
}

constexpr char kRigMagic[4] = {'S', 'D', 'R', 'G'};
constexpr char kBindingMagic[4] = {'S', 'D', 'B', 'N'};

}  // namespace

std::vector<uint8_t> serialize_rig(const Rig& rig) {
    Writer w;
    w.bytes = rig_payload(rig);
    put_corrections(w, rig);
    put_twist_sections(w, rig);
    return frame(kRigMagic, kRigFormatVersion, w.bytes);
}

uint64_t rig_fingerprint(const Rig& rig) {
    uint64_t h = 1469598103934665603ull;
    for (uint8_t byte : rig_payload(rig)) h = (h ^ byte) * 1099511628211ull;
    return h;
}

Rig deserialize_rig(const uint8_t* data, size_t size) {
    uint32_t version = 0;
    Reader r = unframe(data, size, kRigMagic, kRigFormatVersion, "rig", 1, &version);
    const int32_t B = r.get<int32_t>();
    if (B < 1 || B > 100000) throw CorruptData("rig blob has an invalid bone count");
    std::vector<int> parents(B);
    std::vector<dmat4> rest(B);
    std::vector<dvec3> heads(B), tails(B);
    for (int b = 0; b < B; ++b) {
        parents[b] = r.get<int32_t>();
        rest[b] = r.get_glm<dmat4>();
        heads[b] = r.get_glm<dvec3>();
        tails[b] = r.get_glm<dvec3>();
    }
    Rig rig;
    rig.skeleton = Skeleton::build(std::move(parents), std::move(rest), std::move(heads), std::move(tails));
    const int32_t S = r.get<int32_t>();
    if (S < 0 || S > 1024) throw CorruptData("rig blob has an invalid sweep count");
    std::vector<std::vector<KeyEllipse>> sweeps(S);
    for (std::vector<KeyEllipse>& keys : sweeps) {
        const int32_t K = r.get<int32_t>();
        if (K < 2 || K > 256) throw CorruptData("rig blob has an invalid key count");
        keys.resize(K);
        for (KeyEllipse& k : keys) {
            k.center = r.get_glm<dvec3>();
            k.orientation = r.get_glm<dquat>();
            k.a = r.get<double>();
            k.b = r.get<double>();
            k.bone = r.get<int32_t>();
            k.joint_parent = r.get<int32_t>();
            k.swing_fraction = r.get<double>();
            k.twist_fraction = r.get<double>();
        }
    }
    std::vector<CorrectionRecord> corrections;
    if (version >= 2) corrections = get_corrections(r, sweeps);
    get_twist_sections(r, version, sweeps);
    if (r.left() != 0) throw CorruptData("rig blob has trailing bytes");
    for (std::vector<KeyEllipse>& keys : sweeps) rig.add_sweep(std::move(keys));
    if (version >= 2) rig.set_corrections(corrections);
    return rig;
}

std::vector<uint8_t> serialize_binding(const Binding& b) {
    Writer w;
    w.put<uint64_t>(b.rig_fingerprint);
    w.put_array(b.rest_positions);
    w.put_array(b.sweep_offsets);
    w.put_array(b.sweep_influences);
    w.put_array(b.bone_offsets);
    w.put_array(b.bone_influences);
    return frame(kBindingMagic, kBindingFormatVersion, w.bytes);
}

Binding deserialize_binding(const uint8_t* data, size_t size) {
    Reader r = unframe(data, size, kBindingMagic, kBindingFormatVersion, "binding");
    constexpr size_t kMax = size_t(1) << 31;
    Binding b;
    b.rig_fingerprint = r.get<uint64_t>();
    b.rest_positions = r.get_array<float>(kMax);
    b.sweep_offsets = r.get_array<uint32_t>(kMax);
    b.sweep_influences = r.get_array<SweepInfluence>(kMax);
    b.bone_offsets = r.get_array<uint32_t>(kMax);
    b.bone_influences = r.get_array<BoneInfluence>(kMax);
    if (r.left() != 0) throw CorruptData("binding blob has trailing bytes");
    b.check_structure();
    return b;
}

}  // namespace sd
