#include "sweepdeform_io/bvh.h"

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <limits>
#include <map>
#include <sstream>
#include <stdexcept>
#include <string>

#include "mat4.h"

namespace sd::io {
namespace {

/// Whitespace tokenizer that knows its line number.
class Tokens {
 public:
  Tokens(std::string_view text, std::string source) : text_(text), source_(std::move(source)) {}

  bool at_end() {
    skip_space();
    return pos_ >= text_.size();
  }
  std::string_view next() {
    skip_space();
    if (pos_ >= text_.size()) fail("unexpected end of file");
    const size_t start = pos_;
    while (pos_ < text_.size() && !std::isspace(static_cast<unsigned char>(text_[pos_]))) ++pos_;
    return text_.substr(start, pos_ - start);
  }
  void expect(std::string_view word) {
    const std::string_view t = next();
    if (t != word) fail("expected '" + std::string(word) + "', found '" + std::string(t) + "'");
  }
  double number() {
    const std::string_view t = next();
    const std::string s(t);
    char* end = nullptr;
    errno = 0;
    const double v = std::strtod(s.c_str(), &end);
    if (end != s.c_str() + s.size() || s.empty() || errno == ERANGE || !std::isfinite(v))
      fail("expected a number, found '" + s + "'");
    return v;
  }
  long integer() {
    const double v = number();
    if (v != std::floor(v) || v < 0 || v > 1e9) fail("expected a count, found " + std::to_string(v));
    return static_cast<long>(v);
  }
  /// The rest of the current line (for "Frame Time:" written without a space, etc.).
  [[noreturn]] void fail(const std::string& what) const {
    throw std::runtime_error(source_ + ":" + std::to_string(line()) + ": " + what);
  }
  int line() const {
    return 1 + static_cast<int>(std::count(text_.begin(), text_.begin() + static_cast<long>(pos_), '\n'));
  }
  size_t position() const { return pos_; }
  std::string_view text() const { return text_; }

 private:
  void skip_space() {
    while (pos_ < text_.size() && std::isspace(static_cast<unsigned char>(text_[pos_]))) ++pos_;
  }
  std::string_view text_;
  std::string source_;
  size_t pos_ = 0;
};

bool parse_channel(std::string_view t, BvhChannel* out) {
  std::string s(t);
  std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return std::tolower(c); });
  static const std::map<std::string, BvhChannel> names = {
      {"xposition", BvhChannel::Xposition}, {"yposition", BvhChannel::Yposition}, {"zposition", BvhChannel::Zposition},
      {"xrotation", BvhChannel::Xrotation}, {"yrotation", BvhChannel::Yrotation}, {"zrotation", BvhChannel::Zrotation}};
  const auto it = names.find(s);
  if (it == names.end()) return false;
  *out = it->second;
  return true;
}

/// Reads one joint block after its name: { OFFSET ... CHANNELS ... children }.
void parse_joint(Tokens& tok, BvhClip& clip, int32_t parent, std::string name, int depth) {
  if (depth > 512) tok.fail("hierarchy nested too deeply");
  const auto index = static_cast<int32_t>(clip.joints.size());
  BvhJoint j;
  j.name = std::move(name);
  j.parent = parent;
  j.first_channel = clip.channel_count;
  clip.joints.push_back(j);
  if (parent >= 0) clip.joints[static_cast<size_t>(parent)].children.push_back(index);
  tok.expect("{");
  bool have_offset = false, have_channels = false;
  for (;;) {
    const std::string_view t = tok.next();
    if (t == "}") break;
    if (t == "OFFSET") {
      if (have_offset) tok.fail("joint '" + clip.joints[static_cast<size_t>(index)].name + "' has two OFFSETs");
      for (int k = 0; k < 3; ++k) clip.joints[static_cast<size_t>(index)].offset[static_cast<size_t>(k)] = tok.number();
      have_offset = true;
    } else if (t == "CHANNELS") {
      if (have_channels)
        tok.fail("joint '" + clip.joints[static_cast<size_t>(index)].name + "' has two CHANNELS lines");
      const long n = tok.integer();
      if (n > 6) tok.fail("a joint has at most 6 channels, found " + std::to_string(n));
      auto& channels = clip.joints[static_cast<size_t>(index)].channels;
      for (long i = 0; i < n; ++i) {
        const std::string_view c = tok.next();
        BvhChannel ch;
        if (!parse_channel(c, &ch)) tok.fail("unknown channel '" + std::string(c) + "'");
        if (std::find(channels.begin(), channels.end(), ch) != channels.end())
          tok.fail("channel '" + std::string(c) + "' listed twice");
        channels.push_back(ch);
      }
      clip.channel_count += static_cast<int32_t>(n);
      have_channels = true;
    } else if (t == "JOINT") {
      parse_joint(tok, clip, index, std::string(tok.next()), depth + 1);
    } else if (t == "End") {
      tok.expect("Site");
      tok.expect("{");
      std::array<double, 3> end{};
      tok.expect("OFFSET");
      for (int k = 0; k < 3; ++k) end[static_cast<size_t>(k)] = tok.number();
      tok.expect("}");
      clip.joints[static_cast<size_t>(index)].end_sites.push_back(end);
    } else {
      tok.fail("unexpected '" + std::string(t) + "' in joint '" + clip.joints[static_cast<size_t>(index)].name + "'");
    }
  }
  if (!have_offset) tok.fail("joint '" + clip.joints[static_cast<size_t>(index)].name + "' has no OFFSET");
}

