// Private: merging coincident vertices.
#pragma once

#include <cstdint>
#include <vector>

namespace sd::io::detail {

/// Groups vertices closer than `tolerance` (transitively) and numbers the groups in the order
/// of their lowest vertex index.
/// positions: #V*3. Returns #V: the new index of each vertex.
/// The representative of group g is the lowest old index i with result[i] == g.
std::vector<int32_t> weld_map(const std::vector<float>& positions, double tolerance);

}  // namespace sd::io::detail
