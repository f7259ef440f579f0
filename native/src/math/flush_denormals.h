// Denormal floats flushed to zero while the core computes a frame.
//
// Blender's pose matrices and the products of small weights, quaternion parts and half-axis
// changes give the kernel denormal operands now and then; on x86 each one costs a microcode
// assist of about a hundred cycles. MakeHuman's 53.5K body, posed in Blender 4.3: 1.63 ms a
// frame in the core, 0.39 ms with denormals flushed (the same body outside Blender, whose
// poses gave none: 0.37 ms). A denormal is below 1.2e-38: flushing it moves no vertex by
// anything a float can show at a body's scale.
//
// The mode is a thread's own (MXCSR), so each parallel loop of a frame sets it in its body,
// for the worker thread running it, and puts the thread's own mode back after: the workers
// are shared with Blender, whose arithmetic must not change.
#pragma once

#if defined(__SSE2__) || defined(_M_X64)
#include <xmmintrin.h>
#endif

namespace sd {

class FlushDenormals {
public:
#if defined(__SSE2__) || defined(_M_X64)
    FlushDenormals() : saved_(_mm_getcsr()) { _mm_setcsr(saved_ | kFlushToZero | kDenormalsAreZero); }
    ~FlushDenormals() { _mm_setcsr(saved_); }

private:
    static constexpr unsigned kFlushToZero = 0x8000, kDenormalsAreZero = 0x0040;
    unsigned saved_;
#else
    FlushDenormals() = default;  // elsewhere the thread's own mode is kept
#endif

public:
    FlushDenormals(const FlushDenormals&) = delete;
    FlushDenormals& operator=(const FlushDenormals&) = delete;
};

}  // namespace sd