glm::dmat3 axis_rotation(BvhChannel c, double degrees) {
  const double r = glm::radians(degrees);
  const double cs = std::cos(r), sn = std::sin(r);
  glm::dmat3 m(1.0);  // columns
  switch (c) {
    case BvhChannel::Xrotation:
      m[1] = {0, cs, sn};
      m[2] = {0, -sn, cs};
      break;
    case BvhChannel::Yrotation:
      m[0] = {cs, 0, -sn};
      m[2] = {sn, 0, cs};
      break;
    case BvhChannel::Zrotation:
      m[0] = {cs, sn, 0};
      m[1] = {-sn, cs, 0};
      break;
    default:
      break;
  }
  return m;
}

/// Local matrices of every joint at a frame (-1 = rest).
std::vector<glm::dmat4> local_matrices(const BvhClip& clip, int32_t frame) {
  std::vector<glm::dmat4> local(clip.joints.size());
  for (size_t j = 0; j < clip.joints.size(); ++j) {
    const BvhJoint& joint = clip.joints[j];
    glm::dvec3 t(joint.offset[0], joint.offset[1], joint.offset[2]);
    glm::dmat3 r(1.0);
    for (size_t c = 0; c < joint.channels.size(); ++c) {
      const BvhChannel ch = joint.channels[c];
      const double v = clip.value(frame, static_cast<int32_t>(j), c);
      switch (ch) {
        case BvhChannel::Xposition:
          t.x = v;
          break;
        case BvhChannel::Yposition:
          t.y = v;
          break;
        case BvhChannel::Zposition:
          t.z = v;
          break;
        default:
          r = r * axis_rotation(ch, v);
          break;
      }
    }
    glm::dmat4 m(r);
    m[3] = glm::dvec4(t, 1.0);
    local[j] = m;
  }
  return local;
}

std::vector<glm::dmat4> global_matrices(const BvhClip& clip, int32_t frame) {
  if (frame < -1 || frame >= clip.frame_count)
    throw std::out_of_range(clip.source + ": frame " + std::to_string(frame) + " outside [-1, " +
                            std::to_string(clip.frame_count) + ")");
  std::vector<glm::dmat4> g = local_matrices(clip, frame);
  for (size_t j = 0; j < g.size(); ++j) {
    const int32_t p = clip.joints[j].parent;
    if (p >= 0) g[j] = g[static_cast<size_t>(p)] * g[j];
  }
  return g;
}

}  // namespace

int32_t BvhClip::find_joint(std::string_view name) const {
  for (size_t j = 0; j < joints.size(); ++j)
    if (joints[j].name == name) return static_cast<int32_t>(j);
  return -1;
}

double BvhClip::value(int32_t frame, int32_t joint, size_t channel) const {
  const BvhJoint& j = joints.at(static_cast<size_t>(joint));
  if (frame < 0) {
    switch (j.channels.at(channel)) {
      case BvhChannel::Xposition:
        return j.offset[0];
      case BvhChannel::Yposition:
        return j.offset[1];
      case BvhChannel::Zposition:
        return j.offset[2];
      default:
        return 0.0;
    }
  }
  return motion[static_cast<size_t>(frame) * static_cast<size_t>(channel_count) + static_cast<size_t>(j.first_channel) +
                channel];
}

