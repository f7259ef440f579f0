// The C ABI's "library" block (sweepdeform.h): versions and the thread-local message.
#include "sweepdeform/sweepdeform.h"

#include "abi/guard.h"

extern "C" {

int32_t sd_abi_version(void) { return SD_ABI_VERSION; }
const char* sd_library_version(void) { return SWEEPDEFORM_VERSION; }
const char* sd_last_error(void) { return sd::abi::last_error().c_str(); }

}  // extern "C"
