// sd_measure_intersections, whose query culls patches by their normal cone and outline
// (geometry/patch_outline.h), against its own answer for every pair alone (two triangles are
// never culled as one patch unless they share an edge, and then they share vertices): the
// count over the set must be the sum over its pairs. Meshes are a soup, or a sheet of quads
// whose every vertex the fuzzer places (folds, ramps over themselves, flat and coplanar runs).
#include "fuzz_fixture.h"

#include <vector>

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    sdfuzz::Bytes in(data, size);
    std::vector<float> p;
    std::vector<int32_t> t;
    if (in.take<uint8_t>() & 1) {  // a soup: up to 24 points on a coarse grid, 20 triangles
        const int N = 3 + in.take<uint8_t>() % 22, F = 1 + in.take<uint8_t>() % 20;
        for (int i = 0; i < 3 * N; ++i) p.push_back(static_cast<float>(in.take<int8_t>() % 8) / 4.0f);
        for (int i = 0; i < 3 * F; ++i) t.push_back(in.take<uint8_t>() % N);
    } else {  // a sheet of up to 6 x 4 quads: grid positions moved by the fuzzer
        const int W = 1 + in.take<uint8_t>() % 6, H = 1 + in.take<uint8_t>() % 4;
        for (int j = 0; j <= H; ++j)
            for (int i = 0; i <= W; ++i) {
                p.push_back(static_cast<float>(i) + in.take<int8_t>() / 32.0f);
                p.push_back(static_cast<float>(j) + in.take<int8_t>() / 32.0f);
                p.push_back(in.take<int8_t>() / 16.0f);
            }
        const auto id = [&](int i, int j) { return j * (W + 1) + i; };
        for (int j = 0; j < H; ++j)
            for (int i = 0; i < W; ++i) {
                t.insert(t.end(), {id(i, j), id(i + 1, j), id(i + 1, j + 1)});
                t.insert(t.end(), {id(i, j), id(i + 1, j + 1), id(i, j + 1)});
            }
    }
    const int32_t V = static_cast<int32_t>(p.size() / 3), T = static_cast<int32_t>(t.size() / 3);
    int64_t all = -1;
    if (sd_measure_intersections(V, p.data(), T, t.data(), 0, nullptr, &all) != SD_OK) __builtin_trap();
    int64_t sum = 0;
    for (int32_t a = 0; a < T; ++a)
        for (int32_t b = a + 1; b < T; ++b) {
            const int32_t pair[2] = {a, b};
            int64_t one = -1;
            if (sd_measure_intersections(V, p.data(), T, t.data(), 2, pair, &one) != SD_OK) __builtin_trap();
            sum += one;
        }
    if (all != sum) __builtin_trap();
    return 0;
}
