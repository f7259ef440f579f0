#include "sweepdeform_io/refine.h"

#include <cmath>
#include <memory>
#include <numeric>
#include <stdexcept>
#include <string>
#include <vector>

#include <opensubdiv/far/primvarRefiner.h>
#include <opensubdiv/far/topologyDescriptor.h>

#include "skeleton.h"

namespace sd::io {
namespace {

using namespace OpenSubdiv;

/// One vertex's primvar: `n` floats inside a flat array. PrimvarRefiner only needs
/// Clear() and AddWithWeight(), so one type serves positions (n = 3) and weights (n = #B).
class Row {
 public:
  Row(float* p, size_t n) : p_(p), n_(n) {}
  void Clear() { std::fill(p_, p_ + n_, 0.0f); }
  void AddWithWeight(const Row& src, float w) {
    for (size_t i = 0; i < n_; ++i) p_[i] += w * src.p_[i];
  }

 private:
  float* p_;
  size_t n_;
};

/// A flat #rows x n array seen as an array of Row, the container PrimvarRefiner indexes.
class Rows {
 public:
  Rows(std::vector<float>& data, size_t n) : data_(&data), n_(n) {}
  Row operator[](Far::Index i) const { return Row(data_->data() + static_cast<size_t>(i) * n_, n_); }

 private:
  std::vector<float>* data_;
  size_t n_;
};

/// Interpolates a #V x n primvar from the base mesh to the last refined level.
std::vector<float> refine_primvar(const Far::TopologyRefiner& refiner, std::vector<float> values, size_t n) {
  const Far::PrimvarRefiner primvar(refiner);
  for (int level = 1; level <= refiner.GetMaxLevel(); ++level) {
    std::vector<float> next(static_cast<size_t>(refiner.GetLevel(level).GetNumVertices()) * n);
    const Rows src(values, n);
    Rows dst(next, n);
    primvar.Interpolate(level, src, dst);
    values = std::move(next);
  }
  return values;
}

double distance(const std::vector<float>& p, Far::Index a, Far::Index b) {
  double d2 = 0.0;
  for (size_t k = 0; k < 3; ++k) {
    const double d = static_cast<double>(p[3 * static_cast<size_t>(a) + k]) - p[3 * static_cast<size_t>(b) + k];
    d2 += d * d;
  }
  return std::sqrt(d2);
}

}  // namespace

Character refine_catmull_clark(const Character& c, int levels) {
  if (levels < 0) throw std::invalid_argument("refine_catmull_clark: levels < 0");
  const std::string problems = validate(c);
  if (!problems.empty()) throw std::invalid_argument("refine_catmull_clark: invalid character:\n" + problems);
  if (levels == 0) return c;

  const size_t nv = c.positions.size() / 3;
  const size_t nb = c.bone_names.size();
  std::vector<int> verts_per_face(c.triangles.size() / 3, 3);
  Far::TopologyDescriptor desc;
  desc.numVertices = static_cast<int>(nv);
  desc.numFaces = static_cast<int>(verts_per_face.size());
  desc.numVertsPerFace = verts_per_face.data();
  desc.vertIndicesPerFace = c.triangles.data();
  Sdc::Options sdc;
  sdc.SetVtxBoundaryInterpolation(Sdc::Options::VTX_BOUNDARY_EDGE_ONLY);  // smooth open borders, like Blender
  using Factory = Far::TopologyRefinerFactory<Far::TopologyDescriptor>;
  const std::unique_ptr<Far::TopologyRefiner> refiner(
      Factory::Create(desc, Factory::Options(Sdc::SCHEME_CATMARK, sdc)));
  if (!refiner) throw std::runtime_error("refine_catmull_clark: OpenSubdiv rejected the mesh topology");
  refiner->RefineUniform(Far::TopologyRefiner::UniformOptions(levels));

  Character out;
  out.positions = refine_primvar(*refiner, c.positions, 3);

  // Dense per-bone weights (#V x #B): exact, and small enough for our rigs (80K x 53 floats).
  std::vector<float> dense(nv * nb, 0.0f);
  for (size_t v = 0; v < nv; ++v)
    for (size_t k = 0; k < 4; ++k)
      dense[v * nb + static_cast<size_t>(c.skin_joints[4 * v + k])] += c.skin_weights[4 * v + k];
  dense = refine_primvar(*refiner, std::move(dense), nb);
  const size_t out_nv = out.positions.size() / 3;
  out.skin_joints.resize(4 * out_nv);
  out.skin_weights.resize(4 * out_nv);
  std::vector<int32_t> bones(nb);
  std::iota(bones.begin(), bones.end(), 0);
  for (size_t v = 0; v < out_nv; ++v) {
    // Catmull-Clark masks are convex, so every refined vertex keeps a positive weight.
    if (!detail::top4_normalised(bones.data(), &dense[v * nb], static_cast<int>(nb), &out.skin_joints[4 * v],
                                 &out.skin_weights[4 * v]))
      throw std::runtime_error("refine_catmull_clark: a refined vertex lost all its weights");
  }

  // Refined faces are quads; split each along its shorter diagonal, keeping the orientation.
  const Far::TopologyLevel& last = refiner->GetLevel(levels);
  for (int f = 0; f < last.GetNumFaces(); ++f) {
    const Far::ConstIndexArray q = last.GetFaceVertices(f);
    if (q.size() != 4) throw std::runtime_error("refine_catmull_clark: refined face is not a quad");
    if (distance(out.positions, q[0], q[2]) <= distance(out.positions, q[1], q[3]))
      out.triangles.insert(out.triangles.end(), {q[0], q[1], q[2], q[0], q[2], q[3]});
    else
      out.triangles.insert(out.triangles.end(), {q[0], q[1], q[3], q[1], q[2], q[3]});
  }

  out.bone_names = c.bone_names;
  out.bone_parents = c.bone_parents;
  out.bone_rest = c.bone_rest;
  out.bone_heads = c.bone_heads;
  out.bone_tails = c.bone_tails;
  out.animations = c.animations;
  out.nodes = c.nodes;
  return out;
}

}  // namespace sd::io
