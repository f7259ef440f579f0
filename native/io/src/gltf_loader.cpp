#include "sweepdeform_io/gltf_loader.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <fstream>
#include <iterator>
#include <limits>
#include <numeric>
#include <stdexcept>
#include <string>
#include <vector>

#include <tiny_gltf.h>

#include "mat4.h"
#include "skeleton.h"
#include "weld.h"

namespace sd::io {
namespace {

using detail::load_quat;
using detail::trs_matrix;

[[noreturn]] void fail(const std::string& message) { throw std::runtime_error(message); }

// ----------------------------------------------------------------------------------------------
// Accessors

/// Where an accessor's elements are. data == nullptr: no buffer view, all zeros (glTF rule).
struct AccessorData {
  const unsigned char* data = nullptr;
  size_t stride = 0;
  size_t count = 0;
  int components = 0;
  int component_type = 0;
  bool normalized = false;
};

AccessorData accessor_data(const tinygltf::Model& m, int index, int expected_type, const std::string& what) {
  if (index < 0 || static_cast<size_t>(index) >= m.accessors.size())
    fail(what + ": accessor " + std::to_string(index) + " does not exist");
  const tinygltf::Accessor& acc = m.accessors[static_cast<size_t>(index)];
  if (acc.type != expected_type) fail(what + ": unexpected accessor type");
  if (acc.sparse.isSparse) fail(what + ": sparse accessors are not supported");
  AccessorData d;
  d.count = acc.count;
  d.components = tinygltf::GetNumComponentsInType(static_cast<uint32_t>(acc.type));
  d.component_type = acc.componentType;
  d.normalized = acc.normalized;
  const int component_size = tinygltf::GetComponentSizeInBytes(static_cast<uint32_t>(acc.componentType));
  if (d.components <= 0 || component_size <= 0) fail(what + ": invalid accessor component type");
  if (acc.bufferView < 0) {
    // No data: all zeros (sparse accessors, which could fill them, are refused above). Its
    // count is not bounded by any buffer, so bound it by the bytes the file's buffers hold
    // (plus a few KB for files with none) before allocating: a count of 4e9 would ask for
    // tens of GB.
    size_t bytes = 4096;
    for (const tinygltf::Buffer& b : m.buffers) bytes += b.data.size();
    if (d.count > bytes)
      fail(what + ": accessor " + std::to_string(index) + " without data claims " + std::to_string(d.count) +
           " elements, more than the file's buffers have bytes (" + std::to_string(bytes - 4096) + ")");
    return d;
  }
  if (static_cast<size_t>(acc.bufferView) >= m.bufferViews.size())
    fail(what + ": buffer view " + std::to_string(acc.bufferView) + " does not exist");
  const tinygltf::BufferView& view = m.bufferViews[static_cast<size_t>(acc.bufferView)];
  if (view.buffer < 0 || static_cast<size_t>(view.buffer) >= m.buffers.size())
    fail(what + ": buffer " + std::to_string(view.buffer) + " does not exist");
  const tinygltf::Buffer& buffer = m.buffers[static_cast<size_t>(view.buffer)];
  const int stride = acc.ByteStride(view);
  if (stride <= 0) fail(what + ": invalid byte stride");
  d.stride = static_cast<size_t>(stride);
  // Each step compared before it is added, so that offsets and counts near 2^64 cannot wrap.
  const size_t element = static_cast<size_t>(d.components) * static_cast<size_t>(component_size);
  const size_t size = buffer.data.size();
  const bool inside = view.byteOffset <= size && view.byteLength <= size - view.byteOffset &&
                      acc.byteOffset <= view.byteLength &&
                      (d.count == 0 || (element <= view.byteLength - acc.byteOffset &&
                                        d.count - 1 <= (view.byteLength - acc.byteOffset - element) / d.stride));
  if (!inside) fail(what + ": accessor data lies outside its buffer");
  const size_t begin = view.byteOffset + acc.byteOffset;
  d.data = buffer.data.data() + begin;
  return d;
}

/// A value of type T at p. memcpy because glTF only guarantees alignment to the component size
/// within a buffer.
template <class T>
T load(const unsigned char* p) {
  T v;
  std::memcpy(&v, p, sizeof v);
  return v;
}

/// One component as a number, normalized integers mapped to [0, 1] / [-1, 1] (glTF rules).
double read_component(const unsigned char* p, int type, bool normalized) {
  switch (type) {
    case TINYGLTF_COMPONENT_TYPE_FLOAT:
      return load<float>(p);
    case TINYGLTF_COMPONENT_TYPE_DOUBLE:
      return load<double>(p);
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE:
      return normalized ? p[0] / 255.0 : p[0];
    case TINYGLTF_COMPONENT_TYPE_BYTE:
      return normalized ? std::max(load<int8_t>(p) / 127.0, -1.0) : load<int8_t>(p);
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT:
      return normalized ? load<uint16_t>(p) / 65535.0 : load<uint16_t>(p);
    case TINYGLTF_COMPONENT_TYPE_SHORT:
      return normalized ? std::max(load<int16_t>(p) / 32767.0, -1.0) : load<int16_t>(p);
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT:
      return load<uint32_t>(p);
    default:
      fail("unsupported accessor component type " + std::to_string(type));
  }
}

/// All elements of an accessor as floats: count * components values.
std::vector<float> read_floats(const tinygltf::Model& m, int index, int expected_type, const std::string& what) {
  const AccessorData d = accessor_data(m, index, expected_type, what);
  const auto nc = static_cast<size_t>(d.components);
  std::vector<float> out(d.count * nc, 0.0f);
  if (d.data == nullptr) return out;
  const size_t component_size =
      static_cast<size_t>(tinygltf::GetComponentSizeInBytes(static_cast<uint32_t>(d.component_type)));
  for (size_t i = 0; i < d.count; ++i)
    for (size_t k = 0; k < nc; ++k)
      out[i * nc + k] = static_cast<float>(
          read_component(d.data + i * d.stride + k * component_size, d.component_type, d.normalized));
  return out;
}

/// All elements of an unsigned-integer accessor (indices, joints).
std::vector<uint32_t> read_uints(const tinygltf::Model& m, int index, int expected_type, const std::string& what) {
  const AccessorData d = accessor_data(m, index, expected_type, what);
  if ((d.component_type != TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE &&
       d.component_type != TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT &&
       d.component_type != TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT) ||
      d.normalized)
    fail(what + ": expected unsigned integers (u8, u16 or u32)");
  const auto nc = static_cast<size_t>(d.components);
  std::vector<uint32_t> out(d.count * nc, 0u);
  if (d.data == nullptr) return out;
  const size_t component_size =
      static_cast<size_t>(tinygltf::GetComponentSizeInBytes(static_cast<uint32_t>(d.component_type)));
  for (size_t i = 0; i < d.count; ++i)
    for (size_t k = 0; k < nc; ++k)
      out[i * nc + k] =
          static_cast<uint32_t>(read_component(d.data + i * d.stride + k * component_size, d.component_type, false));
  return out;
}

// ----------------------------------------------------------------------------------------------
// File node hierarchy

struct FileNodes {
  std::vector<int> parent;         // per file node, -1 for a root
  std::vector<glm::dmat4> local;   // rest local matrices
  std::vector<glm::dmat4> global;  // rest global matrices (file world space)
  std::vector<size_t> order;       // parents before children (depth first, file order)
};

glm::dmat4 node_local_matrix(const tinygltf::Node& n) {
  if (n.matrix.size() == 16) {
    glm::dmat4 m;
    for (int c = 0; c < 4; ++c)
      for (int k = 0; k < 4; ++k) m[c][k] = n.matrix[4 * static_cast<size_t>(c) + static_cast<size_t>(k)];
    return m;
  }
  glm::dvec3 t(0.0), s(1.0);
  glm::dquat r(1.0, 0.0, 0.0, 0.0);
  if (n.translation.size() == 3) t = {n.translation[0], n.translation[1], n.translation[2]};
  if (n.rotation.size() == 4) r = glm::dquat(n.rotation[3], n.rotation[0], n.rotation[1], n.rotation[2]);
  if (n.scale.size() == 3) s = {n.scale[0], n.scale[1], n.scale[2]};
  return trs_matrix(t, r, s);
}

FileNodes file_nodes(const tinygltf::Model& m) {
  const size_t nn = m.nodes.size();
  FileNodes f;
  f.parent.assign(nn, -1);
  for (size_t i = 0; i < nn; ++i)
    for (int child : m.nodes[i].children) {
      if (child < 0 || static_cast<size_t>(child) >= nn) fail("node child index out of range");
      if (f.parent[static_cast<size_t>(child)] >= 0) fail("node " + std::to_string(child) + " has two parents");
      f.parent[static_cast<size_t>(child)] = static_cast<int>(i);
    }
  f.local.resize(nn);
  f.global.resize(nn);
  for (size_t i = 0; i < nn; ++i) f.local[i] = node_local_matrix(m.nodes[i]);
  // Depth-first from the roots; nodes never reached are on a cycle.
  std::vector<size_t> stack;
  for (size_t i = nn; i-- > 0;)
    if (f.parent[i] < 0) stack.push_back(i);
  while (!stack.empty()) {
    const size_t i = stack.back();
    stack.pop_back();
    f.order.push_back(i);
    f.global[i] = f.parent[i] < 0 ? f.local[i] : f.global[static_cast<size_t>(f.parent[i])] * f.local[i];
    const auto& kids = m.nodes[i].children;
    for (auto it = kids.rbegin(); it != kids.rend(); ++it) stack.push_back(static_cast<size_t>(*it));
  }
  if (f.order.size() != nn) fail("the node hierarchy has a cycle");
  return f;
}

// ----------------------------------------------------------------------------------------------
// Loading steps

/// Parses a .glb or .gltf held in memory. base_dir: where external buffers of a .gltf are
/// looked for; nullptr: external files are refused (loading from memory).
tinygltf::Model read_model(const unsigned char* bytes, size_t size, const std::string* base_dir) {
  tinygltf::TinyGLTF loader;
  // We never need pixels: accept every image without decoding it (no stb_image).
  loader.SetImageLoader([](tinygltf::Image*, const int, std::string*, std::string*, int, int, const unsigned char*, int,
                           void*) { return true; },
                        nullptr);
  if (base_dir == nullptr) {
    tinygltf::FsCallbacks no_files{};
    // "Exists", so that TinyGLTF asks to read it and the refusal below is the message.
    no_files.FileExists = [](const std::string&, void*) { return true; };
    no_files.ExpandFilePath = [](const std::string& p, void*) { return p; };
    no_files.ReadWholeFile = [](std::vector<unsigned char>*, std::string* err, const std::string& p, void*) {
      if (err) *err += "external file '" + p + "' not read: only embedded buffers when loading from memory\n";
      return false;
    };
    no_files.WriteWholeFile = [](std::string*, const std::string&, const std::vector<unsigned char>&, void*) {
      return false;
    };
    loader.SetFsCallbacks(no_files);
  }
  tinygltf::Model model;
  std::string err, warn;
  const bool binary = size >= 4 && std::memcmp(bytes, "glTF", 4) == 0;
  if (size > std::numeric_limits<unsigned int>::max()) fail("4 GB or larger (TinyGLTF reads up to 4 GB)");
  const std::string dir = base_dir ? *base_dir : std::string();
  const bool ok = binary ? loader.LoadBinaryFromMemory(&model, &err, &warn, bytes, static_cast<unsigned int>(size), dir)
                         : loader.LoadASCIIFromString(&model, &err, &warn, reinterpret_cast<const char*>(bytes),
                                                      static_cast<unsigned int>(size), dir);
  if (!ok) fail("TinyGLTF could not parse it: " + err);
  for (const std::string& ext : model.extensionsRequired)
    if (ext == "KHR_draco_mesh_compression" || ext == "EXT_meshopt_compression")
      fail("compressed geometry (" + ext + ") is not supported");
  return model;
}

tinygltf::Model read_model(const std::string& path) {
  std::ifstream file(path, std::ios::binary);
  if (!file) fail("cannot open the file");
  std::vector<unsigned char> bytes((std::istreambuf_iterator<char>(file)), std::istreambuf_iterator<char>());
  if (file.bad() || bytes.empty()) fail("cannot read the file, or it is empty");
  const size_t slash = path.find_last_of("/\\");
  const std::string dir = slash == std::string::npos ? std::string() : path.substr(0, slash);
  return read_model(bytes.data(), bytes.size(), &dir);
}

/// The skin used by skinned mesh nodes, and the meshes (each once) using it.
int find_skin(const tinygltf::Model& m, std::vector<int>& meshes) {
  int skin = -1;
  for (const tinygltf::Node& n : m.nodes) {
    if (n.mesh < 0 || n.skin < 0) continue;
    if (skin >= 0 && n.skin != skin) fail("several skins are used: expected one skinned mesh");
    skin = n.skin;
    if (std::find(meshes.begin(), meshes.end(), n.mesh) == meshes.end()) meshes.push_back(n.mesh);
  }
  if (skin < 0) fail("no skinned mesh (no node has both a mesh and a skin)");
  if (static_cast<size_t>(skin) >= m.skins.size()) fail("skin index out of range");
  for (int mesh : meshes)
    if (static_cast<size_t>(mesh) >= m.meshes.size()) fail("mesh index out of range");
  return skin;
}

/// Skin joints reordered so that parents come first. Returns bone -> skin joint index and
/// fills joint_parent (skin joint -> parent skin joint, -1).
std::vector<size_t> order_joints(const tinygltf::Skin& skin, const FileNodes& f, std::vector<int>& joint_parent) {
  const size_t nj = skin.joints.size();
  std::vector<int> joint_of_node(f.parent.size(), -1);
  for (size_t j = 0; j < nj; ++j) {
    const int node = skin.joints[j];
    if (node < 0 || static_cast<size_t>(node) >= f.parent.size()) fail("skin joint node out of range");
    if (joint_of_node[static_cast<size_t>(node)] >= 0) fail("a node is listed twice in the skin");
    joint_of_node[static_cast<size_t>(node)] = static_cast<int>(j);
  }
  joint_parent.assign(nj, -1);
  bool sorted = true;
  for (size_t j = 0; j < nj; ++j) {
    int a = f.parent[static_cast<size_t>(skin.joints[j])];
    while (a >= 0 && joint_of_node[static_cast<size_t>(a)] < 0) a = f.parent[static_cast<size_t>(a)];
    joint_parent[j] = a < 0 ? -1 : joint_of_node[static_cast<size_t>(a)];
    sorted = sorted && joint_parent[j] < static_cast<int>(j);
  }
  std::vector<size_t> order(nj);
  std::iota(order.begin(), order.end(), size_t{0});
  if (sorted) return order;
  // Otherwise: the file's node order is depth first, parents first; keep joints in it.
  order.clear();
  for (size_t node : f.order)
    if (joint_of_node[node] >= 0) order.push_back(static_cast<size_t>(joint_of_node[node]));
  return order;
}

/// The joint nodes and their ancestors, parents first, as a NodeTree (without root_transform).
/// file_to_tree receives each file node's index in the tree (-1 when not kept).
NodeTree build_node_tree(const tinygltf::Model& m, const FileNodes& f, const std::vector<int>& bone_file_nodes,
                         std::vector<int>& file_to_tree) {
  std::vector<bool> keep(m.nodes.size(), false);
  for (int node : bone_file_nodes)
    for (int a = node; a >= 0 && !keep[static_cast<size_t>(a)]; a = f.parent[static_cast<size_t>(a)])
      keep[static_cast<size_t>(a)] = true;
  NodeTree t;
  file_to_tree.assign(m.nodes.size(), -1);
  for (size_t i : f.order) {
    if (!keep[i]) continue;
    file_to_tree[i] = static_cast<int>(t.parents.size());
    t.names.push_back(m.nodes[i].name);
    t.parents.push_back(f.parent[i] < 0 ? -1 : file_to_tree[static_cast<size_t>(f.parent[i])]);
    // Rest TRS. For nodes given as a matrix it is a decomposition (ignoring shear), only used
    // if a (non-conforming) file animates such a node.
    const glm::dmat4& l = f.local[i];
    const glm::dvec3 s(glm::length(glm::dvec3(l[0])), glm::length(glm::dvec3(l[1])), glm::length(glm::dvec3(l[2])));
    const glm::dmat3 rotation{glm::dvec3(l[0]) / s.x, glm::dvec3(l[1]) / s.y, glm::dvec3(l[2]) / s.z};
    const glm::dquat q = glm::normalize(glm::quat_cast(rotation));
    const double trs[10] = {l[3].x, l[3].y, l[3].z, q.x, q.y, q.z, q.w, s.x, s.y, s.z};
    t.rest_translation.insert(t.rest_translation.end(), trs, trs + 3);
    t.rest_rotation.insert(t.rest_rotation.end(), trs + 3, trs + 7);
    t.rest_scale.insert(t.rest_scale.end(), trs + 7, trs + 10);
    t.rest_matrix.resize(t.rest_matrix.size() + 16);
    detail::store_mat4(l, &t.rest_matrix[t.rest_matrix.size() - 16]);
  }
  for (int node : bone_file_nodes) t.bone_node.push_back(file_to_tree[static_cast<size_t>(node)]);
  return t;
}

/// Mesh data read from the file before welding; `weighted[v]` is false for vertices
/// without any positive weight.
struct RawMesh {
  std::vector<float> positions;
  std::vector<int32_t> triangles;
  std::vector<int32_t> joints;  // #V*4 bone indices
  std::vector<float> weights;   // #V*4
  std::vector<bool> weighted;
};

void read_primitive(const tinygltf::Model& m, const tinygltf::Primitive& prim,
                    const std::vector<int32_t>& bone_of_joint, RawMesh& out, const std::string& what) {
  if (prim.mode != -1 && prim.mode != TINYGLTF_MODE_TRIANGLES)
    fail(what + ": only TRIANGLES primitives are supported (mode " + std::to_string(prim.mode) + ")");
  const auto attribute = [&](const std::string& name) {
    const auto it = prim.attributes.find(name);
    return it == prim.attributes.end() ? -1 : it->second;
  };
  if (attribute("POSITION") < 0) fail(what + ": no POSITION attribute");
  const std::vector<float> pos = read_floats(m, attribute("POSITION"), TINYGLTF_TYPE_VEC3, what + " POSITION");
  const size_t nv = pos.size() / 3;
  const size_t base = out.positions.size() / 3;

  std::vector<uint32_t> idx;
  if (prim.indices >= 0) {
    idx = read_uints(m, prim.indices, TINYGLTF_TYPE_SCALAR, what + " indices");
  } else {
    idx.resize(nv);
    std::iota(idx.begin(), idx.end(), 0u);
  }
  if (idx.size() % 3 != 0) fail(what + ": index count is not a multiple of 3");
  for (uint32_t i : idx) {
    if (i >= nv) fail(what + ": vertex index out of range");
    out.triangles.push_back(static_cast<int32_t>(base + i));
  }

  // All JOINTS_n / WEIGHTS_n sets: up to 4 * sets influences per vertex.
  std::vector<std::vector<uint32_t>> joint_sets;
  std::vector<std::vector<float>> weight_sets;
  for (int set = 0;; ++set) {
    const int ja = attribute("JOINTS_" + std::to_string(set));
    const int wa = attribute("WEIGHTS_" + std::to_string(set));
    if (ja < 0 || wa < 0) break;
    joint_sets.push_back(read_uints(m, ja, TINYGLTF_TYPE_VEC4, what + " JOINTS_" + std::to_string(set)));
    weight_sets.push_back(read_floats(m, wa, TINYGLTF_TYPE_VEC4, what + " WEIGHTS_" + std::to_string(set)));
    if (joint_sets.back().size() != 4 * nv || weight_sets.back().size() != 4 * nv)
      fail(what + ": skin attribute count differs from the vertex count");
  }
  if (joint_sets.empty()) fail(what + ": no JOINTS_0 / WEIGHTS_0 attributes");

  std::vector<int32_t> bones(4 * joint_sets.size());
  std::vector<float> weights(4 * joint_sets.size());
  for (size_t v = 0; v < nv; ++v) {
    for (size_t s = 0; s < joint_sets.size(); ++s)
      for (size_t k = 0; k < 4; ++k) {
        const uint32_t j = joint_sets[s][4 * v + k];
        const float w = weight_sets[s][4 * v + k];
        const bool used = w > 0.0f;
        if (used && j >= bone_of_joint.size()) fail(what + ": joint index out of range of the skin");
        bones[4 * s + k] = used ? bone_of_joint[j] : 0;
        weights[4 * s + k] = used ? w : 0.0f;
      }
    int32_t bj[4];
    float bw[4];
    const bool ok = detail::top4_normalised(bones.data(), weights.data(), static_cast<int>(bones.size()), bj, bw);
    out.joints.insert(out.joints.end(), bj, bj + 4);
    out.weights.insert(out.weights.end(), bw, bw + 4);
    out.weighted.push_back(ok);
    for (int k = 0; k < 3; ++k) out.positions.push_back(pos[3 * v + static_cast<size_t>(k)]);
  }
}

/// Merges coincident vertices of `mesh` in place (see GltfLoadOptions::weld).
void weld(RawMesh& mesh, double tolerance) {
  const std::vector<int32_t> map = detail::weld_map(mesh.positions, tolerance);
  RawMesh w;
  for (size_t v = 0; v < map.size(); ++v) {
    if (static_cast<size_t>(map[v]) * 3 != w.positions.size()) continue;  // not a representative
    w.positions.insert(w.positions.end(), &mesh.positions[3 * v], &mesh.positions[3 * v] + 3);
    w.joints.insert(w.joints.end(), &mesh.joints[4 * v], &mesh.joints[4 * v] + 4);
    w.weights.insert(w.weights.end(), &mesh.weights[4 * v], &mesh.weights[4 * v] + 4);
    w.weighted.push_back(mesh.weighted[v]);
  }
  for (size_t t = 0; t + 2 < mesh.triangles.size(); t += 3) {
    const int32_t a = map[static_cast<size_t>(mesh.triangles[t])];
    const int32_t b = map[static_cast<size_t>(mesh.triangles[t + 1])];
    const int32_t c = map[static_cast<size_t>(mesh.triangles[t + 2])];
    if (a == b || b == c || c == a) continue;  // collapsed by the weld
    w.triangles.insert(w.triangles.end(), {a, b, c});
  }
  mesh = std::move(w);
}

double bbox_diagonal(const std::vector<float>& p) {
  if (p.empty()) return 0.0;
  glm::dvec3 lo(std::numeric_limits<double>::infinity()), hi(-std::numeric_limits<double>::infinity());
  for (size_t i = 0; i + 2 < p.size(); i += 3) {
    const glm::dvec3 x(p[i], p[i + 1], p[i + 2]);
    lo = glm::min(lo, x);
    hi = glm::max(hi, x);
  }
  return glm::length(hi - lo);
}

Animation read_animation(const tinygltf::Model& m, size_t index, const std::vector<int>& file_to_tree) {
  const tinygltf::Animation& a = m.animations[index];
  Animation out;
  out.name = a.name.empty() ? "animation_" + std::to_string(index) : a.name;
  const std::string what = "animation \"" + out.name + "\"";
  double first = std::numeric_limits<double>::infinity(), last = -first;
  for (const tinygltf::AnimationChannel& ch : a.channels) {
    Channel c;
    if (ch.target_path == "translation")
      c.path = Channel::Path::Translation;
    else if (ch.target_path == "rotation")
      c.path = Channel::Path::Rotation;
    else if (ch.target_path == "scale")
      c.path = Channel::Path::Scale;
    else
      continue;  // morph target weights: not part of the skeleton
    if (ch.sampler < 0 || static_cast<size_t>(ch.sampler) >= a.samplers.size())
      fail(what + ": sampler index out of range");
    const tinygltf::AnimationSampler& s = a.samplers[static_cast<size_t>(ch.sampler)];
    if (s.interpolation.empty() || s.interpolation == "LINEAR")
      c.interpolation = Channel::Interpolation::Linear;
    else if (s.interpolation == "STEP")
      c.interpolation = Channel::Interpolation::Step;
    else if (s.interpolation == "CUBICSPLINE")
      c.interpolation = Channel::Interpolation::CubicSpline;
    else
      fail(what + ": unknown interpolation " + s.interpolation);
    c.times = read_floats(m, s.input, TINYGLTF_TYPE_SCALAR, what + " input");
    const bool rotation = c.path == Channel::Path::Rotation;
    c.values = read_floats(m, s.output, rotation ? TINYGLTF_TYPE_VEC4 : TINYGLTF_TYPE_VEC3, what + " output");
    const size_t per_key =
        size_t{rotation ? 4u : 3u} * (c.interpolation == Channel::Interpolation::CubicSpline ? 3u : 1u);
    if (c.values.size() != c.times.size() * per_key) fail(what + ": key and value counts differ");
    if (c.times.empty()) continue;
    for (size_t k = 0; k < c.times.size(); ++k)
      if (!std::isfinite(c.times[k]) || (k > 0 && c.times[k] < c.times[k - 1]))
        fail(what + ": key times are not finite and ascending");
    first = std::min(first, static_cast<double>(c.times.front()));
    last = std::max(last, static_cast<double>(c.times.back()));
    // Channels of nodes that do not move the bones (e.g. the mesh node) are dropped.
    if (ch.target_node < 0 || static_cast<size_t>(ch.target_node) >= file_to_tree.size() ||
        file_to_tree[static_cast<size_t>(ch.target_node)] < 0)
      continue;
    c.node = file_to_tree[static_cast<size_t>(ch.target_node)];
    out.channels.push_back(std::move(c));
  }
  out.first_key_s = std::isfinite(first) ? first : 0.0;
  out.duration_s = std::isfinite(last) ? last : 0.0;
  return out;
}

Character load(const tinygltf::Model& m, const GltfLoadOptions& options) {
  const FileNodes f = file_nodes(m);
  std::vector<int> meshes;
  const tinygltf::Skin& skin = m.skins[static_cast<size_t>(find_skin(m, meshes))];
  const size_t nb = skin.joints.size();
  if (nb == 0) fail("the skin has no joints");

  std::vector<int> joint_parent;
  const std::vector<size_t> joint_of_bone = order_joints(skin, f, joint_parent);
  std::vector<int32_t> bone_of_joint(nb);
  for (size_t b = 0; b < nb; ++b) bone_of_joint[joint_of_bone[b]] = static_cast<int32_t>(b);

  std::vector<glm::dmat4> ibm(nb, glm::dmat4(1.0));  // identity when absent (glTF rule)
  if (skin.inverseBindMatrices >= 0) {
    const std::vector<float> raw = read_floats(m, skin.inverseBindMatrices, TINYGLTF_TYPE_MAT4, "inverseBindMatrices");
    if (raw.size() < 16 * nb) fail("fewer inverse bind matrices than joints");
    for (size_t j = 0; j < nb; ++j) ibm[j] = detail::load_mat4(&raw[16 * j]);
  }

  // Scene space. glTF skins a vertex v to sum_j w_j * global(joint j) * ibm_j * v in world
  // space, ignoring the mesh node's transform. W = global(root joint) * ibm(root joint) maps v
  // to where the file's node rest pose puts it (the identity for most exporters), so storing
  // positions W*v and rest W*inverse(ibm) keeps pose * inverse(rest) equal to glTF's skinning
  // matrix while the rest mesh lies in world space, upright for files like CesiumMan whose
  // IBMs do not include the ancestors' Z_UP / Armature rotations.
  const glm::dmat4 axes = options.to_blender_axes ? detail::gltf_to_blender_axes() : glm::dmat4(1.0);
  const size_t root_joint = joint_of_bone[0];
  const glm::dmat4 scene = axes * f.global[static_cast<size_t>(skin.joints[root_joint])] * ibm[root_joint];

  Character c;
  std::vector<int> bone_file_nodes;
  c.bone_rest.resize(16 * nb);
  for (size_t b = 0; b < nb; ++b) {
    const size_t j = joint_of_bone[b];
    const tinygltf::Node& node = m.nodes[static_cast<size_t>(skin.joints[j])];
    c.bone_names.push_back(node.name.empty() ? "joint_" + std::to_string(j) : node.name);
    c.bone_parents.push_back(joint_parent[j] < 0 ? -1 : bone_of_joint[static_cast<size_t>(joint_parent[j])]);
    detail::store_mat4(scene * glm::inverse(ibm[j]), &c.bone_rest[16 * b]);
    bone_file_nodes.push_back(skin.joints[j]);
  }

  RawMesh mesh;
  for (int mi : meshes) {
    const tinygltf::Mesh& mm = m.meshes[static_cast<size_t>(mi)];
    for (size_t p = 0; p < mm.primitives.size(); ++p)
      read_primitive(m, mm.primitives[p], bone_of_joint, mesh,
                     "mesh \"" + mm.name + "\" primitive " + std::to_string(p));
  }
  for (size_t i = 0; i + 2 < mesh.positions.size(); i += 3) {
    const glm::dvec4 x = scene * glm::dvec4(mesh.positions[i], mesh.positions[i + 1], mesh.positions[i + 2], 1.0);
    for (int k = 0; k < 3; ++k) mesh.positions[i + static_cast<size_t>(k)] = static_cast<float>(x[k]);
  }
  const double size = bbox_diagonal(mesh.positions);
  if (options.weld) weld(mesh, 1e-6 * size);

  c.positions = std::move(mesh.positions);
  c.triangles = std::move(mesh.triangles);
  c.skin_joints = std::move(mesh.joints);
  c.skin_weights = std::move(mesh.weights);
  detail::compute_bone_heads_tails(c, size);
  for (size_t v = 0; v < mesh.weighted.size(); ++v) {
    if (mesh.weighted[v]) continue;
    const int32_t joints[4] = {detail::nearest_bone(c, &c.positions[3 * v]), 0, 0, 0};
    const float weights[4] = {1.0f, 0.0f, 0.0f, 0.0f};
    std::copy(joints, joints + 4, &c.skin_joints[4 * v]);
    std::copy(weights, weights + 4, &c.skin_weights[4 * v]);
  }

  std::vector<int> file_to_tree;
  c.nodes = build_node_tree(m, f, bone_file_nodes, file_to_tree);
  for (int k = 0; k < 16; ++k) c.nodes.root_transform[static_cast<size_t>(k)] = static_cast<float>(axes[k / 4][k % 4]);
  for (size_t a = 0; a < m.animations.size(); ++a) c.animations.push_back(read_animation(m, a, file_to_tree));

  const std::string problems = validate(c);
  if (!problems.empty()) fail("the file gives an inconsistent character:\n" + problems);
  return c;
}

}  // namespace

Character load_gltf_character(const std::string& path, const GltfLoadOptions& options) {
  try {
    return load(read_model(path), options);
  } catch (const std::exception& e) {
    throw std::runtime_error("load_gltf_character(\"" + path + "\"): " + e.what());
  }
}

Character load_gltf_character_from_memory(const void* data, size_t size, const std::string& name,
                                          const GltfLoadOptions& options) {
  try {
    if (data == nullptr && size > 0) fail("no data");
    return load(read_model(static_cast<const unsigned char*>(data), size, nullptr), options);
  } catch (const std::exception& e) {
    throw std::runtime_error("load_gltf_character(\"" + name + "\"): " + e.what());
  }
}

}  // namespace sd::io
