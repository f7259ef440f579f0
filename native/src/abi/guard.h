// Shared by the C ABI's translation units: status mapping, the thread-local message and the
// exception barrier. Internal; not installed.
#pragma once

#include "sweepdeform/sweepdeform.h"

#include "bind/bind.h"
#include "deform/deform.h"
#include "math/math_types.h"
#include "rig/rig.h"

#include <memory>

#include <new>
#include <string>

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

#define SD_REQUIRE(cond, message) \
    do { \
        if (!(cond)) throw sd::InvalidInput(message); \
    } while (0)
