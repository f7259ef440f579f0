#include "sweepdeform_io/mesh_io.h"

#include <OpenMesh/Core/IO/MeshIO.hh>
#include <OpenMesh/Core/Mesh/PolyMesh_ArrayKernelT.hh>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <utility>
#include <vector>

namespace sd::io {
namespace {

using PolyMesh = OpenMesh::PolyMesh_ArrayKernelT<>;

std::string extension(const std::string& path) {
  std::string e = std::filesystem::path(path).extension().string();
  std::transform(e.begin(), e.end(), e.begin(), [](unsigned char c) { return std::tolower(c); });
  return e;
}

/// One element of a PLY header: its name, count and properties (a list's count type in
/// `count_type`).
struct PlyElement {
  struct Property {
    bool list = false;
    std::string count_type, type;
  };
  std::string name;
  long long count = 0;
  std::vector<Property> properties;
};

/// The body of a PLY file, walked value by value before OpenMesh reads it: OpenMesh 9 takes a
/// list size it cannot read (the "0-1" of a face line, a negative number) for a count of
/// billions and allocates until memory runs out (found by fuzz_mesh_file in the 600 s pass).
/// Every list size must be a whole number in 0..kMaxPlyList, every value of a text file a
/// number, and the file must hold all the elements its header declares. `in` stands just
/// after end_header.
constexpr long long kMaxPlyList = 1024;
void check_ply_body(std::istream& in, const std::string& path, const std::string& format,
                    const std::vector<PlyElement>& elements) {
  const bool ascii = format == "ascii";
  const uint16_t probe = 1;
  unsigned char host_first = 0;
  std::memcpy(&host_first, &probe, 1);
  const bool swap = (format == "binary_big_endian") == (host_first == 1);  // file and host differ
  const auto bytes_of = [](const std::string& t) -> int {
    if (t == "char" || t == "uchar" || t == "int8" || t == "uint8") return 1;
    if (t == "short" || t == "ushort" || t == "int16" || t == "uint16") return 2;
    if (t == "double" || t == "float64") return 8;
    return 4;  // int, uint, float and their sized names
  };
  // 0: read into `out`; 1: end of file; 2: a text value that is not a number (in `word`).
  std::string word;
  const auto value = [&](const std::string& type, double& out) -> int {
    if (ascii) {
      if (!(in >> word)) return 1;
      char* end = nullptr;
      out = std::strtod(word.c_str(), &end);
      return end == word.c_str() + word.size() ? 0 : 2;
    }
    unsigned char b[8] = {0, 0, 0, 0, 0, 0, 0, 0};
    const int n = bytes_of(type);
    if (!in.read(reinterpret_cast<char*>(b), n)) return 1;
    if (swap) std::reverse(b, b + n);
    if (type == "float" || type == "float32") {
      float f;
      std::memcpy(&f, b, 4);
      out = f;
    } else if (type == "double" || type == "float64") {
      std::memcpy(&out, b, 8);
    } else {  // b holds the value in the host's byte order now
      if (type == "char" || type == "int8") {
        int8_t v;
        std::memcpy(&v, b, 1);
        out = v;
      } else if (type == "uchar" || type == "uint8") {
        out = b[0];
      } else if (type == "short" || type == "int16") {
        int16_t v;
        std::memcpy(&v, b, 2);
        out = v;
      } else if (type == "ushort" || type == "uint16") {
        uint16_t v;
        std::memcpy(&v, b, 2);
        out = v;
      } else if (type == "int" || type == "int32") {
        int32_t v;
        std::memcpy(&v, b, 4);
        out = v;
      } else {
        uint32_t v;
        std::memcpy(&v, b, 4);
        out = v;
      }
    }
    return 0;
  };
  for (const PlyElement& e : elements)
    for (long long item = 0; item < e.count; ++item)
      for (const PlyElement::Property& p : e.properties) {
        const auto fail = [&](const std::string& why) {
          throw std::runtime_error(path + ": PLY element '" + e.name.substr(0, 24) + "' item " + std::to_string(item) +
                                   ": " + why);
        };
        double x = 0.0;
        int r = value(p.list ? p.count_type : p.type, x);
        if (r == 1) fail("the file ends early");
        if (r == 2 && !p.list) fail("'" + word.substr(0, 24) + "' is not a number");
        if (!p.list) continue;
        const bool digits =
            !ascii || std::all_of(word.begin(), word.end(), [](unsigned char c) { return std::isdigit(c); });
        if (!(r == 0 && digits && x >= 0.0 && x <= kMaxPlyList && x == std::floor(x)))
          fail("list size " +
               (ascii                ? "'" + word.substr(0, 24) + "'"
                : std::abs(x) < 1e18 ? std::to_string(static_cast<long long>(x))
                                     : std::to_string(x)) +
               " is not in 0.." + std::to_string(kMaxPlyList));
        for (long long k = 0, n = static_cast<long long>(x); k < n; ++k) {
          r = value(p.type, x);
          if (r == 1) fail("the file ends early");
          if (r == 2) fail("'" + word.substr(0, 24) + "' is not a number");
        }
      }
}

/// The element counts a PLY or OFF header declares, checked against kMaxMeshVertices /
/// kMaxMeshFaces and the file's size before OpenMesh reserves memory for them (a header
/// claiming 4e9 vertices would otherwise have it try to allocate ~100 GB). Returns the
/// declared (vertex, face) counts (-1 when the header has none).
std::pair<long long, long long> check_header_counts(const std::string& path, const std::string& ext) {
  const auto bytes = static_cast<unsigned long long>(std::filesystem::file_size(path));
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error(path + ": cannot open file");
  long long vertices = -1, faces = -1;
  const auto number = [&](const std::string& word, const std::string& what) -> long long {
    // Digits only: a sign, an exponent or more than 18 digits is no count.
    if (word.empty() || word.size() > 18 ||
        !std::all_of(word.begin(), word.end(), [](unsigned char c) { return std::isdigit(c); }))
      throw std::runtime_error(path + ": the header's " + what + " count '" + word.substr(0, 24) + "' is not a count");
    return std::stoll(word);
  };
  std::string line;
  if (ext == ".ply") {
    // The whole header is checked here: OpenMesh 9's PLY reader loops forever on a header
    // without "end_header" or with a property type it does not know (found by fuzz_mesh_file).
    // OpenMesh reads the header word by word, this check line by line: each line must hold
    // exactly its words, or a missing property name makes OpenMesh take the next line's
    // "end_header" for it and loop forever past the end of the file (fuzz_mesh_file's 600 s
    // pass, regress_ply_property_without_name).
    static const std::vector<std::string> kTypes = {"char",  "uchar",  "short",   "ushort", "int",   "uint",
                                                    "float", "double", "int8",    "uint8",  "int16", "uint16",
                                                    "int32", "uint32", "float32", "float64"};
    const auto is_type = [&](const std::string& t) {
      return std::find(kTypes.begin(), kTypes.end(), t) != kTypes.end();
    };
    const auto bad = [&](int n, const std::string& why) {
      throw std::runtime_error(path + ": PLY header line " + std::to_string(n) + ": " + why);
    };
    int lines = 0;
    bool ended = false, in_element = false;
    std::vector<PlyElement> elements;
    std::string format;
    while (!ended && std::getline(in, line)) {
      if (++lines > 10000) bad(lines, "no end_header in the first 10000 lines");
      if (!line.empty() && line.back() == '\r') line.pop_back();
      if (line.find('\0') != std::string::npos) bad(lines, "a NUL byte in the header");
      std::istringstream ss(line);
      std::string key;
      ss >> key;
      if (key == "format") {  // OpenMesh's header check crashes on a damaged one (fuzz_mesh_file)
        std::string kind, version, more;
        ss >> kind >> version;
        if ((kind != "ascii" && kind != "binary_little_endian" && kind != "binary_big_endian") || version != "1.0" ||
            (ss >> more))
          bad(lines, "unknown format '" + line.substr(0, 60) + "'");
        format = kind;
        continue;
      }
      if (lines == 1) {
        if (key != "ply") bad(1, "the file does not start with 'ply'");
        continue;
      }
      std::string extra;
      const auto words_end = [&]() {  // nothing may follow the line's last word
        if (ss >> extra) bad(lines, "'" + extra.substr(0, 24) + "' after the end of '" + line.substr(0, 60) + "'");
      };
      if (key == "end_header") {
        words_end();
        ended = true;
      } else if (key == "property" && !in_element) {  // OpenMesh crashes on it (fuzz_mesh_file)
        bad(lines, "a property before any element");
      } else if (key == "element") {
        in_element = true;
        std::string kind, count;
        ss >> kind >> count;
        words_end();
        // One element of a name: OpenMesh took a second, huge "vertex" element for its count while
        // this check bounded only the last one (2.4 GB; fuzz_mesh_file's fourth 600 s run,
        // regress_ply_second_vertex_element). Every count is bounded by the file's size.
        for (const PlyElement& e : elements)
          if (e.name == kind) bad(lines, "a second '" + kind.substr(0, 24) + "' element");
        elements.push_back({kind, number(count, kind == "vertex" || kind == "face" ? kind : kind.substr(0, 24)), {}});
        if (static_cast<unsigned long long>(elements.back().count) > bytes && kind != "vertex" && kind != "face")
          bad(lines, "the element '" + kind.substr(0, 24) + "' declares " + std::to_string(elements.back().count) +
                         " items, more than the file's " + std::to_string(bytes) + " bytes can hold");
        if (kind == "vertex") vertices = elements.back().count;
        if (kind == "face") faces = elements.back().count;
      } else if (key == "property") {
        std::string type, a, b, name;
        ss >> type >> a;
        if (type == "list") ss >> b >> name;
        if (type == "list" ? !(is_type(a) && is_type(b)) : !is_type(type))
          bad(lines, "unknown property type in '" + line.substr(0, 60) + "'");
        if ((type == "list" ? name : a).empty()) bad(lines, "a property without a name: '" + line.substr(0, 60) + "'");
        words_end();
        elements.back().properties.push_back({type == "list", a, type == "list" ? b : type});
      } else if (key != "format" && key != "comment" && key != "obj_info" && !key.empty()) {
        bad(lines, "unknown keyword '" + key.substr(0, 24) + "'");
      }
    }
    if (!ended) bad(lines, "the header has no end_header");
    if (format.empty()) bad(lines, "the header has no format line");
    // The body, when every count is bounded (each element takes at least a byte of the file).
    bool bounded = vertices <= kMaxMeshVertices && faces <= kMaxMeshFaces;
    for (const PlyElement& e : elements) bounded = bounded && static_cast<unsigned long long>(e.count) <= bytes;
    if (bounded) check_ply_body(in, path, format, elements);
  } else {  // .off: "[ST][C][N][4]OFF" (maybe with the counts on the same line), comments, "nv nf ne"
    // Only this text form is passed to OpenMesh, which otherwise takes whatever follows a
    // damaged keyword for counts (a 4.7 GB allocation, found by fuzz_mesh_file).
    std::vector<std::string> words;
    bool keyword = false;
    while (words.size() < 2 && std::getline(in, line)) {
      const size_t hash = line.find('#');
      if (hash != std::string::npos) line.resize(hash);
      std::istringstream ss(line);
      for (std::string w; ss >> w;) {
        if (!keyword) {
          static const std::vector<std::string> kKeywords = {"OFF",    "COFF",    "NOFF", "CNOFF", "STOFF", "STCOFF",
                                                             "STNOFF", "STCNOFF", "4OFF", "C4OFF", "N4OFF"};
          if (std::find(kKeywords.begin(), kKeywords.end(), w) == kKeywords.end())
            throw std::runtime_error(path + ": not a text OFF file (it starts with '" + w.substr(0, 24) +
                                     "'; binary and nOFF files are not read)");
          keyword = true;
          std::string more;
          if (ss >> more) {
            // OpenMesh reads the counts from the next line whatever this one holds after the
            // keyword (it took "0-01" there for -1 vertices: 17 GB, found by fuzz_mesh_file).
            if (more == "BINARY") throw std::runtime_error(path + ": binary OFF files are not read");
            throw std::runtime_error(path + ": the OFF keyword line holds '" + more.substr(0, 24) +
                                     "': the counts belong on the next line");
          }
          break;
        }
        words.push_back(w);
      }
    }
    if (words.size() < 2) throw std::runtime_error(path + ": the OFF header has no vertex and face counts");
    vertices = number(words[0], "vertex");
    faces = number(words[1], "face");
    if (vertices <= kMaxMeshVertices && faces <= kMaxMeshFaces && vertices <= static_cast<long long>(bytes) &&
        faces <= static_cast<long long>(bytes)) {
      // The body too: OpenMesh takes a negative or damaged face size for a count of billions
      // (found by fuzz_mesh_file). Vertex lines: three numbers; face lines: n in 3..1024, then
      // n indices below the vertex count.
      const auto body_error = [&](long long item, const std::string& why) {
        throw std::runtime_error(path + ": OFF " + why + " (item " + std::to_string(item) + ")");
      };
      const auto next = [&](std::string& w) -> bool {
        for (;;) {
          if (in >> w) {
            if (w[0] != '#') return true;
            std::getline(in, line);  // a comment
            continue;
          }
          return false;
        }
      };
      std::string w;
      for (long long v = 0; v < vertices; ++v) {
        std::getline(in >> std::ws, line);
        const size_t hash = line.find('#');
        if (hash != std::string::npos) line.resize(hash);
        std::istringstream ss(line);
        double c[3];
        if (!(ss >> c[0] >> c[1] >> c[2]) ||
            !(std::abs(c[0]) <= 1e30 && std::abs(c[1]) <= 1e30 && std::abs(c[2]) <= 1e30))
          body_error(v, "vertex line is not three finite numbers");
      }
      for (long long f = 0; f < faces; ++f) {
        if (!next(w)) body_error(f, "face list ends early");
        const long long n = number(w, "face size");
        if (n < 3 || n > 1024) body_error(f, "face size " + std::to_string(n) + " is outside 3..1024");
        std::getline(in, line);
        std::istringstream ss(line);
        for (long long k = 0; k < n; ++k) {
          std::string idx;
          if (!(ss >> idx)) body_error(f, "face has fewer indices than its size");
          if (number(idx, "face index") >= vertices) body_error(f, "face index " + idx + " is not a vertex");
        }
      }
    }
  }
  // Every element takes at least one byte of the file (three floats in a binary PLY, "x y z" in text).
  if (vertices > kMaxMeshVertices || (vertices > 0 && static_cast<unsigned long long>(vertices) > bytes))
    throw std::runtime_error(path + ": the header declares " + std::to_string(vertices) + " vertices; at most " +
                             std::to_string(kMaxMeshVertices) + " are read, and no more than the file's " +
                             std::to_string(bytes) + " bytes can hold");
  if (faces > kMaxMeshFaces || (faces > 0 && static_cast<unsigned long long>(faces) > bytes))
    throw std::runtime_error(path + ": the header declares " + std::to_string(faces) + " faces; at most " +
                             std::to_string(kMaxMeshFaces) + " are read, and no more than the file's " +
                             std::to_string(bytes) + " bytes can hold");
  return {vertices, faces};
}

/// The "v" and "f" lines of an OBJ file, which is checked line by line first: OpenMesh 9's OBJ
/// reader crashes on a face corner without a vertex index ("f /1 2 5") and indexes out of
/// range on bad indices (found by fuzz_mesh_file). Every face corner must be v, v/vt, v//vn
/// or v/vt/vn with v a vertex defined above it (1-based, or negative: relative); NUL bytes
/// and more than kMaxMeshVertices vertices are refused.
std::pair<long long, long long> obj_counts(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::string line;
  long long v = 0, f = 0, number = 0;
  const auto bad = [&](const std::string& why) {
    throw std::runtime_error(path + ":" + std::to_string(number) + ": " + why);
  };
  const auto index = [&](const std::string& s, size_t a, size_t b, bool required) -> bool {
    if (a == b) {
      if (required) bad("a face corner without a vertex index");
      return false;
    }
    size_t i = a + (s[a] == '-' ? 1 : 0);
    if (i == b || b - i > 12) bad("bad index '" + s.substr(a, std::min<size_t>(b - a, 24)) + "'");
    for (size_t k = i; k < b; ++k)
      if (!std::isdigit(static_cast<unsigned char>(s[k])))
        bad("bad index '" + s.substr(a, std::min<size_t>(b - a, 24)) + "'");
    return true;
  };
  while (std::getline(in, line)) {
    ++number;
    if (line.find('\0') != std::string::npos) bad("a NUL byte (not a text OBJ file)");
    // OpenMesh reads the keyword as the line's first word: " f /3" is a face to it, and a face
    // corner without an index there failed its assertion (fuzz_mesh_file's third 600 s run,
    // regress_obj_indented_face).
    line.erase(0, std::min(line.size(), line.find_first_not_of(" \t\n\v\f\r")));
    if (line.size() > 1 && std::isspace(static_cast<unsigned char>(line[1]))) {
      if (line[0] == 'v' && ++v > kMaxMeshVertices) bad("more than " + std::to_string(kMaxMeshVertices) + " vertices");
      if (line[0] != 'f') continue;
      ++f;
      std::istringstream ss(line.substr(2));
      for (std::string c; ss >> c;) {
        const size_t s1 = c.find('/'), s2 = s1 == std::string::npos ? s1 : c.find('/', s1 + 1);
        const size_t end_v = std::min(s1, c.size());
        index(c, 0, end_v, true);
        const long long vi = std::stoll(c.substr(0, end_v));
        if (vi == 0 || vi > v || -vi > v) bad("face corner '" + c.substr(0, 24) + "' names no vertex defined above it");
        if (s1 != std::string::npos) {
          index(c, s1 + 1, std::min(s2, c.size()), false);
          if (s2 != std::string::npos) index(c, s2 + 1, c.size(), false);
          if (s2 != std::string::npos && c.find('/', s2 + 1) != std::string::npos)
            bad("bad face corner '" + c.substr(0, 24) + "'");
        }
      }
    }
  }
  return {v, f};
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
    if (line.find_first_not_of(" \t\r\v\f") == std::string::npos) continue;  // blank line
    std::istringstream ss(line);
    double x, y, z;
    // A line that does not start with three finite numbers ("nan 0 0", "v 1 2 3") is an
    // error, never skipped: every point of the file is deformed, in order.
    // Beyond 1e30 is refused too: a double past float's range made the conversion undefined
    // (found by fuzz_mesh_file).
    if (!(ss >> x >> y >> z) || !(std::abs(x) <= 1e30) || !(std::abs(y) <= 1e30) || !(std::abs(z) <= 1e30))
      throw std::runtime_error(path + ":" + std::to_string(number) + ": expected 'x y z' with finite numbers");
    if (m.positions.size() / 3 >= static_cast<size_t>(kMaxMeshVertices))
      throw std::runtime_error(path + ": more than " + std::to_string(kMaxMeshVertices) + " points");
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
  // The file's own counts: the header's of a PLY or OFF, the "v" and "f" lines of an OBJ.
  const auto [file_vertices, file_faces] = ext == ".obj" ? obj_counts(path) : check_header_counts(path, ext);
  PolyMesh mesh;
  OpenMesh::IO::Options options;
  if (!OpenMesh::IO::read_mesh(mesh, path, options))
    throw std::runtime_error(path + ": OpenMesh could not read it (not a valid " + ext.substr(1) + " file?)");
  // OpenMesh adds a face it cannot add to a manifold mesh with copies of its vertices,
  // appended after the file's own: those copies are not the file's points. Only the file's
  // vertices are kept, in order, and faces that would need a copy are dropped (counted).
  const long long kept = file_vertices >= 0 ? std::min<long long>(file_vertices, mesh.n_vertices())
                                            : static_cast<long long>(mesh.n_vertices());
  MeshData m;
  m.positions.reserve(3 * static_cast<size_t>(kept));
  for (const auto vh : mesh.vertices()) {
    if (vh.idx() >= kept) break;
    const auto p = mesh.point(vh);
    for (int k = 0; k < 3; ++k) {
      if (!std::isfinite(p[k]))
        throw std::runtime_error(path + ": vertex " + std::to_string(vh.idx()) + " is not finite");
      m.positions.push_back(static_cast<float>(p[k]));
    }
  }
  if (m.positions.empty()) throw std::runtime_error(path + ": no vertices");
  long long on_copies = 0;
  for (const auto fh : mesh.faces()) {
    std::vector<int32_t> corners;
    for (const auto vh : mesh.fv_range(fh)) corners.push_back(vh.idx());
    if (std::any_of(corners.begin(), corners.end(), [&](int32_t c) { return c >= kept; })) {
      ++on_copies;
      continue;
    }
    for (size_t i = 1; i + 1 < corners.size(); ++i)
      m.triangles.insert(m.triangles.end(), {corners[0], corners[i], corners[i + 1]});
  }
  if (dropped_faces) {
    // Faces OpenMesh could not add at all, and those it added on copied vertices.
    const long long read = static_cast<long long>(mesh.n_faces()) - on_copies;
    *dropped_faces = file_faces >= 0 ? static_cast<int>(std::max(0LL, file_faces - read)) : static_cast<int>(on_copies);
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
  // The header's counts against the file's size, before allocating for them.
  std::error_code ec;
  const auto bytes = std::filesystem::file_size(path, ec);
  if (ec || 4 * static_cast<unsigned long long>(n) > bytes)
    throw std::runtime_error(path + ": PC2 header declares " + std::to_string(d.point_count) + " points x " +
                             std::to_string(d.sample_count) + " samples, more than the file holds (truncated?)");
  std::vector<unsigned char> raw(4 * n);
  if (!in.read(reinterpret_cast<char*>(raw.data()), static_cast<std::streamsize>(raw.size())))
    throw std::runtime_error(path + ": PC2 file is truncated");
  d.samples.resize(n);
  for (size_t i = 0; i < n; ++i) d.samples[i] = get_f32(raw.data() + 4 * i);
  return d;
}

}  // namespace sd::io