BvhClip parse_bvh(std::string_view text, const std::string& source) {
  Tokens tok(text, source);
  BvhClip clip;
  clip.source = source;
  if (tok.at_end()) tok.fail("empty file (not a BVH)");
  if (tok.next() != "HIERARCHY") tok.fail("not a BVH file (it does not start with HIERARCHY)");
  for (;;) {
    const std::string_view t = tok.next();
    if (t == "ROOT") {
      parse_joint(tok, clip, -1, std::string(tok.next()), 0);
    } else if (t == "MOTION") {
      break;
    } else {
      tok.fail("expected ROOT or MOTION, found '" + std::string(t) + "'");
    }
  }
  if (clip.joints.empty()) tok.fail("no ROOT joint in the hierarchy");
  // "Frames:" and "Frame Time:" (some writers put a tab, none or several spaces after ':').
  std::string_view t = tok.next();
  if (t != "Frames:") tok.fail("expected 'Frames:', found '" + std::string(t) + "'");
  const long frames = tok.integer();
  tok.expect("Frame");
  t = tok.next();
  if (t != "Time:") tok.fail("expected 'Frame Time:', found 'Frame " + std::string(t) + "'");
  clip.frame_time_s = tok.number();
  if (!(clip.frame_time_s > 0.0)) tok.fail("frame time must be > 0");
  if (frames > 0 && clip.channel_count > 0 && static_cast<double>(frames) * clip.channel_count > 4e8)
    tok.fail("too many values (" + std::to_string(frames) + " frames)");
  clip.frame_count = static_cast<int32_t>(frames);
  const size_t total = static_cast<size_t>(frames) * static_cast<size_t>(clip.channel_count);
  clip.motion.resize(total);
  // Fast number loop (the motion section is most of the file).
  const std::string_view all = tok.text();
  size_t pos = tok.position();
  const char* base = all.data();
  for (size_t i = 0; i < total; ++i) {
    while (pos < all.size() && std::isspace(static_cast<unsigned char>(all[pos]))) ++pos;
    if (pos >= all.size()) {
      const int line = 1 + static_cast<int>(std::count(all.begin(), all.end(), '\n'));
      throw std::runtime_error(source + ":" + std::to_string(line) + ": truncated motion: expected " +
                               std::to_string(total) + " values (" + std::to_string(frames) + " frames x " +
                               std::to_string(clip.channel_count) + " channels), found " + std::to_string(i));
    }
    size_t end = pos;
    while (end < all.size() && !std::isspace(static_cast<unsigned char>(all[end]))) ++end;
    const std::string s(base + pos, end - pos);
    char* stop = nullptr;
    const double v = std::strtod(s.c_str(), &stop);
    if (stop != s.c_str() + s.size() || !std::isfinite(v) || std::abs(v) > 1e30) {
      const int line = 1 + static_cast<int>(std::count(all.begin(), all.begin() + static_cast<long>(pos), '\n'));
      throw std::runtime_error(source + ":" + std::to_string(line) + ": expected a number in frame " +
                               std::to_string(i / static_cast<size_t>(clip.channel_count)) + ", found '" + s + "'");
    }
    clip.motion[i] = static_cast<float>(v);
    pos = end;
  }
  return clip;
}

BvhClip load_bvh(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error(path + ": cannot open file");
  std::ostringstream ss;
  ss << in.rdbuf();
  if (in.bad()) throw std::runtime_error(path + ": read error");
  return parse_bvh(ss.str(), path);
}

std::vector<float> bvh_global_matrices(const BvhClip& clip, int32_t frame) {
  const std::vector<glm::dmat4> g = global_matrices(clip, frame);
  std::vector<float> out(g.size() * 16);
  for (size_t j = 0; j < g.size(); ++j) detail::store_mat4(g[j], out.data() + 16 * j);
  return out;
}

// ---- retargeting ---------------------------------------------------------------------------

