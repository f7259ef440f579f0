// The byte layout every blob of the core shares (bind/serialize.h, deform/joint_volume_blob.h):
// magic (4 bytes) | format version u32 | payload size u64 | payload | CRC-32 u32, little-endian,
// and the bounds-checked reader and the writer of a payload.
#pragma once

#include "math/math_types.h"

#include <glm/gtc/type_ptr.hpp>

#include <cstdint>
#include <cstring>
#include <string>
#include <type_traits>
#include <vector>

namespace sd {

/// CRC-32 (IEEE 802.3) of a byte range.
uint32_t crc32(const uint8_t* data, size_t size);

namespace blob {

class Writer {
public:
    template <class T>
    void put(const T& v) {
        static_assert(std::is_trivially_copyable<T>::value, "plain data only");
        const auto* p = reinterpret_cast<const uint8_t*>(&v);
        bytes.insert(bytes.end(), p, p + sizeof(T));
    }
    /// GLM vectors, quaternions and matrices, as their doubles.
    template <class G>
    void put_glm(const G& g) {
        const double* p = glm::value_ptr(g);
        for (size_t i = 0; i < sizeof(G) / sizeof(double); ++i) put<double>(p[i]);
    }
    template <class T>
    void put_array(const std::vector<T>& v) {
        put<uint64_t>(v.size());
        const auto* p = reinterpret_cast<const uint8_t*>(v.data());
        bytes.insert(bytes.end(), p, p + v.size() * sizeof(T));
    }
    std::vector<uint8_t> bytes;
};

class Reader {
public:
    Reader(const uint8_t* data, size_t size) : p_(data), left_(size) {}
    template <class T>
    T get() {
        T v;
        take(&v, sizeof(T));
        return v;
    }
    template <class G>
    G get_glm() {
        G g;
        double* p = glm::value_ptr(g);
        for (size_t i = 0; i < sizeof(G) / sizeof(double); ++i) p[i] = get<double>();
        return g;
    }
    template <class T>
    std::vector<T> get_array(size_t max_count) {
        const uint64_t n = get<uint64_t>();
        if (n > max_count || n * sizeof(T) > left_) throw CorruptData("blob array length is out of range");
        std::vector<T> v(n);
        take(v.data(), n * sizeof(T));
        return v;
    }
    size_t left() const { return left_; }

private:
    void take(void* out, size_t n) {
        if (n > left_) throw CorruptData("blob is truncated");
        if (n == 0) return;  // an empty array: out may be NULL
        std::memcpy(out, p_, n);
        p_ += n;
        left_ -= n;
    }
    const uint8_t* p_;
    size_t left_;
};

/// The framed blob of a payload.
std::vector<uint8_t> frame(const char magic[4], uint32_t version, const std::vector<uint8_t>& payload);

/// Checks the frame and returns a reader over the payload; versions [min_version, version]
/// are accepted (out_version, if given, receives the blob's). @throws CorruptData
Reader unframe(const uint8_t* data, size_t size, const char magic[4], uint32_t version, const char* what,
               uint32_t min_version = 0, uint32_t* out_version = nullptr);

}  // namespace blob
}  // namespace sd
