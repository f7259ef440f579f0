#include "bind/blob_io.h"

#include <array>

namespace sd {

uint32_t crc32(const uint8_t* data, size_t size) {
    static const std::array<uint32_t, 256> table = [] {
        std::array<uint32_t, 256> t{};
        for (uint32_t i = 0; i < 256; ++i) {
            uint32_t c = i;
            for (int k = 0; k < 8; ++k) c = (c & 1) ? 0xEDB88320u ^ (c >> 1) : c >> 1;
            t[i] = c;
        }
        return t;
    }();
    uint32_t c = 0xFFFFFFFFu;
    for (size_t i = 0; i < size; ++i) c = table[(c ^ data[i]) & 0xFF] ^ (c >> 8);
    return c ^ 0xFFFFFFFFu;
}

namespace blob {

std::vector<uint8_t> frame(const char magic[4], uint32_t version, const std::vector<uint8_t>& payload) {
    Writer w;
    w.bytes.assign(magic, magic + 4);
    w.put<uint32_t>(version);
    w.put<uint64_t>(payload.size());
    w.bytes.insert(w.bytes.end(), payload.begin(), payload.end());
    w.put<uint32_t>(crc32(payload.data(), payload.size()));
    return w.bytes;
}

Reader unframe(const uint8_t* data, size_t size, const char magic[4], uint32_t version, const char* what,
               uint32_t min_version, uint32_t* out_version) {
    if (!data) throw CorruptData(std::string(what) + " blob is NULL");
    const size_t header = 4 + 4 + 8;
    if (size < header + 4) throw CorruptData(std::string(what) + " blob is truncated");
    if (std::memcmp(data, magic, 4) != 0) throw CorruptData(std::string("not a ") + what + " blob (bad magic)");
    Reader r(data + 4, size - 4);
    const uint32_t v = r.get<uint32_t>();
    if (min_version == 0) min_version = version;
    if (v < min_version || v > version)
        throw CorruptData(
            std::string(what) + " blob has format version " + std::to_string(v) + ", this library reads version" +
            (min_version == version ? " " + std::to_string(version)
                                    : "s " + std::to_string(min_version) + " to " + std::to_string(version)));
    if (out_version) *out_version = v;
    const uint64_t n = r.get<uint64_t>();
    if (n != size - header - 4) throw CorruptData(std::string(what) + " blob is truncated or has trailing bytes");
    uint32_t stored;
    std::memcpy(&stored, data + header + n, 4);
    if (stored != crc32(data + header, n))
        throw CorruptData(std::string(what) + " blob checksum mismatch (corrupt data)");
    return Reader(data + header, n);
}

}  // namespace blob
}  // namespace sd