namespace {

/// Canonical joints both sides are mapped to.
enum Canon : int {
  kNone = -1,
  kHips,
  kSpine1,
  kSpine2,
  kSpine3,
  kNeck,
  kNeck2,
  kHead,
  kClavicleL,
  kUpperArmL,
  kLowerArmL,
  kHandL,
  kThighL,
  kCalfL,
  kFootL,
  kToeL,
  kClavicleR,
  kUpperArmR,
  kLowerArmR,
  kHandR,
  kThighR,
  kCalfR,
  kFootR,
  kToeR,
  kCanonCount
};

/// Lower-case, without a namespace prefix ("mixamorig:", "Armature|") and without '_', '-',
/// '.', ' ' (so "upperarm_l", "UpperArm.L" and "upperarm-l" compare equal).
std::string normalise(std::string_view name) {
  const size_t colon = name.find_last_of(":|");
  if (colon != std::string_view::npos) name = name.substr(colon + 1);
  std::string s;
  for (char c : name)
    if (std::isalnum(static_cast<unsigned char>(c)))
      s.push_back(static_cast<char>(std::tolower(static_cast<unsigned char>(c))));
  return s;
}

struct Convention {
  const char* name;
  std::vector<std::pair<const char*, Canon>> names;  // normalised names
};

/// Mixamo's skeleton: a motion source (exported as BVH) and a character's skeleton alike.
Convention mixamo() {
  return {"Mixamo",
          {{"hips", kHips},
           {"spine", kSpine1},
           {"spine1", kSpine2},
           {"spine2", kSpine3},
           {"neck", kNeck},
           {"head", kHead},
           {"leftshoulder", kClavicleL},
           {"leftarm", kUpperArmL},
           {"leftforearm", kLowerArmL},
           {"lefthand", kHandL},
           {"leftupleg", kThighL},
           {"leftleg", kCalfL},
           {"leftfoot", kFootL},
           {"lefttoebase", kToeL},
           {"rightshoulder", kClavicleR},
           {"rightarm", kUpperArmR},
           {"rightforearm", kLowerArmR},
           {"righthand", kHandR},
           {"rightupleg", kThighR},
           {"rightleg", kCalfR},
           {"rightfoot", kFootR},
           {"righttoebase", kToeR}}};
}

const std::vector<Convention>& source_conventions() {
  static const std::vector<Convention> c = {
      {"cgspeed MotionBuilder", {{"hips", kHips},          {"lowerback", kSpine1},
                                 {"spine", kSpine2},       {"spine1", kSpine3},
                                 {"neck", kNeck},          {"neck1", kNeck2},
                                 {"head", kHead},          {"leftshoulder", kClavicleL},
                                 {"leftarm", kUpperArmL},  {"leftforearm", kLowerArmL},
                                 {"lefthand", kHandL},     {"leftupleg", kThighL},
                                 {"leftleg", kCalfL},      {"leftfoot", kFootL},
                                 {"lefttoebase", kToeL},   {"rightshoulder", kClavicleR},
                                 {"rightarm", kUpperArmR}, {"rightforearm", kLowerArmR},
                                 {"righthand", kHandR},    {"rightupleg", kThighR},
                                 {"rightleg", kCalfR},     {"rightfoot", kFootR},
                                 {"righttoebase", kToeR}}},
      {"Daz/Second Life",
       {{"hip", kHips},
        {"abdomen", kSpine1},
        {"chest", kSpine3},
        {"neck", kNeck},
        {"head", kHead},
        {"lcollar", kClavicleL},
        {"lshldr", kUpperArmL},
        {"lforearm", kLowerArmL},
        {"lhand", kHandL},
        {"lthigh", kThighL},
        {"lshin", kCalfL},
        {"lfoot", kFootL},
        {"rcollar", kClavicleR},
        {"rshldr", kUpperArmR},
        {"rforearm", kLowerArmR},
        {"rhand", kHandR},
        {"rthigh", kThighR},
        {"rshin", kCalfR},
        {"rfoot", kFootR}}},
      // Mixamo's skeleton exported as BVH: like cgspeed's names, but three spine joints
      // Spine, Spine1, Spine2 and no LowerBack; the file matching more names wins.
      mixamo(),
  };
  return c;
}

const std::vector<Convention>& target_conventions() {
  static const std::vector<Convention> c = {
      {"MakeHuman game_engine",
       {{"pelvis", kHips},         {"spine01", kSpine1}, {"spine02", kSpine2},      {"spine03", kSpine3},
        {"neck01", kNeck},         {"head", kHead},      {"claviclel", kClavicleL}, {"upperarml", kUpperArmL},
        {"lowerarml", kLowerArmL}, {"handl", kHandL},    {"thighl", kThighL},       {"calfl", kCalfL},
        {"footl", kFootL},         {"balll", kToeL},     {"clavicler", kClavicleR}, {"upperarmr", kUpperArmR},
        {"lowerarmr", kLowerArmR}, {"handr", kHandR},    {"thighr", kThighR},       {"calfr", kCalfR},
        {"footr", kFootR},         {"ballr", kToeR}}},
      mixamo(),
      {"CesiumMan",
       {{"skeletontorsojoint1", kHips},
        {"skeletontorsojoint2", kSpine1},
        {"torsojoint3", kSpine3},
        {"skeletonneckjoint1", kNeck},
        {"skeletonneckjoint2", kHead},
        {"skeletonarmjointl4", kUpperArmL},
        {"skeletonarmjointl3", kLowerArmL},
        {"skeletonarmjointl2", kHandL},
        {"skeletonarmjointr", kUpperArmR},
        {"skeletonarmjointr2", kLowerArmR},
        {"skeletonarmjointr3", kHandR},
        {"legjointl1", kThighL},
        {"legjointl2", kCalfL},
        {"legjointl3", kFootL},
        {"legjointl5", kToeL},
        {"legjointr1", kThighR},
        {"legjointr2", kCalfR},
        {"legjointr3", kFootR},
        {"legjointr5", kToeR}}},
  };
  return c;
}

/// The convention matching most of `names`; fills canon[i] for each name (kNone if absent).
const Convention* best_convention(const std::vector<Convention>& conventions, const std::vector<std::string>& names,
                                  std::vector<int>& canon) {
  const Convention* best = nullptr;
  size_t best_hits = 0;
  for (const Convention& c : conventions) {
    size_t hits = 0;
    for (const std::string& n : names) {
      const std::string k = normalise(n);
      for (const auto& e : c.names)
        if (k == e.first) {
          ++hits;
          break;
        }
    }
    if (hits > best_hits) {
      best_hits = hits;
      best = &c;
    }
  }
  canon.assign(names.size(), kNone);
  if (!best || best_hits < 3) return nullptr;
  for (size_t i = 0; i < names.size(); ++i) {
    const std::string k = normalise(names[i]);
    for (const auto& e : best->names)
      if (k == e.first) canon[i] = e.second;
  }
  return best;
}

glm::dquat rotation_between(const glm::dvec3& from, const glm::dvec3& to) {
  const glm::dvec3 a = glm::normalize(from), b = glm::normalize(to);
  const double d = glm::dot(a, b);
  if (d > 1.0 - 1e-12) return glm::dquat(1, 0, 0, 0);
  if (d < -1.0 + 1e-12) {  // half turn about any axis perpendicular to a
    glm::dvec3 axis = glm::cross(a, glm::dvec3(1, 0, 0));
    if (glm::length(axis) < 1e-6) axis = glm::cross(a, glm::dvec3(0, 1, 0));
    return glm::angleAxis(glm::pi<double>(), glm::normalize(axis));
  }
  const glm::dvec3 c = glm::cross(a, b);
  return glm::normalize(glm::dquat(1.0 + d, c.x, c.y, c.z));
}

glm::dmat4 bvh_to_character(bool z_up) { return z_up ? detail::gltf_to_blender_axes() : glm::dmat4(1.0); }

/// Rotation part of a (rigid) matrix, orthonormalised.
glm::dmat3 rotation_of(const glm::dmat4& m) {
  glm::dmat3 r(m);
  return glm::mat3_cast(glm::normalize(glm::quat_cast(r)));
}

double distance(const float* a, const float* b) {
  const double dx = double(a[0]) - b[0], dy = double(a[1]) - b[1], dz = double(a[2]) - b[2];
  return std::sqrt(dx * dx + dy * dy + dz * dz);
}

/// Directions (BVH space) of the bones Blender's BVH importer (io_anim_bvh, read_bvh and
/// bvh_node_dict2armature) makes for the joints, which the *_anims.glb retarget used:
///  * tail = the End Site, else the only child's head, else the mean of the children's heads;
///  * a bone shorter than 0.001 units is lengthened by its parent's (rest_head_local -
///    rest_tail_local) reversed, i.e. it continues its parent (a hand whose finger joints sit
///    on the wrist points like the forearm; Spine1 under three zero-offset joints points like
///    Spine); with no parent, or a parent of zero length too, it points up (+Y).
/// The importer's "local" tail of a joint with several children is the mean of their
/// offsets (not added to the joint's own offset); that quirk is kept.
std::vector<glm::dvec3> source_bone_directions(const BvhClip& clip, const std::vector<glm::dmat4>& rest) {
  const size_t J = clip.joints.size();
  std::vector<glm::dvec3> head_local(J), tail_local(J), dir(J);
  for (size_t j = 0; j < J; ++j) {
    const BvhJoint& jj = clip.joints[j];
    head_local[j] = glm::dvec3(jj.offset[0], jj.offset[1], jj.offset[2]);
    const glm::dvec3 head(rest[j][3]);
    glm::dvec3 tail = head;
    tail_local[j] = head_local[j];
    if (!jj.end_sites.empty()) {
      const auto& e = jj.end_sites.back();
      tail = head + glm::dvec3(e[0], e[1], e[2]);
      tail_local[j] = head_local[j] + glm::dvec3(e[0], e[1], e[2]);
    } else if (jj.children.size() == 1) {
      const auto c = static_cast<size_t>(jj.children[0]);
      tail = glm::dvec3(rest[c][3]);
      tail_local[j] =
          head_local[j] + glm::dvec3(clip.joints[c].offset[0], clip.joints[c].offset[1], clip.joints[c].offset[2]);
    } else if (!jj.children.empty()) {
      glm::dvec3 world(0.0), local(0.0);
      for (int32_t c : jj.children) {
        world += glm::dvec3(rest[static_cast<size_t>(c)][3]);
        const auto& o = clip.joints[static_cast<size_t>(c)].offset;
        local += glm::dvec3(o[0], o[1], o[2]);
      }
      tail = world / static_cast<double>(jj.children.size());
      tail_local[j] = local / static_cast<double>(jj.children.size());
    }
    dir[j] = tail - head;
  }
  for (size_t j = 0; j < J; ++j) {
    if (glm::length(dir[j]) >= 0.001) continue;
    const int32_t p = clip.joints[j].parent;
    const glm::dvec3 ofs =
        p >= 0 ? head_local[static_cast<size_t>(p)] - tail_local[static_cast<size_t>(p)] : glm::dvec3(0.0);
    dir[j] = glm::length(ofs) > 0.0 ? dir[j] - ofs : dir[j] + glm::dvec3(0.0, 1.0, 0.0);
  }
  return dir;
}

}  // namespace

