#include "deform/slot_planes.h"

namespace sd {

void SlotPlanes::resize(const std::vector<size_t>& sizes) {
    sizes_ = sizes;
    offsets_.resize(sizes.size());
    size_t end = 0;
    for (size_t p = 0; p < sizes.size(); ++p) {
        // The next page boundary, then this plane's sixteenth of a page into it.
        const size_t page = (end + kPageFloats - 1) / kPageFloats * kPageFloats;
        offsets_[p] = page + (p % 16) * kStaggerFloats;
        end = offsets_[p] + sizes[p];
    }
    storage_.assign(end + kPageFloats, 0.0f);  // room to start at a page boundary
}

}  // namespace sd
