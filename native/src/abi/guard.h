// Shared by the C ABI's translation units: the opaque handles, status mapping, the thread-local
// message, the exception barrier, and the helpers several ABI areas use (bytes into the
// caller's buffer, a sweep by index). Internal; not installed.
#pragma once

#include "sweepdeform/sweepdeform.h"

#include "bind/bind.h"
#include "deform/deform.h"
#include "deform/output_check.h"
#include "math/math_types.h"
#include "rig/rig.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <memory>
#include <new>
#include <string>
#include <vector>

// The opaque handles of the header.
struct sd_rig {
    sd::Rig rig;
};
struct sd_binding {
    sd::Binding binding;
};
struct sd_deformer {
    std::unique_ptr<sd::Deformer> deformer;
};
struct sd_output_check {
    std::unique_ptr<sd::OutputCheck> check;
};

namespace sd::abi {

/// The thread-local message behind sd_last_error().
inline std::string& last_error() {
    thread_local std::string message;
    return message;
}

inline sd_status fail(sd_status status, std::string message) {
    last_error() = std::move(message);
    return status;
}

/// Runs f (returning sd_status), mapping every exception to a status and a message, so
/// that no exception crosses the ABI. InvalidInput maps to `invalid_input` (blob loaders
/// report it as corrupt data).
template <class F>
sd_status guarded(const char* function, F&& f, sd_status invalid_input = SD_ERR_INVALID_ARGUMENT) {
    try {
        last_error().clear();
        return f();
    } catch (const sd::InvalidInput& e) {
        return fail(invalid_input, std::string(function) + ": " + e.what());
    } catch (const sd::CorruptData& e) {
        return fail(SD_ERR_CORRUPT_DATA, std::string(function) + ": " + e.what());
    } catch (const std::bad_alloc&) {
        return fail(SD_ERR_OUT_OF_MEMORY, std::string(function) + ": out of memory");
    } catch (const std::exception& e) {
        return fail(SD_ERR_INTERNAL, std::string(function) + ": internal error: " + e.what());
    } catch (...) {
        return fail(SD_ERR_INTERNAL, std::string(function) + ": unknown internal error");
    }
}

}  // namespace sd::abi

#define SD_REQUIRE(cond, message)                     \
    do {                                              \
        if (!(cond)) throw sd::InvalidInput(message); \
    } while (0)

namespace sd::abi {

/// Size query, then fill: *out_size = size (bytes); copies data into buffer unless buffer is
/// NULL; a buffer smaller than size is an error naming `what`. Inside guarded().
template <class Byte>
sd_status write_bytes(const Byte* data, size_t size, Byte* buffer, int64_t capacity, int64_t* out_size,
                      const char* what) {
    SD_REQUIRE(out_size, "out_size is NULL");
    *out_size = static_cast<int64_t>(size);
    if (!buffer) return SD_OK;
    if (capacity < static_cast<int64_t>(size))
        return fail(SD_ERR_INVALID_ARGUMENT, "buffer capacity " + std::to_string(capacity) + " is smaller than " +
                                                 what + " (" + std::to_string(size) + " bytes)");
    std::copy(data, data + size, buffer);
    return SD_OK;
}

/// write_bytes for a rig or binding blob.
inline sd_status write_blob(const std::vector<uint8_t>& blob, uint8_t* buffer, int64_t capacity, int64_t* out_size) {
    return write_bytes(blob.data(), blob.size(), buffer, capacity, out_size, "the blob");
}

/// The counts a frame's call gives, against the deformer's rig and binding.
inline sd_status check_frame_counts(const sd_deformer* d, int32_t bone_count, int32_t vertex_count) {
    if (bone_count != d->deformer->rig().skeleton.bone_count())
        return fail(SD_ERR_MISMATCH, "pose has " + std::to_string(bone_count) + " bones, the rig " +
                                         std::to_string(d->deformer->rig().skeleton.bone_count()));
    if (vertex_count != d->deformer->vertex_count())
        return fail(SD_ERR_MISMATCH, "vertex_count " + std::to_string(vertex_count) + " differs from the binding's " +
                                         std::to_string(d->deformer->vertex_count()));
    return SD_OK;
}

/// sd_deform_frame, its errors named after `function` (sd_deform_displaced is this without
/// a check or sums; abi/deform_frame.cpp).
sd_status deform_frame(const char* function, sd_deformer* d, int32_t bone_count, const float* pose,
                       int32_t vertex_count, int32_t moved_count, const int32_t* moved_vertices,
                       const float* displacements, float* out_positions, float* out_turned,
                       const sd_output_check* check, float ratio_limit, int32_t* out_beyond, float* out_worst_ratio,
                       int32_t* out_worst_vertex, int32_t* out_worst_bone, const float* rest, const float* base,
                       int32_t subtract_displacements, float* out_composed);

/// Every value of p[0..n) finite, or SD_ERR_INVALID_ARGUMENT naming the first that is not.
inline void require_finite(const float* p, size_t n, const char* what) {
    for (size_t i = 0; i < n; ++i)
        SD_REQUIRE(std::isfinite(p[i]), std::string(what) + " has a non-finite value at index " + std::to_string(i));
}

/// Every value of p[0..n) finite and within ±limit, or SD_ERR_INVALID_ARGUMENT naming the
/// first that is not. The pass compares bit patterns (for |x| they order as the values do, and
/// NaN and infinity lie above every finite one): integer compares, which vectorise.
inline void require_within(const float* p, size_t n, float limit, const char* what) {
    int32_t bound;
    std::memcpy(&bound, &limit, sizeof bound);
    int32_t beyond = 0;
    for (size_t i = 0; i < n; ++i) {
        int32_t bits;
        std::memcpy(&bits, p + i, sizeof bits);
        beyond |= static_cast<int32_t>((bits & 0x7fffffff) > bound);  // (a signed compare: SSE2 has it)
    }
    if (!beyond) return;
    for (size_t i = 0; i < n; ++i)
        SD_REQUIRE(std::isfinite(p[i]) && std::abs(p[i]) <= limit,
                   std::string(what) + " has a value not finite or beyond " + std::to_string(limit) + " at index " +
                       std::to_string(i));
}

/// The rig's sweep `sweep`; throws InvalidInput for a NULL rig or an index out of range.
inline const sd::Sweep& sweep_of(const sd_rig* rig, int32_t sweep) {
    SD_REQUIRE(rig, "rig is NULL");
    SD_REQUIRE(sweep >= 0 && sweep < static_cast<int32_t>(rig->rig.sweeps.size()),
               "sweep index " + std::to_string(sweep) + " is out of range");
    return rig->rig.sweeps[sweep];
}

}  // namespace sd::abi
