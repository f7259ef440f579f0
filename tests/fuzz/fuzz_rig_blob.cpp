// Loading a rig blob (untrusted: it comes from a .blend file). A blob that loads must write
// back a blob that loads to the same rig: serialise(load(x)) is a fixed point. (x itself may
// be an older format version, which loading upgrades.)
#include "fuzz_fixture.h"

static std::vector<uint8_t> blob_of(const sd_rig* rig) {
    int64_t n = 0;
    if (sd_rig_serialize(rig, nullptr, 0, &n) != SD_OK) __builtin_trap();
    std::vector<uint8_t> out(static_cast<size_t>(n));
    if (sd_rig_serialize(rig, out.data(), n, &n) != SD_OK) __builtin_trap();
    return out;
}

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    sd_rig* rig = nullptr;
    if (sd_rig_deserialize(data, static_cast<int64_t>(size), &rig) != SD_OK) return 0;
    const std::vector<uint8_t> once = blob_of(rig);
    sd_rig* again = nullptr;
    if (sd_rig_deserialize(once.data(), static_cast<int64_t>(once.size()), &again) != SD_OK) __builtin_trap();
    if (blob_of(again) != once) __builtin_trap();
    sd_rig_destroy(again);
    sd_rig_destroy(rig);
    return 0;
}
