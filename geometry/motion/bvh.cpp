// SPDX-License-Identifier: Apache-2.0
#include "bvh.h"

#include <algorithm>
#include <array>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <unordered_set>

#include "vfit/geometry/mesh/atomic_write.h"
#include "vfit/kernels/error.h"

namespace vfit {

namespace {

constexpr std::size_t MAX_JOINTS = 100000;
constexpr int MAX_DEPTH = 1000;
constexpr std::size_t MAX_FRAMES = 10000000;
constexpr std::size_t MAX_VALUES = 1000000000;
constexpr double MAX_FRAME_TIME = 10.0;

constexpr std::array<std::string_view, 6> CHANNEL_NAMES = {"Xposition", "Yposition", "Zposition",
                                                           "Xrotation", "Yrotation", "Zrotation"};

bool is_position(BvhChannel c) { return static_cast<int>(c) < 3; }
int axis_of(BvhChannel c) { return static_cast<int>(c) % 3; }

bool is_space(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\f' || c == '\v'; }

// Words of the text with their line numbers; lines are LF-separated (a CR before it is space).
class Tokens {
public:
  Tokens(std::string_view text, const std::string& source) : m_text(text), m_source(source) {}

  // The next word, or empty at the end of the text.
  std::string_view next() {
    skip_space();
    std::size_t j = m_at;
    while (j < m_text.size() && !is_space(m_text[j]) && m_text[j] != '\n')
      ++j;
    const std::string_view word = m_text.substr(m_at, j - m_at);
    m_at = j;
    return word;
  }
  // The next word, which must be there.
  std::string_view expect_word(std::string_view what) {
    const std::string_view w = next();
    if (w.empty()) fail("unexpected end of file: expected " + std::string(what));
    return w;
  }
  void expect(std::string_view keyword) {
    const std::string_view w = next();
    if (w != keyword)
      fail("expected '" + std::string(keyword) + "', found " + (w.empty() ? "the end of the file" : quoted(w)));
  }
  double number(std::string_view what) {
    const std::string_view w = expect_word(what);
    double v = 0;
    if (!parse_number(w, v)) fail(std::string(what) + ": " + quoted(w) + " is not a number");
    if (!std::isfinite(v)) fail(std::string(what) + ": " + quoted(w) + " is not finite");
    return v;
  }
  // The rest of the current line (after the current position), and moves to the next line.
  std::string_view rest_of_line() {
    const std::size_t end = std::min(m_text.find('\n', m_at), m_text.size());
    const std::string_view line = m_text.substr(m_at, end - m_at);
    m_at = end;
    if (m_at < m_text.size()) {
      ++m_at;
      ++m_line;
    }
    return line;
  }
  bool at_end() {
    skip_space();
    return m_at >= m_text.size();
  }
  std::int64_t line() const { return m_line; }
  [[noreturn]] void fail(const std::string& what) const { throw Error(m_source, m_line, what); }

  static bool parse_number(std::string_view w, double& v) {
    if (!w.empty() && w.front() == '+') w.remove_prefix(1);
    const auto [end, ec] = std::from_chars(w.data(), w.data() + w.size(), v);
    return ec == std::errc() && end == w.data() + w.size();
  }
  static std::string quoted(std::string_view w) {
    return "'" + std::string(w.substr(0, 40)) + (w.size() > 40 ? "...'" : "'");
  }

private:
  void skip_space() {
    while (m_at < m_text.size() && (is_space(m_text[m_at]) || m_text[m_at] == '\n')) {
      if (m_text[m_at] == '\n') ++m_line;
      ++m_at;
    }
  }

  std::string_view m_text;
  const std::string& m_source;
  std::size_t m_at = 0;
  std::int64_t m_line = 1;
};

Eigen::Vector3d read_offset(Tokens& t) {
  t.expect("OFFSET");
  Eigen::Vector3d o;
  for (int k = 0; k < 3; ++k)
    o[k] = t.number("OFFSET");
  return o;
}

// One joint's block after its name: "{ OFFSET ... CHANNELS ... (JOINT ... | End Site ...)* }".
void read_joint(Tokens& t, BvhMotion& m, std::unordered_set<std::string>& names, std::string name, std::int32_t parent,
                int depth) {
  if (depth > MAX_DEPTH) t.fail("the hierarchy nests deeper than " + std::to_string(MAX_DEPTH) + " joints");
  if (m.joints.size() >= MAX_JOINTS) t.fail("more than " + std::to_string(MAX_JOINTS) + " joints");
  if (!names.insert(name).second) t.fail("a second joint named '" + name + "'");
  const auto index = static_cast<std::int32_t>(m.joints.size());
  m.joints.push_back({});
  m.joints.back().name = std::move(name);
  m.joints.back().parent = parent;
  t.expect("{");
  m.joints[std::size_t(index)].offset = read_offset(t);
  t.expect("CHANNELS");
  const double count = t.number("CHANNELS count");
  if (count != std::floor(count) || count < 0 || count > 6)
    t.fail("CHANNELS count must be a whole number from 0 to 6, got " + std::to_string(count));
  BvhJoint& j = m.joints[std::size_t(index)];
  j.first_column = m.columns;
  for (int c = 0; c < int(count); ++c) {
    const std::string_view w = t.expect_word("a channel name");
    const auto it = std::find(CHANNEL_NAMES.begin(), CHANNEL_NAMES.end(), w);
    if (it == CHANNEL_NAMES.end())
      t.fail("unknown channel " + Tokens::quoted(w) +
             " (expected Xposition, Yposition, Zposition, Xrotation, "
             "Yrotation or Zrotation)");
    const auto channel = static_cast<BvhChannel>(it - CHANNEL_NAMES.begin());
    if (std::find(j.channels.begin(), j.channels.end(), channel) != j.channels.end())
      t.fail("channel " + Tokens::quoted(w) + " listed twice for joint '" + j.name + "'");
    j.channels.push_back(channel);
  }
  m.columns += j.channels.size();
  for (;;) {
    const std::string_view w = t.expect_word("JOINT, End Site or '}'");
    if (w == "}") return;
    if (w == "JOINT") {
      const std::string child(t.expect_word("a joint name"));
      read_joint(t, m, names, child, index, depth + 1);
    } else if (w == "End") {
      t.expect("Site");
      if (m.joints.size() >= MAX_JOINTS) t.fail("more than " + std::to_string(MAX_JOINTS) + " joints");
      BvhJoint end;
      end.name = m.joints[std::size_t(index)].name + "/End Site";
      end.parent = index;
      end.end_site = true;
      end.first_column = m.columns;
      t.expect("{");
      end.offset = read_offset(t);
      t.expect("}");
      m.joints.push_back(std::move(end));
    } else {
      t.fail("expected JOINT, End Site or '}', found " + Tokens::quoted(w));
    }
  }
}

// Non-root position channels: absolute when their mean over the frames lies nearer the OFFSET
// than zero (see BvhJoint::absolute_position).
void decide_position_channels(BvhMotion& m) {
  const std::size_t frames = m.frame_count();
  for (std::size_t j = 0; j < m.joints.size(); ++j) {
    BvhJoint& joint = m.joints[j];
    if (joint.parent < 0) {
      joint.absolute_position = true;
      continue;
    }
    Eigen::Vector3d mean = Eigen::Vector3d::Zero(), offset = Eigen::Vector3d::Zero();
    bool any = false;
    for (std::size_t c = 0; c < joint.channels.size(); ++c) {
      if (!is_position(joint.channels[c])) continue;
      any = true;
      const int a = axis_of(joint.channels[c]);
      double sum = 0;
      for (std::size_t f = 0; f < frames; ++f)
        sum += m.frame(f)[joint.first_column + c];
      mean[a] = sum / double(frames);
      offset[a] = joint.offset[a];
    }
    joint.absolute_position = any && (mean - offset).norm() < mean.norm();
  }
}

Eigen::Matrix3d axis_rotation(int axis, double degrees) {
  return Eigen::AngleAxisd(degrees * std::numbers::pi / 180.0, Eigen::Vector3d::Unit(axis)).toRotationMatrix();
}

UpAxis snap_to_axis(const Eigen::Vector3d& d) {
  Eigen::Index k = 0;
  d.cwiseAbs().maxCoeff(&k);
  const bool positive = d[k] >= 0;
  switch (k) {
  case 0: return positive ? UpAxis::POS_X : UpAxis::NEG_X;
  case 1: return positive ? UpAxis::POS_Y : UpAxis::NEG_Y;
  default: return positive ? UpAxis::POS_Z : UpAxis::NEG_Z;
  }
}

std::string lower(std::string_view s) {
  std::string out(s);
  for (char& c : out)
    c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return out;
}

void append_number(std::string& out, double v) {
  char buffer[32];
  const auto [end, ec] = std::to_chars(buffer, buffer + sizeof buffer, v);
  out.append(buffer, ec == std::errc() ? end : buffer);
}

void write_joint(const BvhMotion& m, const std::vector<std::vector<std::size_t>>& children, std::size_t j, int depth,
                 std::string& out) {
  const BvhJoint& joint = m.joints[j];
  const std::string indent(std::size_t(depth), '\t');
  if (joint.end_site) {
    out += indent + "End Site\n" + indent + "{\n" + indent + "\tOFFSET";
  } else {
    out += indent + (joint.parent < 0 ? "ROOT " : "JOINT ") + joint.name + "\n" + indent + "{\n" + indent + "\tOFFSET";
  }
  for (int k = 0; k < 3; ++k) {
    out += ' ';
    append_number(out, joint.offset[k]);
  }
  out += '\n';
  if (!joint.end_site) {
    out += indent + "\tCHANNELS " + std::to_string(joint.channels.size());
    for (BvhChannel c : joint.channels)
      out += " " + std::string(bvh_channel_name(c));
    out += '\n';
    for (const std::size_t k : children[j])
      write_joint(m, children, k, depth + 1, out);
  }
  out += indent + "}\n";
}

} // namespace

std::string_view bvh_channel_name(BvhChannel channel) { return CHANNEL_NAMES[static_cast<std::size_t>(channel)]; }

std::int32_t BvhMotion::find(std::string_view name) const {
  for (std::size_t j = 0; j < joints.size(); ++j)
    if (joints[j].name == name) return std::int32_t(j);
  return -1;
}

BvhMotion parse_bvh(std::string_view text, const std::string& source) {
  BvhMotion m;
  m.source = source;
  Tokens t(text, source);
  t.expect("HIERARCHY");
  t.expect("ROOT");
  std::unordered_set<std::string> names;
  read_joint(t, m, names, std::string(t.expect_word("the root's name")), -1, 0);
  const std::string_view after = t.expect_word("MOTION");
  if (after == "ROOT") t.fail("a second ROOT: one skeleton per file is supported");
  if (after != "MOTION") t.fail("expected 'MOTION', found " + Tokens::quoted(after));
  t.expect("Frames:");
  const double frames = t.number("Frames");
  if (frames != std::floor(frames) || frames < 1 || frames > double(MAX_FRAMES))
    t.fail("Frames: expected a whole number from 1 to " + std::to_string(MAX_FRAMES) + ", got " +
           std::to_string(frames));
  const auto frame_count = static_cast<std::size_t>(frames);
  if (m.columns > 0 && frame_count > MAX_VALUES / m.columns)
    t.fail(std::to_string(frame_count) + " frames of " + std::to_string(m.columns) + " channels: more than " +
           std::to_string(MAX_VALUES) + " values");
  t.expect("Frame");
  t.expect("Time:");
  m.frame_time = t.number("Frame Time");
  if (!(m.frame_time > 0) || m.frame_time > MAX_FRAME_TIME)
    t.fail("Frame Time: expected seconds in (0, " + std::to_string(int(MAX_FRAME_TIME)) + "], got " +
           std::to_string(m.frame_time));
  if (const std::string_view rest = t.rest_of_line(); rest.find_first_not_of(" \t\r\f\v") != std::string_view::npos)
    throw Error(source, t.line() - 1, "unexpected " + Tokens::quoted(rest) + " after the frame time");
  m.values.reserve(frame_count * m.columns);
  std::size_t read = 0;
  while (read < frame_count) {
    if (t.at_end())
      t.fail("the file ends after " + std::to_string(read) + " of the " + std::to_string(frame_count) +
             " frames 'Frames:' states");
    const std::int64_t line = t.line();
    const std::string_view row = t.rest_of_line();
    std::size_t i = 0, count = 0;
    while (i < row.size()) {
      while (i < row.size() && is_space(row[i]))
        ++i;
      if (i >= row.size()) break;
      std::size_t j = i;
      while (j < row.size() && !is_space(row[j]))
        ++j;
      const std::string_view w = row.substr(i, j - i);
      double v = 0;
      if (!Tokens::parse_number(w, v) || !std::isfinite(v))
        throw Error(source, line,
                    "frame " + std::to_string(read + 1) + ", value " + std::to_string(count + 1) + ": " +
                        Tokens::quoted(w) + " is not a finite number");
      if (++count > m.columns) break;
      m.values.push_back(v);
      i = j;
    }
    if (count != m.columns)
      throw Error(source, line,
                  "frame " + std::to_string(read + 1) + " has " + (count > m.columns ? "more than " : "") +
                      std::to_string(count > m.columns ? m.columns : count) + " values; the hierarchy has " +
                      std::to_string(m.columns) + " channels");
    ++read;
  }
  if (!t.at_end()) t.fail("more frame lines than the " + std::to_string(frame_count) + " 'Frames:' states");
  decide_position_channels(m);
  const std::vector<Eigen::Vector3d> rest = bvh_rest_positions(m);
  m.up = bvh_infer_up(m, rest);
  bvh_infer_unit(m, rest, m.up);
  return m;
}

BvhMotion read_bvh(const std::filesystem::path& path) { return parse_bvh(read_file_bytes(path), path.string()); }

std::string bvh_text(const BvhMotion& m) {
  std::string out = "HIERARCHY\n";
  std::vector<std::vector<std::size_t>> children(m.joints.size());
  for (std::size_t j = 1; j < m.joints.size(); ++j)
    children[std::size_t(m.joints[j].parent)].push_back(j);
  if (!m.joints.empty()) write_joint(m, children, 0, 0, out);
  out += "MOTION\nFrames: " + std::to_string(m.frame_count()) + "\nFrame Time: ";
  append_number(out, m.frame_time);
  out += '\n';
  for (std::size_t f = 0; f < m.frame_count(); ++f) {
    for (std::size_t c = 0; c < m.columns; ++c) {
      if (c > 0) out += ' ';
      append_number(out, m.frame(f)[c]);
    }
    out += '\n';
  }
  return out;
}

Eigen::Isometry3d bvh_local_transform(const BvhMotion& m, std::size_t j, std::size_t f) {
  const BvhJoint& joint = m.joints[j];
  Eigen::Vector3d translation = joint.offset;
  Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();
  const double* values = f < m.frame_count() ? m.frame(f) + joint.first_column : nullptr;
  for (std::size_t c = 0; c < joint.channels.size() && values; ++c) {
    const BvhChannel ch = joint.channels[c];
    if (is_position(ch)) {
      const int a = axis_of(ch);
      translation[a] = joint.absolute_position ? values[c] : joint.offset[a] + values[c];
    } else {
      rotation = rotation * axis_rotation(axis_of(ch), values[c]);
    }
  }
  Eigen::Isometry3d local = Eigen::Isometry3d::Identity();
  local.linear() = rotation;
  local.translation() = translation;
  return local;
}

std::vector<Eigen::Isometry3d> bvh_world_transforms(const BvhMotion& m, std::size_t f) {
  std::vector<Eigen::Isometry3d> world(m.joints.size());
  for (std::size_t j = 0; j < m.joints.size(); ++j) {
    const Eigen::Isometry3d local = bvh_local_transform(m, j, f);
    world[j] = m.joints[j].parent < 0 ? local : world[std::size_t(m.joints[j].parent)] * local;
  }
  return world;
}

std::vector<Eigen::Vector3d> bvh_rest_positions(const BvhMotion& m) {
  std::vector<Eigen::Vector3d> rest(m.joints.size());
  for (std::size_t j = 0; j < m.joints.size(); ++j)
    rest[j] = m.joints[j].parent < 0 ? m.joints[j].offset
                                     : Eigen::Vector3d(rest[std::size_t(m.joints[j].parent)] + m.joints[j].offset);
  return rest;
}

UpAxis bvh_infer_up(const BvhMotion& m, const std::vector<Eigen::Vector3d>& rest) {
  if (m.joints.empty()) return UpAxis::POS_Y;
  const Eigen::Vector3d root = rest[0];
  for (std::size_t j = 0; j < m.joints.size(); ++j)
    if (!m.joints[j].end_site && lower(m.joints[j].name).find("head") != std::string::npos &&
        (rest[j] - root).norm() > 0)
      return snap_to_axis(rest[j] - root);
  // The first joint with three or more children (the hips): its two largest subtrees are the
  // legs, whose farthest end sites (the feet) lie below it.
  std::vector<std::vector<std::size_t>> children(m.joints.size());
  for (std::size_t j = 1; j < m.joints.size(); ++j)
    children[std::size_t(m.joints[j].parent)].push_back(j);
  std::vector<std::size_t> size(m.joints.size(), 1);
  for (std::size_t j = m.joints.size(); j-- > 1;)
    size[std::size_t(m.joints[j].parent)] += size[j];
  std::size_t hub = 0;
  while (children[hub].size() == 1)
    hub = children[hub].front();
  if (children[hub].size() < 2) return UpAxis::POS_Y;
  // Each branch's farthest joint from the hub; the legs are the pair most nearly mirror images
  // (equal lengths, their difference normal to their sum).
  std::vector<Eigen::Vector3d> reach;
  for (const std::size_t branch : children[hub]) {
    std::size_t farthest = branch;
    for (std::size_t j = branch; j < branch + size[branch]; ++j)
      if ((rest[j] - rest[hub]).norm() > (rest[farthest] - rest[hub]).norm()) farthest = j;
    reach.push_back(rest[farthest] - rest[hub]);
  }
  double best = INFINITY;
  Eigen::Vector3d feet = Eigen::Vector3d::Zero();
  for (std::size_t a = 0; a < reach.size(); ++a)
    for (std::size_t b = a + 1; b < reach.size(); ++b) {
      const double la = reach[a].norm(), lb = reach[b].norm();
      const Eigen::Vector3d sum = reach[a] + reach[b], difference = reach[a] - reach[b];
      if (la == 0 || lb == 0 || sum.norm() == 0) continue;
      const double cosine =
          difference.norm() > 0 ? std::abs(sum.dot(difference)) / (sum.norm() * difference.norm()) : 0;
      const double score = std::abs(la - lb) / std::max(la, lb) + cosine;
      if (score < best) {
        best = score;
        feet = sum;
      }
    }
  return feet.norm() > 0 ? snap_to_axis(-feet) : UpAxis::POS_Y;
}

void bvh_infer_unit(BvhMotion& m, const std::vector<Eigen::Vector3d>& rest, UpAxis up) {
  const std::array<double, 3> u = up_axis_vector(up);
  const Eigen::Vector3d axis(u[0], u[1], u[2]);
  double lo = INFINITY, hi = -INFINITY;
  for (const Eigen::Vector3d& p : rest) {
    lo = std::min(lo, p.dot(axis));
    hi = std::max(hi, p.dot(axis));
  }
  const double height = hi - lo;
  if (!(height > 0) || !std::isfinite(height))
    throw Error(m.source, 0, "the skeleton has no height at rest: cannot infer its length unit");
  const std::pair<const char*, double> units[] = {{"m", 1.0},    {"dm", 0.1},      {"cm", 0.01},
                                                  {"mm", 0.001}, {"inch", 0.0254}, {"foot", 0.3048}};
  for (const auto& [name, metres] : units)
    if (height * metres >= 1.4 && height * metres <= 2.1) {
      m.unit = name;
      m.metres_per_unit = metres;
      return;
    }
  m.unit = "scaled";
  m.metres_per_unit = 1.7 / height;
}

} // namespace vfit
