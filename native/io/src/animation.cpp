#include "sweepdeform_io/animation.h"

#include <algorithm>
#include <stdexcept>
#include <string>

#include "mat4.h"

namespace sd::io {
namespace {

/// Local transform of one node while posing.
struct LocalTRS {
  glm::dvec3 t{0.0}, s{1.0};
  glm::dquat r{1.0, 0.0, 0.0, 0.0};
  bool animated = false;
};

/// Key interval of time t: keys k0 and k1 = min(k0 + 1, last), fraction u in [0, 1]
/// (clamped outside the keys).
struct KeySpan {
  size_t k0 = 0, k1 = 0;
  double u = 0.0, dt = 0.0;
};

KeySpan locate(const std::vector<float>& times, double t) {
  KeySpan s;
  if (t <= times.front()) return s;
  if (t >= times.back()) {
    s.k0 = s.k1 = times.size() - 1;
    return s;
  }
  s.k1 = static_cast<size_t>(std::upper_bound(times.begin(), times.end(), t) - times.begin());
  s.k0 = s.k1 - 1;
  s.dt = static_cast<double>(times[s.k1]) - times[s.k0];  // > 0: times[k0] <= t < times[k1]
  s.u = (t - times[s.k0]) / s.dt;
  return s;
}

/// Channel value at t as 4 doubles (x, y, z[, w]), for n = 3 or 4 components.
glm::dvec4 sample_values(const Channel& ch, double t, int n) {
  const KeySpan s = locate(ch.times, t);
  const auto nc = static_cast<size_t>(n);
  const auto value = [&](size_t key, size_t slot, size_t stride) {
    glm::dvec4 v(0.0);
    for (size_t i = 0; i < nc; ++i) v[static_cast<glm::length_t>(i)] = ch.values[(key * stride + slot) * nc + i];
    return v;
  };
  switch (ch.interpolation) {
    case Channel::Interpolation::Step:
      return value(s.k0, 0, 1);
    case Channel::Interpolation::Linear: {
      const glm::dvec4 a = value(s.k0, 0, 1), b = value(s.k1, 0, 1);
      if (n == 4) {  // slerp along the shorter arc
        const glm::dquat q = glm::slerp(glm::dquat(a.w, a.x, a.y, a.z), glm::dquat(b.w, b.x, b.y, b.z), s.u);
        return {q.x, q.y, q.z, q.w};
      }
      return glm::mix(a, b, s.u);
    }
    case Channel::Interpolation::CubicSpline: {
      // Keys hold (in-tangent, value, out-tangent); tangents are scaled by the key spacing.
      const double u = s.u, u2 = u * u, u3 = u2 * u;
      const glm::dvec4 p0 = value(s.k0, 1, 3), m0 = value(s.k0, 2, 3) * s.dt;
      const glm::dvec4 p1 = value(s.k1, 1, 3), m1 = value(s.k1, 0, 3) * s.dt;
      const glm::dvec4 v =
          (2 * u3 - 3 * u2 + 1) * p0 + (u3 - 2 * u2 + u) * m0 + (-2 * u3 + 3 * u2) * p1 + (u3 - u2) * m1;
      return n == 4 ? glm::normalize(v) : v;
    }
  }
  return glm::dvec4(0.0);
}

}  // namespace

std::vector<float> sample_pose(const Character& c, int animation, double time_s) {
  if (animation < -1 || animation >= static_cast<int>(c.animations.size()))
    throw std::out_of_range("sample_pose: animation " + std::to_string(animation) + " of " +
                            std::to_string(c.animations.size()));
  const NodeTree& nodes = c.nodes;
  const size_t nn = nodes.parents.size();
  if (nodes.bone_node.size() != c.bone_names.size())
    throw std::invalid_argument("sample_pose: the character has no node tree for its bones");

  std::vector<LocalTRS> local(nn);
  if (animation >= 0) {
    for (const Channel& ch : c.animations[static_cast<size_t>(animation)].channels) {
      if (ch.times.empty()) continue;
      const auto n = static_cast<size_t>(ch.node);
      LocalTRS& l = local[n];
      if (!l.animated) {  // start from the rest values; channels override some of them
        l.t = {nodes.rest_translation[3 * n], nodes.rest_translation[3 * n + 1], nodes.rest_translation[3 * n + 2]};
        l.r = detail::load_quat(&nodes.rest_rotation[4 * n]);
        l.s = {nodes.rest_scale[3 * n], nodes.rest_scale[3 * n + 1], nodes.rest_scale[3 * n + 2]};
        l.animated = true;
      }
      switch (ch.path) {
        case Channel::Path::Translation:
          l.t = glm::dvec3(sample_values(ch, time_s, 3));
          break;
        case Channel::Path::Scale:
          l.s = glm::dvec3(sample_values(ch, time_s, 3));
          break;
        case Channel::Path::Rotation: {
          const glm::dvec4 q = sample_values(ch, time_s, 4);
          l.r = glm::dquat(q.w, q.x, q.y, q.z);
          break;
        }
      }
    }
  }

  // Parents come first, so one pass computes every global matrix.
  const glm::dmat4 root = detail::load_mat4(nodes.root_transform.data());
  std::vector<glm::dmat4> global(nn);
  for (size_t n = 0; n < nn; ++n) {
    const glm::dmat4 l = local[n].animated ? detail::trs_matrix(local[n].t, local[n].r, local[n].s)
                                           : detail::load_mat4(&nodes.rest_matrix[16 * n]);
    global[n] = (nodes.parents[n] < 0 ? root : global[static_cast<size_t>(nodes.parents[n])]) * l;
  }

  std::vector<float> pose(16 * nodes.bone_node.size());
  for (size_t b = 0; b < nodes.bone_node.size(); ++b)
    detail::store_mat4(global[static_cast<size_t>(nodes.bone_node[b])], &pose[16 * b]);
  return pose;
}

std::vector<float> rest_pose(const Character& c) { return c.bone_rest; }

}  // namespace sd::io