int32_t BvhBoneMap::mapped_count() const {
  return static_cast<int32_t>(std::count_if(source.begin(), source.end(), [](int32_t s) { return s >= 0; }));
}

BvhBoneMap map_bvh_to_character(const BvhClip& clip, const Character& c,
                                const std::vector<std::pair<std::string, std::string>>& overrides) {
  const size_t B = c.bone_names.size();
  BvhBoneMap m;
  m.source.assign(B, -1);
  std::vector<std::string> joint_names;
  for (const BvhJoint& j : clip.joints) joint_names.push_back(j.name);
  std::vector<int> src_canon, dst_canon;
  const Convention* src = best_convention(source_conventions(), joint_names, src_canon);
  const Convention* dst = best_convention(target_conventions(), c.bone_names, dst_canon);
  if (src && dst) {
    m.source_convention = src->name;
    m.target_convention = dst->name;
    for (size_t b = 0; b < B; ++b) {
      if (dst_canon[b] == kNone) continue;
      for (size_t j = 0; j < joint_names.size(); ++j)
        if (src_canon[j] == dst_canon[b] && m.source[b] < 0) m.source[b] = static_cast<int32_t>(j);
    }
  }
  if (m.mapped_count() == 0) {
    // Same names on both sides (a character rigged with the BVH's own skeleton).
    m.source_convention = m.target_convention = "BVH names";
    for (size_t b = 0; b < B; ++b) {
      const std::string k = normalise(c.bone_names[b]);
      for (size_t j = 0; j < joint_names.size(); ++j)
        if (normalise(joint_names[j]) == k) {
          m.source[b] = static_cast<int32_t>(j);
          break;
        }
    }
    if (m.mapped_count() > 0) {
      // Canonical roles of the matched bones come from the BVH side.
      dst_canon.assign(B, kNone);
      if (src)
        for (size_t b = 0; b < B; ++b)
          if (m.source[b] >= 0) dst_canon[b] = src_canon[static_cast<size_t>(m.source[b])];
    }
  }
  for (const auto& [bone, joint] : overrides) {
    const auto it = std::find(c.bone_names.begin(), c.bone_names.end(), bone);
    if (it == c.bone_names.end()) throw std::runtime_error("bone map: the character has no bone '" + bone + "'");
    const auto b = static_cast<size_t>(it - c.bone_names.begin());
    if (joint.empty()) {
      m.source[b] = -1;
      continue;
    }
    const int32_t j = clip.find_joint(joint);
    if (j < 0) throw std::runtime_error("bone map: " + clip.source + " has no joint '" + joint + "'");
    m.source[b] = j;
    if (m.source_convention.empty()) m.source_convention = m.target_convention = "custom";
  }
  if (m.mapped_count() == 0) {
    std::string msg = "no bone of the character matches a joint of " + clip.source + " (give a bone map). Joints:";
    for (const auto& n : joint_names) msg += " " + n;
    msg += ". Bones:";
    for (const auto& n : c.bone_names) msg += " " + n;
    throw std::runtime_error(msg);
  }
  // The hips: the bone mapped to the canonical hips, else the mapped bone nearest the root
  // (fewest ancestors), driven by a BVH root if possible.
  for (size_t b = 0; b < B; ++b)
    if (m.source[b] >= 0 && dst_canon.size() == B && dst_canon[b] == kHips) m.root_bone = static_cast<int32_t>(b);
  if (m.root_bone < 0) {
    int best_depth = 1 << 30;
    for (size_t b = 0; b < B; ++b) {
      if (m.source[b] < 0) continue;
      int depth = 0;
      for (int32_t p = c.bone_parents[b]; p >= 0; p = c.bone_parents[static_cast<size_t>(p)]) ++depth;
      if (depth < best_depth) {
        best_depth = depth;
        m.root_bone = static_cast<int32_t>(b);
      }
    }
  }
  m.root_joint = m.source[static_cast<size_t>(m.root_bone)];
  return m;
}

