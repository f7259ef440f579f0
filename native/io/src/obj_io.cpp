#include "sweepdeform_io/mesh_io.h"

#include <OpenMesh/Core/IO/MeshIO.hh>
#include <OpenMesh/Core/Mesh/PolyMesh_ArrayKernelT.hh>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>

namespace sd::io {
namespace {

using PolyMesh = OpenMesh::PolyMesh_ArrayKernelT<>;

std::string extension(const std::string& path) {
  std::string e = std::filesystem::path(path).extension().string();
  std::transform(e.begin(), e.end(), e.begin(), [](unsigned char c) { return std::tolower(c); });
  return e;
}

MeshData read_points(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error(path + ": cannot open file");
  MeshData m;
  std::string line;
  int number = 0;
  while (std::getline(in, line)) {
    ++number;
    const size_t hash = line.find('#');
    if (hash != std::string::npos) line.resize(hash);
    std::istringstream ss(line);
    double x, y, z;
    if (!(ss >> x)) continue;  // blank line
    if (!(ss >> y >> z) || !std::isfinite(x) || !std::isfinite(y) || !std::isfinite(z))
      throw std::runtime_error(path + ":" + std::to_string(number) + ": expected 'x y z'");
    m.positions.insert(m.positions.end(), {static_cast<float>(x), static_cast<float>(y), static_cast<float>(z)});
  }
  return m;
}

/// Little-endian writes (the PC2 layout), whatever the host.
void put_u32(std::FILE* f, uint32_t v) {
  const unsigned char b[4] = {static_cast<unsigned char>(v), static_cast<unsigned char>(v >> 8),
                              static_cast<unsigned char>(v >> 16), static_cast<unsigned char>(v >> 24)};
  std::fwrite(b, 1, 4, f);
}
void put_f32(std::FILE* f, float x) {
  uint32_t v;
  std::memcpy(&v, &x, 4);
  put_u32(f, v);
}
uint32_t get_u32(const unsigned char* b) {
  return uint32_t(b[0]) | uint32_t(b[1]) << 8 | uint32_t(b[2]) << 16 | uint32_t(b[3]) << 24;
}
float get_f32(const unsigned char* b) {
  const uint32_t v = get_u32(b);
  float x;
  std::memcpy(&x, &v, 4);
  return x;
}

}  // namespace

MeshData read_mesh(const std::string& path, int* dropped_faces) {
  if (dropped_faces) *dropped_faces = 0;
  if (!std::filesystem::is_regular_file(path)) throw std::runtime_error(path + ": no such file");
  const std::string ext = extension(path);
  if (ext == ".xyz" || ext == ".txt" || ext == ".pts") {
    MeshData m = read_points(path);
    if (m.positions.empty()) throw std::runtime_error(path + ": no points");
    return m;
  }
  if (ext != ".obj" && ext != ".ply" && ext != ".off")
    throw std::runtime_error(path + ": unknown mesh format '" + ext + "' (use .obj, .ply, .off or .xyz)");
  PolyMesh mesh;
  OpenMesh::IO::Options options;
  if (!OpenMesh::IO::read_mesh(mesh, path, options))
    throw std::runtime_error(path + ": OpenMesh could not read it (not a valid " + ext.substr(1) + " file?)");
  MeshData m;
  m.positions.reserve(3 * mesh.n_vertices());
  for (const auto vh : mesh.vertices()) {
    const auto p = mesh.point(vh);
    for (int k = 0; k < 3; ++k) {
      if (!std::isfinite(p[k]))
        throw std::runtime_error(path + ": vertex " + std::to_string(vh.idx()) + " is not finite");
      m.positions.push_back(static_cast<float>(p[k]));
    }
  }
  if (m.positions.empty()) throw std::runtime_error(path + ": no vertices");
  for (const auto fh : mesh.faces()) {
    std::vector<int32_t> corners;
    for (const auto vh : mesh.fv_range(fh)) corners.push_back(vh.idx());
    for (size_t i = 1; i + 1 < corners.size(); ++i)
      m.triangles.insert(m.triangles.end(), {corners[0], corners[i], corners[i + 1]});
  }
  if (dropped_faces) {
    // OpenMesh drops faces it cannot add (complex edges); count the file's faces for OBJ/OFF.
    int faces = -1;
    if (ext == ".obj") {
      std::ifstream in(path);
      std::string line;
      faces = 0;
      while (std::getline(in, line))
        if (line.size() > 1 && line[0] == 'f' && std::isspace(static_cast<unsigned char>(line[1]))) ++faces;
    }
    if (faces >= 0) *dropped_faces = std::max(0, faces - static_cast<int>(mesh.n_faces()));
  }
  return m;
}

void write_obj(const std::string& path, const float* p, size_t n, const std::vector<int32_t>& triangles) {
  std::FILE* f = std::fopen(path.c_str(), "wb");
  if (!f) throw std::runtime_error(path + ": cannot write (" + std::strerror(errno) + ")");
  std::string buf;
  buf.reserve(1 << 20);
  char line[128];
  const auto flush = [&] {
    if (!buf.empty() && std::fwrite(buf.data(), 1, buf.size(), f) != buf.size()) {
      std::fclose(f);
      throw std::runtime_error(path + ": write error");
    }
    buf.clear();
  };
  for (size_t v = 0; v < n; ++v) {
    const int len = std::snprintf(line, sizeof line, "v %.6g %.6g %.6g\n", p[3 * v], p[3 * v + 1], p[3 * v + 2]);
    buf.append(line, static_cast<size_t>(len));
    if (buf.size() > (1 << 20)) flush();
  }
  for (size_t t = 0; t + 2 < triangles.size(); t += 3) {
    const int len =
        std::snprintf(line, sizeof line, "f %d %d %d\n", triangles[t] + 1, triangles[t + 1] + 1, triangles[t + 2] + 1);
    buf.append(line, static_cast<size_t>(len));
    if (buf.size() > (1 << 20)) flush();
  }
  flush();
  if (std::fclose(f) != 0) throw std::runtime_error(path + ": write error");
}

Pc2Writer::Pc2Writer(const std::string& path, int32_t point_count, float start_frame, float sample_rate)
    : path_(path), points_(point_count) {
  if (point_count < 1) throw std::invalid_argument("PC2: point count must be >= 1");
  f_ = std::fopen(path.c_str(), "wb");
  if (!f_) throw std::runtime_error(path + ": cannot write (" + std::strerror(errno) + ")");
  std::fwrite("POINTCACHE2\0", 1, 12, f_);
  put_u32(f_, 1);
  put_u32(f_, static_cast<uint32_t>(point_count));
  put_f32(f_, start_frame);
  put_f32(f_, sample_rate);
  put_u32(f_, 0);  // numSamples, written by close()
}

Pc2Writer::~Pc2Writer() {
  try {
    close();
  } catch (...) {
  }
}

void Pc2Writer::add_frame(const float* p) {
  if (!f_) throw std::logic_error("PC2: writer is closed");
  for (size_t i = 0; i < 3 * static_cast<size_t>(points_); ++i) put_f32(f_, p[i]);
  if (std::ferror(f_)) throw std::runtime_error(path_ + ": write error");
  ++frames_;
}

void Pc2Writer::close() {
  if (!f_) return;
  std::FILE* f = f_;
  f_ = nullptr;
  const bool ok = std::fseek(f, 28, SEEK_SET) == 0;  // numSamples
  if (ok) put_u32(f, static_cast<uint32_t>(frames_));
  if (std::fclose(f) != 0 || !ok) throw std::runtime_error(path_ + ": write error");
}

Pc2Data read_pc2(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error(path + ": cannot open file");
  unsigned char h[32];
  if (!in.read(reinterpret_cast<char*>(h), 32) || std::memcmp(h, "POINTCACHE2\0", 12) != 0)
    throw std::runtime_error(path + ": not a PC2 file");
  if (get_u32(h + 12) != 1) throw std::runtime_error(path + ": PC2 version is not 1");
  Pc2Data d;
  d.point_count = static_cast<int32_t>(get_u32(h + 16));
  d.start_frame = get_f32(h + 20);
  d.sample_rate = get_f32(h + 24);
  d.sample_count = static_cast<int32_t>(get_u32(h + 28));
  if (d.point_count < 0 || d.sample_count < 0) throw std::runtime_error(path + ": bad PC2 header");
  const size_t n = static_cast<size_t>(d.point_count) * static_cast<size_t>(d.sample_count) * 3;
  std::vector<unsigned char> raw(4 * n);
  if (!in.read(reinterpret_cast<char*>(raw.data()), static_cast<std::streamsize>(raw.size())))
    throw std::runtime_error(path + ": PC2 file is truncated");
  d.samples.resize(n);
  for (size_t i = 0; i < n; ++i) d.samples[i] = get_f32(raw.data() + 4 * i);
  return d;
}

}  // namespace sd::io
