// Denormals flushed while the core computes a frame (math/flush_denormals.h), and every
// thread's own floating-point mode back afterwards: Blender's threads run the same workers.
#include "math/flush_denormals.h"

#include "deform/deform.h"
#include "test_arm.h"

#include <gtest/gtest.h>
#include <tbb/parallel_for.h>

#include <atomic>
#include <cfloat>
#include <vector>

#if defined(__SSE2__) || defined(_M_X64)
#include <xmmintrin.h>

namespace sd {
namespace {

constexpr unsigned kFlushBits = 0x8040;  // flush to zero, denormals are zero

float product(float a, float b) {
    volatile float x = a, y = b;  // computed at run time, in the thread's mode
    return x * y;
}

TEST(FlushDenormals, InsideDenormalsAreZeroAndAfterwardsTheModeIsTheThreads) {
    ASSERT_EQ(_mm_getcsr() & kFlushBits, 0u) << "the test thread starts with denormals on";
    EXPECT_GT(product(FLT_MIN, 0.25f), 0.0f);  // a denormal result, as IEEE 754 gives it
    {
        const FlushDenormals flush;
        EXPECT_EQ(product(FLT_MIN, 0.25f), 0.0f);         // a denormal result: flushed to zero
        EXPECT_EQ(product(FLT_TRUE_MIN, 1.0e30f), 0.0f);  // a denormal operand: read as zero
    }
    EXPECT_EQ(_mm_getcsr() & kFlushBits, 0u);
    EXPECT_GT(product(FLT_MIN, 0.25f), 0.0f);
}

TEST(FlushDenormals, AFrameLeavesEveryThreadsModeAsItWas) {
    const test::Arm arm(0.1, 0.07, 49, 32);
    Deformer d(arm.rig, arm.bind());
    std::vector<float> out(arm.mesh.size());
    const unsigned before = _mm_getcsr();
    for (int i = 0; i < 20; ++i) d.deform(arm.pose(0.05 * i, 0.3).data(), out.data());
    constexpr unsigned kStatusFlags = 0x3F;  // raised by the arithmetic itself, not a mode
    EXPECT_EQ(_mm_getcsr() & ~kStatusFlags, before & ~kStatusFlags);
    // The worker threads that ran the kernel's loops: none keeps the flush bits.
    std::atomic<int> flushing{0};
    tbb::parallel_for(0, 10000, [&](int) {
        if (_mm_getcsr() & kFlushBits) ++flushing;
    });
    EXPECT_EQ(flushing.load(), 0);
}

}  // namespace
}  // namespace sd
#endif