BvhRetarget::BvhRetarget(const BvhClip& clip, const Character& c, BvhBoneMap map, const BvhRetargetOptions& options)
    : clip_(&clip), character_(&c), map_(std::move(map)), z_up_(options.character_z_up) {
  const size_t B = c.bone_names.size();
  if (map_.source.size() != B) throw std::invalid_argument("BvhRetarget: the bone map is for another character");
  for (size_t b = 0; b < B; ++b)
    if (map_.source[b] >= clip.joint_count()) throw std::invalid_argument("BvhRetarget: bone map joint out of range");
  if (map_.root_bone < 0 || map_.root_joint < 0) throw std::invalid_argument("BvhRetarget: no root bone");
  const glm::dmat4 A = bvh_to_character(z_up_);
  const glm::dmat3 A3(A);
  const std::vector<glm::dmat4> rest = global_matrices(clip, -1);
  const auto joint_pos = [&](int32_t j) { return glm::dvec3(rest[static_cast<size_t>(j)][3]); };

  // Which bone each joint drives (for directions: the joint driving b's child).
  std::vector<int32_t> bone_of_joint(clip.joints.size(), -1);
  for (size_t b = 0; b < B; ++b)
    if (map_.source[b] >= 0 && bone_of_joint[static_cast<size_t>(map_.source[b])] < 0)
      bone_of_joint[static_cast<size_t>(map_.source[b])] = static_cast<int32_t>(b);
  std::vector<std::vector<int32_t>> children(B);
  for (size_t b = 0; b < B; ++b)
    if (c.bone_parents[b] >= 0) children[static_cast<size_t>(c.bone_parents[b])].push_back(static_cast<int32_t>(b));

  const std::vector<glm::dvec3> source_dirs = source_bone_directions(clip, rest);
  // Swings S_b, parents first (bones are ordered parents first): the root bone has none, a
  // mapped bone turns its rest direction onto its joint's (Blender) bone direction, an
  // unmapped bone keeps its parent's.
  swing_.assign(B, {1, 0, 0, 0});
  for (size_t b = 0; b < B; ++b) {
    const int32_t j = map_.source[b];
    const int32_t parent = c.bone_parents[b];
    glm::dquat s(1, 0, 0, 0);
    if (static_cast<int32_t>(b) == map_.root_bone) {
      s = glm::dquat(1, 0, 0, 0);
    } else if (j >= 0) {
      const float* head = c.bone_heads.data() + 3 * b;
      const float* tail = c.bone_tails.data() + 3 * b;
      const glm::dvec3 bone_dir = glm::dvec3(tail[0], tail[1], tail[2]) - glm::dvec3(head[0], head[1], head[2]);
      if (glm::length(bone_dir) > 0.0) s = rotation_between(bone_dir, A3 * source_dirs[static_cast<size_t>(j)]);
    } else if (parent >= 0) {
      const auto& ps = swing_[static_cast<size_t>(parent)];
      s = glm::dquat(ps[0], ps[1], ps[2], ps[3]);
    }
    swing_[b] = {s.w, s.x, s.y, s.z};
  }

  // Translation scale: leg lengths, else hips-to-head heights.
  scale_ = options.translation_scale;
  if (!(scale_ > 0.0)) {
    std::vector<int> dst_canon(B, kNone), src_canon(clip.joints.size(), kNone);
    // Canonical roles through the map: a bone's role is its joint's.
    std::vector<std::string> joint_names;
    for (const BvhJoint& jj : clip.joints) joint_names.push_back(jj.name);
    best_convention(source_conventions(), joint_names, src_canon);
    for (size_t b = 0; b < B; ++b)
      if (map_.source[b] >= 0) dst_canon[b] = src_canon[static_cast<size_t>(map_.source[b])];
    const auto bone_with = [&](int canon) -> int32_t {
      for (size_t b = 0; b < B; ++b)
        if (dst_canon[b] == canon) return static_cast<int32_t>(b);
      return -1;
    };
    // The left leg's hip-to-ankle distance (thigh head to foot head), else the right's:
    // what the *_anims.glb retarget used (it reproduces their root motion to 0.01 %).
    double target = 0.0, source = 0.0;
    for (const auto& leg : {std::array<int, 2>{kThighL, kFootL}, std::array<int, 2>{kThighR, kFootR}}) {
      const int32_t t0 = bone_with(leg[0]), t1 = bone_with(leg[1]);
      if (t0 < 0 || t1 < 0 || target > 0.0) continue;
      target = distance(c.bone_heads.data() + 3 * t0, c.bone_heads.data() + 3 * t1);
      source = glm::length(joint_pos(map_.source[static_cast<size_t>(t1)]) -
                           joint_pos(map_.source[static_cast<size_t>(t0)]));
    }
    if (!(target > 0.0 && source > 0.0)) {
      const int32_t th = bone_with(kHips), tt = bone_with(kHead);
      if (th >= 0 && tt >= 0) {
        target = distance(c.bone_heads.data() + 3 * th, c.bone_heads.data() + 3 * tt);
        source = glm::length(joint_pos(map_.source[static_cast<size_t>(tt)]) -
                             joint_pos(map_.source[static_cast<size_t>(th)]));
      }
    }
    scale_ = target > 0.0 && source > 0.0 ? target / source : 1.0;
  }

  // The root's rest position in BVH space: its OFFSET (what the *_anims.glb retarget used).
  // A root OFFSET of (0,0,0) (cgspeed's 01_xx originals, Daz) would lift the character by the
  // whole hip height; there the rest height is the root's height above the lowest rest joint,
  // plus the lowest any joint gets in the clip (the floor).
  const BvhJoint& root = clip.joints[static_cast<size_t>(map_.root_joint)];
  const glm::dvec3 root_rest = joint_pos(map_.root_joint);
  root_rest_ = {root_rest.x, root_rest.y, root_rest.z};
  if (!options.root_rest_from_offset && root.parent < 0 && root.offset[0] == 0.0 && root.offset[1] == 0.0 &&
      root.offset[2] == 0.0 && clip.frame_count > 0) {
    double lowest_rest = 0.0;
    for (const glm::dmat4& g : rest) lowest_rest = std::min(lowest_rest, g[3][1]);
    double floor = std::numeric_limits<double>::infinity();
    const int32_t step = std::max(1, clip.frame_count / 200);
    for (int32_t f = 0; f < clip.frame_count; f += step)
      for (const glm::dmat4& g : global_matrices(clip, f)) floor = std::min(floor, g[3][1]);
    root_rest_[1] = root_rest.y - lowest_rest + floor;
  }
}

