// Loading a rig blob (untrusted: it comes from a .blend file). A blob that loads must
// serialise back to the same bytes.
#include "fuzz_fixture.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    sd_rig* rig = nullptr;
    if (sd_rig_deserialize(data, static_cast<int64_t>(size), &rig) != SD_OK) return 0;
    int64_t n = 0;
    if (sd_rig_serialize(rig, nullptr, 0, &n) != SD_OK) __builtin_trap();
    std::vector<uint8_t> again(static_cast<size_t>(n));
    if (sd_rig_serialize(rig, again.data(), n, &n) != SD_OK) __builtin_trap();
    if (again.size() != size || std::memcmp(again.data(), data, size) != 0) __builtin_trap();
    sd_rig_destroy(rig);
    return 0;
}
