// SPDX-License-Identifier: Apache-2.0
#include "test_support.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <map>
#include <random>
#include <sstream>
#include <stdexcept>

#include <fcntl.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include "vfit/geometry/body/mannequin.h"

extern char** environ;

namespace vfit::test {

const Body& mannequin(RestPose pose, std::size_t vertices) {
  static std::map<std::pair<RestPose, std::size_t>, Body> cache;
  const auto key = std::make_pair(pose, vertices);
  if (auto it = cache.find(key); it != cache.end()) return it->second;
  MannequinOptions o;
  o.pose = pose;
  o.target_vertices = vertices;
  return cache.emplace(key, make_mannequin(o)).first->second;
}

TempDir::TempDir() {
  std::random_device rd;
  auto base = std::filesystem::temp_directory_path();
  for (int attempt = 0; attempt < 100; ++attempt) {
    auto p = base / ("vfit_test_" + std::to_string(rd()));
    if (std::filesystem::create_directory(p)) {
      m_path = p;
      return;
    }
  }
  throw std::runtime_error("cannot create a temporary folder");
}

TempDir::~TempDir() {
  std::error_code ec;
  std::filesystem::remove_all(m_path, ec);
}

void write_file(const std::filesystem::path& path, const std::string& bytes) {
  std::ofstream f(path, std::ios::binary);
  f.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  if (!f) throw std::runtime_error("cannot write " + path.string());
}

std::string read_file(const std::filesystem::path& path) {
  std::ifstream f(path, std::ios::binary);
  if (!f) throw std::runtime_error("cannot read " + path.string());
  std::ostringstream s;
  s << f.rdbuf();
  return s.str();
}

CliResult run_cli(const std::vector<std::string>& args) {
  TempDir tmp;
  const auto out_path = tmp / "stdout", err_path = tmp / "stderr";
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, 0, "/dev/null", O_RDONLY, 0);
  posix_spawn_file_actions_addopen(&actions, 1, out_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  posix_spawn_file_actions_addopen(&actions, 2, err_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  std::vector<std::string> all{VFIT_CLI_PATH};
  all.insert(all.end(), args.begin(), args.end());
  std::vector<char*> argv;
  for (auto& a : all)
    argv.push_back(a.data());
  argv.push_back(nullptr);
  pid_t pid = 0;
  int rc = posix_spawn(&pid, VFIT_CLI_PATH, &actions, nullptr, argv.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  if (rc != 0) throw std::runtime_error(std::string("cannot start ") + VFIT_CLI_PATH);
  int status = 0;
  waitpid(pid, &status, 0);
  CliResult r;
  r.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
  r.out = read_file(out_path);
  r.err = read_file(err_path);
  return r;
}

std::optional<std::string> gltf_validator_report(const std::filesystem::path& file) {
  const std::filesystem::path modules = std::filesystem::path(VFIT_SOURCE_DIR) / "build" / "npm" / "node_modules";
  const char* node = "/usr/bin/node";
  std::error_code ec;
  if (!std::filesystem::exists(modules / "gltf-validator", ec) || !std::filesystem::exists(node, ec))
    return std::nullopt;
  TempDir tmp;
  const auto out_path = tmp / "stdout";
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, 1, out_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  std::string script = (std::filesystem::path(VFIT_SOURCE_DIR) / "tools" / "validate_gltf.cjs").string();
  std::string target = file.string();
  std::string node_arg = node;
  std::vector<char*> argv{node_arg.data(), script.data(), target.data(), nullptr};
  std::string node_path = "NODE_PATH=" + modules.string();
  std::vector<char*> env{node_path.data(), nullptr};
  pid_t pid = 0;
  const int rc = posix_spawn(&pid, node, &actions, nullptr, argv.data(), env.data());
  posix_spawn_file_actions_destroy(&actions);
  if (rc != 0) return std::nullopt;
  int status = 0;
  waitpid(pid, &status, 0);
  if (!WIFEXITED(status) || WEXITSTATUS(status) == 2) return std::nullopt;
  return read_file(out_path);
}

std::optional<std::filesystem::path> corpus_dir() {
  std::filesystem::path p = VFIT_CORPUS_DIR;
  if (const char* env = std::getenv("VFIT_CORPUS"); env && *env) p = env;
  std::error_code ec;
  if (std::filesystem::is_directory(p, ec)) return p;
  return std::nullopt;
}

std::vector<std::filesystem::path> files_with_extensions(const std::filesystem::path& dir,
                                                         const std::vector<std::string>& extensions) {
  std::vector<std::filesystem::path> out;
  for (const auto& e : std::filesystem::recursive_directory_iterator(dir)) {
    if (!e.is_regular_file()) continue;
    std::string ext = e.path().extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return std::tolower(c); });
    if (std::find(extensions.begin(), extensions.end(), ext) != extensions.end()) out.push_back(e.path());
  }
  std::sort(out.begin(), out.end());
  return out;
}

Mesh unit_square() {
  Mesh m;
  m.positions = {0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0};
  m.triangles = {0, 1, 2, 0, 2, 3};
  m.uvs = {0, 0, 1, 0, 1, 1, 0, 1};
  m.uv_triangles = {0, 1, 2, 0, 2, 3};
  return m;
}

Mesh random_fan(int rim, std::mt19937& rng) {
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  Mesh fan;
  fan.positions = {0.0f, 0.0f, 0.0f};
  for (int k = 0; k < rim; ++k) {
    const float a = 2.0f * 3.14159265f * float(k) / float(rim), r = 0.3f + 0.05f * u(rng);
    fan.positions.insert(fan.positions.end(), {r * std::cos(a), 0.02f * u(rng), r * std::sin(a)});
    fan.triangles.insert(fan.triangles.end(), {0, 1 + k, 1 + (k + 1) % rim});
  }
  return fan;
}

double mean_edge_length_change(const Mesh& before, const Mesh& after) {
  double sum = 0;
  std::size_t n = 0;
  for (std::size_t f = 0; f < before.face_count(); ++f)
    for (int k = 0; k < 3; ++k) {
      const std::size_t u = before.triangles[3 * f + k], v = before.triangles[3 * f + (k + 1) % 3];
      auto len = [&](const Mesh& m) {
        double s2 = 0;
        for (int c = 0; c < 3; ++c)
          s2 += std::pow(double(m.positions[3 * u + c]) - m.positions[3 * v + c], 2);
        return std::sqrt(s2);
      };
      sum += std::abs(len(after) / len(before) - 1.0);
      ++n;
    }
  return n ? sum / double(n) : 0.0;
}

Mesh octahedron() {
  Mesh m;
  m.positions = {1, 0, 0, -1, 0, 0, 0, 1, 0, 0, -1, 0, 0, 0, 1, 0, 0, -1};
  // +x=0 -x=1 +y=2 -y=3 +z=4 -z=5; each face CCW seen from outside.
  m.triangles = {0, 2, 4, 2, 1, 4, 1, 3, 4, 3, 0, 4, 2, 0, 5, 1, 2, 5, 3, 1, 5, 0, 3, 5};
  return m;
}

std::optional<GarmentType> corpus_garment_type(const std::string& name, bool* known) {
  auto has = [&](const char* part) { return name.find(part) != std::string::npos; };
  if (known) *known = true;
  if (has("collar") || has("inner_shirt")) return std::nullopt;
  if (has("longsleeve") || has("blazer") || has("jacket")) return GarmentType::LONG_SLEEVE;
  if (has("tshirt") || has("crop_top")) return GarmentType::TEE;
  if (has("shirt")) return GarmentType::LONG_SLEEVE;
  // Overalls: full-length legs under a bib, which stays torso.
  if (has("jeans") || has("trousers") || has("leggings") || has("overalls")) return GarmentType::TROUSERS;
  if (has("shorts")) return GarmentType::SHORTS;
  if (has("skirt")) return GarmentType::SKIRT;
  if (known) *known = false;
  return std::nullopt;
}

std::string glb_json_text(const std::string& glb) {
  std::uint32_t length = 0;
  if (glb.size() >= 20) std::memcpy(&length, glb.data() + 12, 4);
  return glb.substr(std::min<std::size_t>(20, glb.size()), length);
}

} // namespace vfit::test
