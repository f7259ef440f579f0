#include <cmath>
#include <map>
#include <sstream>
#include <string>

#include "sweepdeform_io/character.h"

namespace sd::io {
namespace {

/// Collects problems, keeping the first few of each kind and counting the rest.
class Report {
 public:
  void add(const std::string& kind, const std::string& detail) {
    const int n = ++count_[kind];
    if (n <= 3)
      out_ << kind << ": " << detail << '\n';
    else if (n == 4)
      out_ << kind << ": (more problems of this kind)\n";
  }
  std::string str() const { return out_.str(); }

 private:
  std::map<std::string, int> count_;
  std::ostringstream out_;
};

bool all_finite(const std::vector<float>& v) {
  for (float x : v)
    if (!std::isfinite(x)) return false;
  return true;
}

bool size_is(Report& r, const char* name, size_t size, size_t expected) {
  if (size == expected) return true;
  r.add("size", std::string(name) + " has " + std::to_string(size) + " values, expected " + std::to_string(expected));
  return false;
}

void validate_nodes(const Character& c, size_t nb, Report& r) {
  const NodeTree& t = c.nodes;
  if (t.parents.empty() && t.bone_node.empty()) {
    if (!c.animations.empty()) r.add("nodes", "animations need a node tree, which is empty");
    return;  // a character built by hand may have no node tree (sample_pose then throws)
  }
  const size_t nn = t.parents.size();
  bool ok = size_is(r, "nodes.names", t.names.size(), nn);
  ok = size_is(r, "nodes.rest_translation", t.rest_translation.size(), 3 * nn) && ok;
  ok = size_is(r, "nodes.rest_rotation", t.rest_rotation.size(), 4 * nn) && ok;
  ok = size_is(r, "nodes.rest_scale", t.rest_scale.size(), 3 * nn) && ok;
  ok = size_is(r, "nodes.rest_matrix", t.rest_matrix.size(), 16 * nn) && ok;
  ok = size_is(r, "nodes.bone_node", t.bone_node.size(), nb) && ok;
  if (!ok) return;
  for (size_t n = 0; n < nn; ++n)
    if (t.parents[n] < -1 || t.parents[n] >= static_cast<int32_t>(n))
      r.add("nodes",
            "node " + std::to_string(n) + " has parent " + std::to_string(t.parents[n]) + " (parents must come first)");
  for (size_t b = 0; b < nb; ++b)
    if (t.bone_node[b] < 0 || static_cast<size_t>(t.bone_node[b]) >= nn)
      r.add("nodes", "bone " + std::to_string(b) + " has node " + std::to_string(t.bone_node[b]));
  if (!all_finite(t.rest_translation) || !all_finite(t.rest_rotation) || !all_finite(t.rest_scale) ||
      !all_finite(t.rest_matrix))
    r.add("finite", "node rest transforms have non-finite values");

  for (const Animation& a : c.animations) {
    for (const Channel& ch : a.channels) {
      const std::string where = "animation \"" + a.name + "\" node " + std::to_string(ch.node);
      if (ch.node < 0 || static_cast<size_t>(ch.node) >= nn) r.add("animation", where + " out of range");
      const size_t per_key = size_t{ch.path == Channel::Path::Rotation ? 4u : 3u} *
                             (ch.interpolation == Channel::Interpolation::CubicSpline ? 3u : 1u);
      if (ch.values.size() != per_key * ch.times.size()) r.add("animation", where + ": value count");
      for (size_t k = 0; k < ch.times.size(); ++k)
        if (!std::isfinite(ch.times[k]) || (k > 0 && ch.times[k] < ch.times[k - 1])) {
          r.add("animation", where + ": key times not finite and ascending");
          break;
        }
      if (!all_finite(ch.values)) r.add("finite", where + ": non-finite key values");
    }
  }
}

}  // namespace

std::string validate(const Character& c) {
  Report r;
  const size_t nv = c.positions.size() / 3;
  const size_t nb = c.bone_names.size();
  if (c.positions.size() % 3 != 0) r.add("size", "positions is not #V*3");
  if (c.triangles.size() % 3 != 0) r.add("size", "triangles is not #T*3");
  if (!all_finite(c.positions)) r.add("finite", "positions has non-finite values");
  for (size_t t = 0; t + 2 < c.triangles.size(); t += 3) {
    const int32_t a = c.triangles[t], b = c.triangles[t + 1], d = c.triangles[t + 2];
    const auto in = [&](int32_t i) { return i >= 0 && static_cast<size_t>(i) < nv; };
    if (!in(a) || !in(b) || !in(d))
      r.add("triangles", "triangle " + std::to_string(t / 3) + " index out of range");
    else if (a == b || b == d || d == a)
      r.add("triangles", "triangle " + std::to_string(t / 3) + " repeats a vertex");
  }

  bool bones_ok = size_is(r, "bone_parents", c.bone_parents.size(), nb);
  bones_ok = size_is(r, "bone_rest", c.bone_rest.size(), 16 * nb) && bones_ok;
  bones_ok = size_is(r, "bone_heads", c.bone_heads.size(), 3 * nb) && bones_ok;
  bones_ok = size_is(r, "bone_tails", c.bone_tails.size(), 3 * nb) && bones_ok;
  if (bones_ok) {
    if (!all_finite(c.bone_rest) || !all_finite(c.bone_heads) || !all_finite(c.bone_tails))
      r.add("finite", "bone matrices, heads or tails have non-finite values");
    for (size_t b = 0; b < nb; ++b) {
      const std::string bone = "bone " + std::to_string(b) + " \"" + c.bone_names[b] + "\"";
      if (c.bone_parents[b] < -1 || c.bone_parents[b] >= static_cast<int32_t>(b))
        r.add("bones", bone + " has parent " + std::to_string(c.bone_parents[b]) + " (parents must come first)");
      const float* m = &c.bone_rest[16 * b];
      const double det = m[0] * (m[5] * m[10] - m[9] * m[6]) - m[4] * (m[1] * m[10] - m[9] * m[2]) +
                         m[8] * (m[1] * m[6] - m[5] * m[2]);
      if (!(std::abs(det) > 1e-12) || m[3] != 0.0f || m[7] != 0.0f || m[11] != 0.0f || m[15] != 1.0f)
        r.add("bones", bone + " rest matrix is not an invertible affine matrix");
      double len2 = 0.0;
      for (size_t k = 0; k < 3; ++k) {
        const float h = c.bone_heads[3 * b + k];
        if (std::abs(h - m[12 + k]) > 1e-5f * (1.0f + std::abs(h)))
          r.add("bones", bone + " head differs from its rest translation");
        const double d = static_cast<double>(c.bone_tails[3 * b + k]) - h;
        len2 += d * d;
      }
      if (!(len2 > 0.0)) r.add("bones", bone + " has zero length (tail = head)");
    }
  }

  bool skin_ok = size_is(r, "skin_joints", c.skin_joints.size(), 4 * nv);
  skin_ok = size_is(r, "skin_weights", c.skin_weights.size(), 4 * nv) && skin_ok;
  if (skin_ok) {
    for (size_t v = 0; v < nv; ++v) {
      double sum = 0.0;
      bool ok = true;
      for (size_t k = 0; k < 4; ++k) {
        const int32_t j = c.skin_joints[4 * v + k];
        const float w = c.skin_weights[4 * v + k];
        ok = ok && j >= 0 && static_cast<size_t>(j) < nb && std::isfinite(w) && w >= 0.0f;
        sum += w;
      }
      if (!ok)
        r.add("skin", "vertex " + std::to_string(v) + " has a bone index out of range or a bad weight");
      else if (std::abs(sum - 1.0) > 1e-4)
        r.add("skin", "vertex " + std::to_string(v) + " weights sum to " + std::to_string(sum));
    }
  }

  validate_nodes(c, nb, r);
  return r.str();
}

}  // namespace sd::io