std::vector<float> BvhRetarget::pose(int32_t frame) const {
  const BvhClip& clip = *clip_;
  const Character& c = *character_;
  const size_t B = c.bone_names.size();
  const glm::dmat4 A = bvh_to_character(z_up_);
  const glm::dmat3 A3(A), Ai3 = glm::transpose(A3);
  const std::vector<glm::dmat4> g = global_matrices(clip, frame);
  const std::vector<glm::dmat4> g0 = global_matrices(clip, -1);
  std::vector<glm::dmat4> rest(B), posed(B);
  for (size_t b = 0; b < B; ++b) rest[b] = detail::load_mat4(c.bone_rest.data() + 16 * b);
  for (size_t b = 0; b < B; ++b) {
    const int32_t parent = c.bone_parents[b];
    const int32_t j = map_.source[b];
    // Head: carried by the parent (rest offset in the parent's frame), or the root motion.
    glm::dvec3 head(rest[b][3]);
    if (parent >= 0)
      head =
          glm::dvec3(posed[static_cast<size_t>(parent)] * glm::inverse(rest[static_cast<size_t>(parent)]) * rest[b][3]);
    if (static_cast<int32_t>(b) == map_.root_bone) {
      const glm::dvec3 p(g[static_cast<size_t>(j)][3]);
      const glm::dvec3 d = p - glm::dvec3(root_rest_[0], root_rest_[1], root_rest_[2]);
      head = glm::dvec3(rest[b][3]) + scale_ * (A3 * d);
    }
    glm::dmat3 r;
    if (j >= 0) {
      const glm::dmat3 delta =
          A3 * rotation_of(g[static_cast<size_t>(j)]) * glm::transpose(rotation_of(g0[static_cast<size_t>(j)])) * Ai3;
      const auto& s = swing_[b];
      r = delta * glm::mat3_cast(glm::dquat(s[0], s[1], s[2], s[3])) * rotation_of(rest[b]);
    } else if (parent >= 0) {
      r = glm::dmat3(posed[static_cast<size_t>(parent)] * glm::inverse(rest[static_cast<size_t>(parent)]) * rest[b]);
    } else {
      r = glm::dmat3(rest[b]);
    }
    glm::dmat4 m(r);
    m[3] = glm::dvec4(head, 1.0);
    posed[b] = m;
  }
  std::vector<float> out(16 * B);
  for (size_t b = 0; b < B; ++b) detail::store_mat4(posed[b], out.data() + 16 * b);
  return out;
}

}  // namespace sd::io
