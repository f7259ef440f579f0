#include "skeleton.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>
#include <vector>

#include <glm/glm.hpp>

namespace sd::io::detail {
namespace {

glm::dvec3 vec3_at(const std::vector<float>& v, size_t i) { return {v[3 * i], v[3 * i + 1], v[3 * i + 2]}; }

}  // namespace

void compute_bone_heads_tails(Character& c, double mesh_size) {
  const size_t nb = c.bone_parents.size();
  std::vector<glm::dvec3> head(nb), yaxis(nb), tail(nb);
  std::vector<std::vector<size_t>> children(nb);
  for (size_t b = 0; b < nb; ++b) {
    const float* m = &c.bone_rest[16 * b];
    head[b] = {m[12], m[13], m[14]};
    const glm::dvec3 y(m[4], m[5], m[6]);
    yaxis[b] = glm::length(y) > 0.0 ? glm::normalize(y) : glm::dvec3(0, 0, 1);
    if (c.bone_parents[b] >= 0) children[static_cast<size_t>(c.bone_parents[b])].push_back(b);
  }
  const double min_len = 1e-4 * mesh_size;

  // Rigs exported from Blender have each bone's local +Y along the bone (glTF keeps the bone
  // frames), so +Y gives the true direction of every bone, including leaves, hands and
  // Blender's floor-aligned root bones. Detect that convention.
  int one_child = 0, aligned = 0;
  for (size_t b = 0; b < nb; ++b) {
    if (children[b].size() != 1) continue;
    const glm::dvec3 d = head[children[b][0]] - head[b];
    if (glm::length(d) < min_len) continue;
    ++one_child;
    if (glm::dot(glm::normalize(d), yaxis[b]) > 0.99) ++aligned;
  }
  const bool y_along_bone = one_child > 0 && aligned >= 0.9 * one_child;

  for (size_t b = 0; b < nb; ++b) {  // parents first, so a parent's tail is known
    const auto& kids = children[b];
    const int32_t parent = c.bone_parents[b];
    bool found = false;
    if (y_along_bone) {
      // Keep Blender's bone direction exactly; reach the farthest child along it.
      double reach = 0.0;
      for (size_t k : kids) reach = std::max(reach, glm::dot(head[k] - head[b], yaxis[b]));
      tail[b] = head[b] + reach * yaxis[b];
      found = reach >= min_len;
    } else if (kids.size() == 1) {
      tail[b] = head[kids[0]];
      found = glm::length(tail[b] - head[b]) >= min_len;
    } else if (kids.size() > 1) {
      glm::dvec3 mean(0.0), farthest = head[b], continuing(0.0);
      bool has_continuing = false;
      double best_cos = 0.7;  // a child within ~45 degrees of the incoming direction
      const glm::dvec3 incoming = parent >= 0 ? head[b] - head[static_cast<size_t>(parent)] : glm::dvec3(0.0);
      for (size_t k : kids) {
        const glm::dvec3 d = head[k] - head[b];
        mean += head[k] / static_cast<double>(kids.size());
        if (glm::length(d) > glm::length(farthest - head[b])) farthest = head[k];
        if (glm::length(d) >= min_len && glm::length(incoming) >= min_len) {
          const double cos = glm::dot(glm::normalize(d), glm::normalize(incoming));
          if (cos > best_cos) {
            best_cos = cos;
            continuing = head[k];
            has_continuing = true;
          }
        }
      }
      const double far_dist = glm::length(farthest - head[b]);
      if (has_continuing)
        tail[b] = continuing;  // e.g. upper spine -> neck
      else if (glm::length(mean - head[b]) >= 0.25 * far_dist)
        tail[b] = mean;  // e.g. hand -> fingers
      else
        tail[b] = farthest;  // children on opposite sides, e.g. hips -> spine and legs
      found = far_dist >= min_len;
    }
    if (!found) {  // leaf, or children at the head: half the parent's length
      double len = 0.05 * mesh_size;
      glm::dvec3 dir = yaxis[b];
      if (parent >= 0) {
        const size_t pp = static_cast<size_t>(parent);
        len = 0.5 * glm::length(tail[pp] - head[pp]);
        const glm::dvec3 from_parent = head[b] - head[pp];
        if (!y_along_bone && glm::length(from_parent) >= min_len) dir = glm::normalize(from_parent);
      }
      tail[b] = head[b] + len * dir;
    }
    if (glm::length(tail[b] - head[b]) < min_len) tail[b] = head[b] + 0.01 * mesh_size * yaxis[b];
  }

  c.bone_heads.resize(3 * nb);
  c.bone_tails.resize(3 * nb);
  for (size_t b = 0; b < nb; ++b)
    for (int k = 0; k < 3; ++k) {
      c.bone_heads[3 * b + k] = static_cast<float>(head[b][k]);
      c.bone_tails[3 * b + k] = static_cast<float>(tail[b][k]);
    }
}

int32_t nearest_bone(const Character& c, const float* p) {
  const glm::dvec3 x(p[0], p[1], p[2]);
  int32_t best = 0;
  double best_d = std::numeric_limits<double>::infinity();
  for (size_t b = 0; b < c.bone_parents.size(); ++b) {
    const glm::dvec3 h = vec3_at(c.bone_heads, b), t = vec3_at(c.bone_tails, b);
    const glm::dvec3 ht = t - h;
    const double len2 = glm::dot(ht, ht);
    const double s = len2 > 0.0 ? std::clamp(glm::dot(x - h, ht) / len2, 0.0, 1.0) : 0.0;
    const double d = glm::length(x - (h + s * ht));
    if (d < best_d) {
      best_d = d;
      best = static_cast<int32_t>(b);
    }
  }
  return best;
}

bool top4_normalised(const int32_t* joints, const float* weights, int n, int32_t* out_joints, float* out_weights) {
  // Merge repeated joints first: some exporters split one bone's weight over two slots.
  std::vector<std::pair<int32_t, double>> merged;
  for (int i = 0; i < n; ++i) {
    if (!(weights[i] > 0.0f)) continue;
    auto it = std::find_if(merged.begin(), merged.end(), [&](const auto& jw) { return jw.first == joints[i]; });
    if (it == merged.end())
      merged.emplace_back(joints[i], weights[i]);
    else
      it->second += weights[i];
  }
  if (merged.empty()) return false;
  // Stable, so equal weights keep the file's order (deterministic output).
  std::stable_sort(merged.begin(), merged.end(), [](const auto& a, const auto& b) { return a.second > b.second; });
  merged.resize(std::min<size_t>(merged.size(), 4));
  double sum = 0.0;
  for (const auto& jw : merged) sum += jw.second;
  for (size_t i = 0; i < 4; ++i) {
    out_joints[i] = i < merged.size() ? merged[i].first : 0;
    out_weights[i] = i < merged.size() ? static_cast<float>(merged[i].second / sum) : 0.0f;
  }
  return true;
}

}  // namespace sd::io::detail
