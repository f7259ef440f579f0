// The kernel's per-slot arrays in one buffer (deform/slot_planes.h): each plane starts a
// sixteenth of a page further into a page than the one before, wherever the allocator put
// the buffer, and keeps its contents when moved.
#include "deform/slot_planes.h"

#include <gtest/gtest.h>

#include <cstdint>
#include <set>
#include <utility>

namespace {

size_t offset_into_page(const float* p) {
    return reinterpret_cast<std::uintptr_t>(p) % (sd::SlotPlanes::kPageFloats * sizeof(float));
}

}  // namespace

TEST(SlotPlanes, EachPlaneStartsAtItsOwnSixteenthOfAPage) {
    for (size_t n : {1u, 1000u, 1024u, 80270u}) {
        sd::SlotPlanes planes;
        planes.resize(std::vector<size_t>(16, n));
        std::set<size_t> offsets;
        for (int p = 0; p < 16; ++p) {
            EXPECT_EQ(offset_into_page(planes[p]), p * sd::SlotPlanes::kStaggerFloats * sizeof(float)) << n;
            offsets.insert(offset_into_page(planes[p]));
            EXPECT_EQ(planes.size(p), n);
        }
        EXPECT_EQ(offsets.size(), 16u);
    }
}

TEST(SlotPlanes, PlanesAreZeroedAndDoNotOverlap) {
    sd::SlotPlanes planes;
    planes.resize({3000, 5, 4 * 3000, 8 * 3000});
    for (int p = 0; p < 4; ++p)
        for (size_t i = 0; i < planes.size(p); ++i) {
            EXPECT_EQ(planes[p][i], 0.0f);
            planes[p][i] = static_cast<float>(p + 1);
        }
    for (int p = 0; p < 4; ++p)
        for (size_t i = 0; i < planes.size(p); ++i) ASSERT_EQ(planes[p][i], static_cast<float>(p + 1));
}

TEST(SlotPlanes, AMoveKeepsTheContents) {
    sd::SlotPlanes planes;
    planes.resize({100, 200});
    for (size_t i = 0; i < 200; ++i) planes[1][i] = static_cast<float>(i);
    const sd::SlotPlanes moved = std::move(planes);
    for (size_t i = 0; i < 200; ++i) ASSERT_EQ(moved[1][i], static_cast<float>(i));
    EXPECT_EQ(offset_into_page(moved[1]), sd::SlotPlanes::kStaggerFloats * sizeof(float));
}
