#include "weld.h"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <unordered_map>

namespace sd::io::detail {
namespace {

int32_t find_root(std::vector<int32_t>& parent, int32_t i) {
  while (parent[static_cast<size_t>(i)] != i) {
    auto& p = parent[static_cast<size_t>(i)];
    p = parent[static_cast<size_t>(p)];  // path halving
    i = p;
  }
  return i;
}

/// The grid cell of a coordinate, floor(x / cell), clamped to ±2^62 and 0 for a NaN, so that
/// the conversion is defined for any float: a glTF vertex at -8e24 with a cell of a micrometre
/// was undefined behaviour (found by fuzz_gltf). Clamped points share a cell; the exact
/// distance test below still decides.
int64_t cell_of(double x, double cell) {
  const double c = std::floor(x / cell);
  if (!(c == c)) return 0;
  return static_cast<int64_t>(std::clamp(c, -0x1p62, 0x1p62));
}

}  // namespace

std::vector<int32_t> weld_map(const std::vector<float>& positions, double tolerance) {
  const size_t nv = positions.size() / 3;
  std::vector<int32_t> parent(nv);
  std::iota(parent.begin(), parent.end(), 0);
  if (!(tolerance > 0.0)) tolerance = 0.0;

  // Hash grid with cells of size `tolerance`: close vertices are in the same or adjacent cells.
  const double cell = tolerance > 0.0 ? tolerance : 1.0;
  auto key = [](int64_t x, int64_t y, int64_t z) {
    return static_cast<uint64_t>(x) * 73856093ULL ^ static_cast<uint64_t>(y) * 19349663ULL ^
           static_cast<uint64_t>(z) * 83492791ULL;
  };
  std::unordered_multimap<uint64_t, int32_t> grid;
  grid.reserve(nv);
  const double tol2 = tolerance * tolerance;
  for (size_t i = 0; i < nv; ++i) {
    const float* p = &positions[3 * i];
    const int64_t cx = cell_of(p[0], cell), cy = cell_of(p[1], cell), cz = cell_of(p[2], cell);
    for (int64_t dx = -1; dx <= 1; ++dx)
      for (int64_t dy = -1; dy <= 1; ++dy)
        for (int64_t dz = -1; dz <= 1; ++dz) {
          auto range = grid.equal_range(key(cx + dx, cy + dy, cz + dz));
          for (auto it = range.first; it != range.second; ++it) {
            const float* q = &positions[3 * static_cast<size_t>(it->second)];
            const double ex = p[0] - q[0], ey = p[1] - q[1], ez = p[2] - q[2];
            // Also filters hash collisions, and never welds a NaN (validate() refuses it later).
            if (!(ex * ex + ey * ey + ez * ez <= tol2)) continue;
            const int32_t a = find_root(parent, static_cast<int32_t>(i));
            const int32_t b = find_root(parent, it->second);
            if (a != b) parent[static_cast<size_t>(std::max(a, b))] = std::min(a, b);
          }
        }
    grid.emplace(key(cx, cy, cz), static_cast<int32_t>(i));
  }

  // Roots are the lowest index of their group, so numbering roots in index order works.
  std::vector<int32_t> new_index(nv, -1);
  int32_t next = 0;
  for (size_t i = 0; i < nv; ++i) {
    const auto r = static_cast<size_t>(find_root(parent, static_cast<int32_t>(i)));
    if (new_index[r] < 0) new_index[r] = next++;
    new_index[i] = new_index[r];
  }
  return new_index;
}

}  // namespace sd::io::detail
