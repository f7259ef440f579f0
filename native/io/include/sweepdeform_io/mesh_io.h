// Meshes and point clouds from and to files: OBJ, PLY and OFF through OpenMesh, plain XYZ
// point lists, OBJ sequences and PC2 point caches.
#pragma once

#include <cstdint>
#include <cstdio>
#include <string>
#include <vector>

namespace sd::io {

/// Positions and triangles as read; no triangles for a point cloud.
struct MeshData {
  std::vector<float> positions;    ///< #V*3, file axes and units
  std::vector<int32_t> triangles;  ///< #T*3; polygons are split into fans
};

/// The largest meshes read_mesh accepts (a PLY or OFF header declaring more is refused before
/// anything is allocated, as is one declaring more elements than its file has bytes).
constexpr long long kMaxMeshVertices = 50'000'000;
constexpr long long kMaxMeshFaces = 100'000'000;

/// Reads .obj, .ply, .off (OpenMesh: vertex order kept, faces with more than 3 corners split
/// into fans, faces OpenMesh cannot add to a manifold mesh dropped and counted in
/// `dropped_faces`; the vertices are exactly the file's, never the copies OpenMesh makes for
/// such faces) or .xyz / .txt / .pts (one point "x y z ..." per line, '#' comments).
/// OFF files are read in their text form only ([ST][C][N][4]OFF; not binary, not nOFF), PLY
/// files only with a header this reader understands (types, names, end_header) and a body
/// holding every element it declares, each list of at most 1024 entries.
/// Throws std::runtime_error naming the file when it cannot be read, has no vertices, declares
/// more than kMaxMeshVertices / kMaxMeshFaces, or has a point line that is not three finite
/// numbers.
MeshData read_mesh(const std::string& path, int* dropped_faces = nullptr);

/// Writes an OBJ file ("v" lines, then "f" lines with 1-based indices when there are
/// triangles). Throws std::runtime_error on an I/O error.
void write_obj(const std::string& path, const float* positions, size_t vertex_count,
               const std::vector<int32_t>& triangles);

/// A PC2 point cache (3ds Max / Blender's Mesh Cache modifier): the header
/// "POINTCACHE2\0", int32 version 1, int32 numPoints, float startFrame, float sampleRate,
/// int32 numSamples, then numSamples x numPoints x 3 float32 (little-endian). Frames are
/// appended one by one; close() writes the final sample count into the header.
class Pc2Writer {
 public:
  Pc2Writer(const std::string& path, int32_t point_count, float start_frame, float sample_rate);
  ~Pc2Writer();
  Pc2Writer(const Pc2Writer&) = delete;
  Pc2Writer& operator=(const Pc2Writer&) = delete;
  void add_frame(const float* positions);  ///< #numPoints*3
  void close();
  int32_t frames() const { return frames_; }

 private:
  std::string path_;
  std::FILE* f_ = nullptr;
  int32_t points_ = 0, frames_ = 0;
};

/// Reads a PC2 file back: header fields and all samples (#numSamples*numPoints*3).
struct Pc2Data {
  int32_t point_count = 0, sample_count = 0;
  float start_frame = 0, sample_rate = 1;
  std::vector<float> samples;
};
Pc2Data read_pc2(const std::string& path);

}  // namespace sd::io
