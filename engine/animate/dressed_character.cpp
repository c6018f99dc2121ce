// SPDX-License-Identifier: Apache-2.0
#include "dressed_character.h"

#include <algorithm>
#include <chrono>
#include <cmath>

#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include "vfit/engine/dress/dresser.h"
#include "vfit/engine/fit/dressing_order.h"
#include "vfit/kernels/error.h"

namespace vfit {

namespace {

using Clock = std::chrono::steady_clock;
double ms_since(Clock::time_point t) { return std::chrono::duration<double, std::milli>(Clock::now() - t).count(); }

// The fit's layering constants: the gap kept outside an inner garment (seed 001 eq. 7's k) and
// how far a layer point may be from a garment vertex and still count.
constexpr double LAYER_CLEARANCE = 0.003, LAYER_REACH = 0.05;

} // namespace

void FrameReport::add(const FrameReport& frame) {
  lbs_ms += frame.lbs_ms;
  physics_ms += frame.physics_ms;
  blend_ms += frame.blend_ms;
  cleanup_ms += frame.cleanup_ms;
  layering_ms += frame.layering_ms;
  total_ms += frame.total_ms;
  restarted = restarted || frame.restarted;
  diverged += frame.diverged;
  solver_iterations += frame.solver_iterations;
  contacts += frame.contacts;
  non_finite += frame.non_finite;
  body_pushed += frame.body_pushed;
  crossings_pushed += frame.crossings_pushed;
  layer_pushed += frame.layer_pushed;
  left_inside_1mm += frame.left_inside_1mm;
  left_crossing += frame.left_crossing;
}

void FrameReport::add(const FrameCleanupCounts& garment) {
  body_pushed += garment.body_pushed;
  crossings_pushed += garment.crossings_pushed;
  layer_pushed += garment.layer_pushed;
  left_inside_1mm += garment.left_inside_1mm;
  left_crossing += garment.left_crossing;
  cleanup_ms += garment.body_ms;
  layering_ms += garment.layering_ms;
}

struct DressedCharacter::Arena {
  tbb::task_arena arena;
  explicit Arena(int threads) : arena(threads > 0 ? threads : tbb::task_arena::automatic) {}
};

ClothOptions AnimationOptions::default_cloth() {
  ClothOptions o;
  // Two implicit steps per 30 fps frame. The skinning carries the cloth over the body, so
  // friction against the (carried, resting) body would hold particles where the skinning put
  // them while their neighbours move on. Mean edge strain |l/L − 1| on the demo walk
  // (docs/benchmarks.md): skinning 3.3 %; cloth with one step per frame 4.8 %, with two 2.0 %,
  // with two and μ = 0.3 5.7 %.
  o.implicit_step = 1.0 / 60.0;
  o.contact_friction = 0.0f;
  // The skinning carries the cloth along, so a particle is rarely far inside the body: the
  // contacts search 2 cm (the clean-up, 5 cm, catches anything deeper), which saves a few
  // milliseconds of queries per frame and leaves the demo walk's strain and contacts unchanged.
  o.contact_search_radius = 0.02f;
  // The tethers bound how far a particle can go; a contact that moves one across a limb (a
  // pinched armpit in the skinned garment) stretches its springs far past the fit's runaway
  // threshold for a step without any runaway.
  o.max_stretch = 100;
  return o;
}

DressedCharacter::DressedCharacter(const Body& body, const std::vector<FittedGarment>& garments,
                                   const AnimationOptions& options)
    : m_options(options), m_body(body), m_body_positions(body.mesh.positions),
      m_arena(std::make_unique<Arena>(options.threads)) {
  if (options.threads < 0) throw Error("animation: threads must be ≥ 0 (0: every core)");
  m_transforms.fill(Eigen::Isometry3d::Identity());
  if (!(options.max_physical_weight >= 0 && options.max_physical_weight <= 1))
    throw Error("animation: max_physical_weight must lie in [0, 1]");
  if (!(options.cut_speed > 0)) throw Error("animation: cut_speed must be > 0 m/s");
  if (!(options.inertia >= 0 && options.inertia <= 1)) throw Error("animation: inertia must lie in [0, 1]");
  validate_skin_weights(m_body.weights, m_body.mesh.vertex_count(), "dressed character: the body's weights");
  std::vector<const Mesh*> meshes;
  for (const FittedGarment& g : garments)
    meshes.push_back(&g.mesh);
  m_cleanup = std::make_unique<FrameCleanup>(m_body.mesh, meshes, options.cleanup);
  const double hips = 0.5 * (m_body.joints(idx(Joint::LEFT_HIP), 1) + m_body.joints(idx(Joint::RIGHT_HIP), 1));
  for (const FittedGarment& g : garments) {
    Layer layer;
    layer.name = g.name;
    layer.type = g.segmentation.type;
    layer.rest = g.mesh;
    try {
      layer.weights = garment_skin_weights(m_body, g.mesh, layer.type, options.skinning);
      layer.blend =
          blend_weights(*m_cleanup->body(), g.mesh, layer.type, hips, options.split_band, options.max_physical_weight);
      if (options.physics) {
        ClothOptions co = options.cloth;
        co.waistband_pins = co.waistband_pins || fitting::is_bottom(layer.type);
        layer.cloth = std::make_unique<ClothSim>(g.mesh.positions, g.mesh.triangles, co);
        layer.cloth->set_body(m_cleanup->body(), m_body.mesh.positions, m_body.mesh.triangles);
        // The leash: the tether plus the vertex's distance to the body at rest (eq. 9's), so
        // loose parts (a skirt's hem) swing farther than tight ones.
        layer.tether_radii.resize(layer.blend.distances.size());
        for (std::size_t v = 0; v < layer.blend.distances.size(); ++v)
          layer.tether_radii[v] = float(options.tether + double(layer.blend.distances[v]));
      }
    } catch (const Error& e) {
      throw Error(g.name, 0, std::string("animation: ") + e.what());
    }
    layer.positions = g.mesh.positions;
    layer.lbs = g.mesh.positions;
    layer.lbs_previous = g.mesh.positions;
    layer.skin_velocity.assign(g.mesh.positions.size(), 0.0f);
    layer.start_x.resize(g.mesh.positions.size());
    layer.start_v.resize(g.mesh.positions.size());
    m_garments.push_back(std::move(layer));
  }
}

DressedCharacter::~DressedCharacter() = default;
DressedCharacter::DressedCharacter(DressedCharacter&&) noexcept = default;
DressedCharacter& DressedCharacter::operator=(DressedCharacter&&) noexcept = default;

const FrameReport& DressedCharacter::step(const Pose& pose, double dt) {
  const auto t0 = Clock::now();
  m_report = FrameReport{};
  m_arena->arena.execute([&] { step_stages(pose, dt); });
  m_report.total_ms = ms_since(t0);
  return m_report;
}

void DressedCharacter::step_stages(const Pose& pose, double dt) {
  FrameReport& r = m_report;
  auto t = Clock::now();
  m_transforms = skinning_transforms(m_body.joints, pose);
  const auto& transforms = m_transforms;
  // The body's fastest vertex over the frame tells a cut in the motion (compared before the
  // body moves; the first frame always restarts).
  bool cut = m_restart || !(dt > 0) || !std::isfinite(dt);
  std::vector<float>& body = m_body_positions;
  if (!cut) {
    const double limit2 = (m_options.cut_speed * dt) * (m_options.cut_speed * dt);
    std::vector<float>& before = m_previous_body;
    before.assign(body.begin(), body.end());
    linear_blend_skinning(m_body.mesh.positions, m_body.weights, transforms, body);
    for (std::size_t i = 0; i + 2 < body.size() && !cut; i += 3) {
      const double dx = double(body[i]) - before[i], dy = double(body[i + 1]) - before[i + 1],
                   dz = double(body[i + 2]) - before[i + 2];
      cut = dx * dx + dy * dy + dz * dz > limit2;
    }
  } else {
    linear_blend_skinning(m_body.mesh.positions, m_body.weights, transforms, body);
  }
  for (Layer& g : m_garments) {
    g.lbs_previous.swap(g.lbs); // the same sizes: no allocation
    linear_blend_skinning(g.rest.positions, g.weights, transforms, g.lbs);
  }
  r.lbs_ms = ms_since(t);

  t = Clock::now();
  // The one index of the posed body: the cloths' and the clean-up's.
  if (m_options.physics || m_options.clean_up) m_cleanup->refit_body(body);
  if (m_options.physics) {
    // The garments' cloths are independent (each collides with the body only; the layers are
    // the clean-up's): stepped side by side, each also parallel inside.
    const auto inertia = float(m_options.inertia);
    tbb::parallel_for(std::size_t(0), m_garments.size(), [&](std::size_t i) {
      Layer& g = m_garments[i];
      ClothSim& cloth = *g.cloth;
      cloth.move_body(body, 0.0); // at rest in the carried frame (the shared index is refitted)
      if (cut) {
        cloth.set_state(g.lbs);
        g.skin_velocity_known = false;
        return;
      }
      // Carried by the skinning: each particle moves as its skinned position did, keeps its
      // velocity relative to the skin, less `inertia` times the skin's change of velocity.
      const std::span<const float> x = cloth.positions(), v = cloth.velocities();
      const auto inv_dt = float(1.0 / dt);
      for (std::size_t c = 0; c < x.size(); ++c) {
        const float moved = g.lbs[c] - g.lbs_previous[c], skin_v = moved * inv_dt;
        const float kick = g.skin_velocity_known ? inertia * (skin_v - g.skin_velocity[c]) : 0.0f;
        g.start_x[c] = x[c] + moved;
        g.start_v[c] = v[c] - kick;
        g.skin_velocity[c] = skin_v;
      }
      g.skin_velocity_known = true;
      cloth.set_state(g.start_x, g.start_v);
      cloth.set_tethers(g.lbs, g.tether_radii);
      g.last = cloth.step(dt);
      if (g.last.status != ClothStatus::OK) {
        cloth.set_state(g.lbs);
        g.skin_velocity_known = false;
      }
    });
    if (!cut)
      for (const Layer& g : m_garments) {
        r.diverged += g.last.status != ClothStatus::OK ? 1 : 0;
        r.solver_iterations += g.last.solver_iterations;
        r.contacts += g.last.contacts;
      }
  }
  r.restarted = cut;
  m_restart = false;
  r.physics_ms = ms_since(t);

  t = Clock::now();
  for (Layer& g : m_garments) {
    const std::size_t nv = g.lbs.size() / 3;
    if (!m_options.physics) {
      std::copy(g.lbs.begin(), g.lbs.end(), g.positions.begin());
      continue;
    }
    const std::span<const float> phys = g.cloth->positions();
    std::size_t bad = 0;
    for (std::size_t v = 0; v < nv; ++v) {
      const float w = g.blend.per_vertex[v];
      float out[3];
      bool finite = true;
      for (std::size_t k = 0; k < 3; ++k) {
        out[k] = g.lbs[3 * v + k] + w * (phys[3 * v + k] - g.lbs[3 * v + k]);
        finite = finite && std::isfinite(out[k]);
      }
      if (!finite) {
        std::copy_n(&g.lbs[3 * v], 3, out);
        ++bad;
      }
      std::copy_n(out, 3, &g.positions[3 * v]);
    }
    r.non_finite += bad;
  }
  r.blend_ms = ms_since(t);

  if (m_options.clean_up)
    for (std::size_t g = 0; g < m_garments.size(); ++g)
      r.add(m_cleanup->clean(g, m_garments[g].positions));
}

void DressedCharacter::bind_space_offsets(std::size_t g, std::span<float> out) const {
  const Layer& layer = m_garments.at(g);
  const std::size_t nv = layer.rest.vertex_count();
  if (out.size() != 3 * nv) throw Error(layer.name, 0, "bind_space_offsets: the output is not #V × 3");
  for (std::size_t v = 0; v < nv; ++v) {
    Eigen::Matrix3d m = Eigen::Matrix3d::Zero();
    double heaviest = -1;
    int joint = 0;
    for (std::size_t k = 0; k < 4; ++k) {
      const float w = layer.weights.weights[4 * v + k];
      const int j = layer.weights.joints[4 * v + k];
      m += double(w) * m_transforms[std::size_t(j)].linear();
      if (w > heaviest) heaviest = w, joint = j;
    }
    const Eigen::Vector3d residual(double(layer.positions[3 * v]) - layer.lbs[3 * v],
                                   double(layer.positions[3 * v + 1]) - layer.lbs[3 * v + 1],
                                   double(layer.positions[3 * v + 2]) - layer.lbs[3 * v + 2]);
    const Eigen::Vector3d d = std::fabs(m.determinant()) >= 1e-3
                                  ? Eigen::Vector3d(m.inverse() * residual)
                                  : Eigen::Vector3d(m_transforms[std::size_t(joint)].linear().transpose() * residual);
    for (std::size_t c = 0; c < 3; ++c)
      out[3 * v + c] = float(d[Eigen::Index(c)]);
  }
}

FramePenetration DressedCharacter::measure() const {
  Mesh posed;
  posed.positions = m_body_positions;
  posed.triangles = m_body.mesh.triangles;
  DressingBody body(posed, LAYER_CLEARANCE, LAYER_REACH);
  FramePenetration out;
  ClosestHits hits;
  for (const Layer& g : m_garments) {
    Mesh garment;
    garment.positions = g.positions;
    garment.triangles = g.rest.triangles;
    const PenetrationStats s = Dresser(body, garment, DressOptions{}).measure(garment);
    out.inside += s.inside_count;
    out.max_depth_mm = std::max(out.max_depth_mm, 1000 * s.max_depth);
    out.crossing_edges += s.crossing_edges;
    out.layer_inside += s.layer_inside_count;
    out.layer_crossing_edges += s.layer_crossing_edges;
    body.index().closest_points(garment.positions, INFINITY, hits);
    for (std::size_t v = 0; v < hits.size(); ++v)
      if (hits.triangles[v] >= 0 && hits.signed_distances[v] < -0.001f) ++out.inside_1mm;
    body.add_layer(garment);
  }
  return out;
}

} // namespace vfit
