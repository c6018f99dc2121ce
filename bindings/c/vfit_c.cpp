// SPDX-License-Identifier: Apache-2.0
// The C API (vfit.h) over the engine: each handle is a C++ object behind an opaque pointer, each
// call a try block that turns exceptions into a status and the context's message.
#include "vfit.h"

#include "../binding_support.h"

#include <cmath>
#include <cstring>
#include <memory>
#include <mutex>
#include <new>
#include <stdexcept>
#include <string>
#include <vector>

#include "vfit/engine/animate/dressed_character.h"
#include "vfit/engine/engine.h"
#include "vfit/engine/fit/fit_feedback.h"
#include "vfit/engine/fit/fit_report_json.h"
#include "vfit/geometry/body/pose_io.h"
#include "vfit/geometry/garment/catalogue.h"
#include "vfit/geometry/mesh/mesh_io.h"
#include "vfit/kernels/error.h"
#include "vfit/kernels/version.h"

namespace {

struct ContextState {
  std::unique_ptr<vfit::Engine> engine;
  int threads = 0;
  std::string description;
  std::mutex mutex; // guards the error
  vfit_status status = VFIT_OK;
  std::string message;
};
using Context = std::shared_ptr<ContextState>;

thread_local std::string create_error; // vfit_context_create()'s message, where no context exists

// What a failed call leaves: its status and message, in the context (when there is one).
void set_error(const Context& context, vfit_status status, const std::string& message) {
  if (!context) return;
  const std::lock_guard lock(context->mutex);
  context->status = status;
  context->message = message;
}

// Runs `work`, mapping every exception to a status; the context's error is cleared first.
template <class Work> vfit_status guarded(const Context& context, Work&& work) {
  if (context) set_error(context, VFIT_OK, "");
  try {
    work();
    return VFIT_OK;
  } catch (const vfit::Error& e) {
    set_error(context, VFIT_ERROR_INPUT, e.what());
    return VFIT_ERROR_INPUT;
  } catch (const std::invalid_argument& e) {
    set_error(context, VFIT_ERROR_ARGUMENT, e.what());
    return VFIT_ERROR_ARGUMENT;
  } catch (const std::bad_alloc&) {
    set_error(context, VFIT_ERROR_MEMORY, "out of memory");
    return VFIT_ERROR_MEMORY;
  } catch (const std::exception& e) {
    set_error(context, VFIT_ERROR_INTERNAL, e.what());
    return VFIT_ERROR_INTERNAL;
  } catch (...) {
    set_error(context, VFIT_ERROR_INTERNAL, "unknown exception");
    return VFIT_ERROR_INTERNAL;
  }
}

void require(bool ok, const char* what) {
  if (!ok) throw std::invalid_argument(what);
}

vfit::RestPose rest_pose_of(const char* name, vfit::RestPose fallback) {
  return name ? vfit::bindings::rest_pose_named(name) : fallback;
}

} // namespace

// The handles behind vfit.h's opaque pointers, named as the C header declares them.
// NOLINTBEGIN(readability-identifier-naming)
struct vfit_context_t {
  Context state;
};
struct vfit_mesh_t {
  Context context;
  vfit::Mesh mesh;
};
struct vfit_body_t {
  Context context;
  vfit::SourcedBody made;
  std::shared_ptr<const vfit::Body> posed; // the body as posed now; a fit keeps the one it used
  bool at_rest = true;
};
struct vfit_fit_t {
  Context context;
  std::shared_ptr<const vfit::Body> body; // the body it was fitted onto
  bool at_rest = true;
  vfit::FitResult result;
  std::string report_json;
  std::string verdict;
};
struct vfit_character_t {
  Context context;
  std::unique_ptr<vfit::DressedCharacter> character;
  const vfit::FrameReport* last = nullptr; // owned by the character, valid until its next step
};
// NOLINTEND(readability-identifier-naming)

extern "C" {

const char* vfit_version(void) {
  static const std::string text = std::string(vfit::version()) + " (" + vfit::git_commit() + ")";
  return text.c_str();
}

vfit_status vfit_context_create(vfit_backend backend, const char* device, int threads, vfit_context* out) {
  create_error.clear();
  if (!out) {
    create_error = "vfit_context_create: out is NULL";
    return VFIT_ERROR_ARGUMENT;
  }
  *out = nullptr;
  try {
    if (threads < 0) {
      create_error = "vfit_context_create: threads must be 0 (every core) or more";
      return VFIT_ERROR_ARGUMENT;
    }
    if (backend != VFIT_BACKEND_TBB && backend != VFIT_BACKEND_SERIAL && backend != VFIT_BACKEND_OPENCL) {
      create_error = "vfit_context_create: unknown backend";
      return VFIT_ERROR_ARGUMENT;
    }
    vfit::EngineOptions options;
    options.backend = backend == VFIT_BACKEND_SERIAL   ? vfit::Backend::SERIAL
                      : backend == VFIT_BACKEND_OPENCL ? vfit::Backend::OPENCL
                                                       : vfit::Backend::TBB;
    options.device = device ? device : "";
    options.threads = threads;
    auto state = std::make_shared<ContextState>();
    state->engine = std::make_unique<vfit::Engine>(options);
    state->threads = state->engine->thread_count();
    state->description = state->engine->description();
    *out = new vfit_context_t{std::move(state)};
    return VFIT_OK;
  } catch (const vfit::Error& e) {
    create_error = e.what();
    return VFIT_ERROR_BACKEND;
  } catch (const std::bad_alloc&) {
    create_error = "out of memory";
    return VFIT_ERROR_MEMORY;
  } catch (const std::exception& e) {
    create_error = e.what();
    return VFIT_ERROR_INTERNAL;
  }
}

const char* vfit_context_create_error(void) { return create_error.c_str(); }

vfit_status vfit_context_error(vfit_context context) {
  if (!context) return VFIT_ERROR_ARGUMENT;
  const std::lock_guard lock(context->state->mutex);
  return context->state->status;
}

const char* vfit_context_error_message(vfit_context context) {
  if (!context) return "vfit_context_error_message: the context is NULL";
  const std::lock_guard lock(context->state->mutex);
  return context->state->message.c_str();
}

const char* vfit_context_description(vfit_context context) {
  return context ? context->state->description.c_str() : "";
}

void vfit_context_release(vfit_context context) { delete context; }

// ---- meshes ----

vfit_status vfit_mesh_create(vfit_context context, const float* positions, size_t vertex_count,
                             const int32_t* triangles, size_t triangle_count, vfit_mesh* out) {
  if (!context) return VFIT_ERROR_ARGUMENT;
  return guarded(context->state, [&] {
    require(out != nullptr, "vfit_mesh_create: out is NULL");
    *out = nullptr;
    vfit::Mesh mesh = vfit::bindings::mesh_from_arrays(positions, vertex_count, triangles, triangle_count);
    *out = new vfit_mesh_t{context->state, std::move(mesh)};
  });
}

vfit_status vfit_mesh_read(vfit_context context, const char* path, vfit_mesh* out) {
  if (!context) return VFIT_ERROR_ARGUMENT;
  return guarded(context->state, [&] {
    require(out != nullptr && path != nullptr, "vfit_mesh_read: path or out is NULL");
    *out = nullptr;
    vfit::ParsedMesh parsed = vfit::read_mesh(path);
    *out = new vfit_mesh_t{context->state, std::move(parsed.mesh)};
  });
}

vfit_status vfit_mesh_catalogue(vfit_context context, const char* type, const char* size, const char* rest_pose,
                                size_t vertex_count, vfit_mesh* out) {
  if (!context) return VFIT_ERROR_ARGUMENT;
  return guarded(context->state, [&] {
    require(out != nullptr && type != nullptr, "vfit_mesh_catalogue: type or out is NULL");
    *out = nullptr;
    vfit::GarmentOptions options;
    options.type = vfit::parse_garment_type(type);
    if (size) options.size = size;
    options.pose = rest_pose_of(rest_pose, vfit::RestPose::TPOSE);
    options.target_vertices = vertex_count;
    *out = new vfit_mesh_t{context->state, vfit::make_garment(options).mesh};
  });
}

vfit_status vfit_mesh_write(vfit_context context, vfit_mesh mesh, const char* path) {
  if (!context) return VFIT_ERROR_ARGUMENT;
  return guarded(context->state, [&] {
    require(mesh != nullptr && path != nullptr, "vfit_mesh_write: mesh or path is NULL");
    vfit::write_mesh(path, mesh->mesh);
  });
}

size_t vfit_mesh_vertex_count(vfit_mesh mesh) { return mesh ? mesh->mesh.vertex_count() : 0; }
size_t vfit_mesh_triangle_count(vfit_mesh mesh) { return mesh ? mesh->mesh.face_count() : 0; }
const float* vfit_mesh_positions(vfit_mesh mesh) { return mesh ? mesh->mesh.positions.data() : nullptr; }
const int32_t* vfit_mesh_triangles(vfit_mesh mesh) { return mesh ? mesh->mesh.triangles.data() : nullptr; }
void vfit_mesh_release(vfit_mesh mesh) { delete mesh; }

// ---- bodies ----

namespace {
vfit_status make_body(vfit_context context, const vfit::BodySource& source, vfit_body* out) {
  return guarded(context->state, [&] {
    require(out != nullptr, "out is NULL");
    *out = nullptr;
    auto body = std::make_unique<vfit_body_t>();
    body->context = context->state;
    body->made = context->state->engine->make_body(source);
    body->posed = std::make_shared<const vfit::Body>(body->made.body);
    *out = body.release();
  });
}
} // namespace

vfit_status vfit_body_mannequin(vfit_context context, const double* measurements, const char* rest_pose,
                                size_t vertex_count, vfit_body* out) {
  if (!context) return VFIT_ERROR_ARGUMENT;
  vfit::BodySource source;
  const vfit_status status = guarded(context->state, [&] {
    vfit::MannequinOptions& m = source.request.mannequin;
    if (measurements) {
      // vfit.h's VFIT_HEIGHT … VFIT_CALF are BodyMeasurements::names()' order.
      const auto& names = vfit::BodyMeasurements::names();
      if (names.size() != VFIT_MEASUREMENT_COUNT)
        throw std::logic_error("vfit.h's measurements differ from the engine's");
      for (std::size_t i = 0; i < names.size(); ++i)
        m.measurements[names[i]] = measurements[i];
    }
    m.pose = rest_pose_of(rest_pose, vfit::RestPose::APOSE);
    if (vertex_count > 0) m.target_vertices = vertex_count;
  });
  return status != VFIT_OK ? status : make_body(context, source, out);
}

vfit_status vfit_body_read(vfit_context context, const char* path, vfit_body* out) {
  if (!context) return VFIT_ERROR_ARGUMENT;
  if (!path) {
    set_error(context->state, VFIT_ERROR_ARGUMENT, "vfit_body_read: path is NULL");
    return VFIT_ERROR_ARGUMENT;
  }
  vfit::BodySource source;
  source.request.source = path;
  return make_body(context, source, out);
}

vfit_status vfit_body_set_pose(vfit_context context, vfit_body body, const double* pose) {
  if (!context) return VFIT_ERROR_ARGUMENT;
  return guarded(context->state, [&] {
    require(body != nullptr && pose != nullptr, "vfit_body_set_pose: body or pose is NULL");
    const vfit::Pose p = vfit::bindings::pose_from_values(pose);
    body->posed = std::make_shared<const vfit::Body>(body->made.loaded.posed(p));
    body->at_rest = p.is_rest();
  });
}

vfit_status vfit_body_set_named_pose(vfit_context context, vfit_body body, const char* name_or_file) {
  if (!context) return VFIT_ERROR_ARGUMENT;
  return guarded(context->state, [&] {
    require(body != nullptr && name_or_file != nullptr, "vfit_body_set_named_pose: body or name is NULL");
    const vfit::Pose p = vfit::pose_by_name_or_file(name_or_file, body->made.loaded.rest.rest_pose);
    body->posed = std::make_shared<const vfit::Body>(body->made.loaded.posed(p));
    body->at_rest = p.is_rest();
  });
}

vfit_status vfit_body_mesh(vfit_context context, vfit_body body, vfit_mesh* out) {
  if (!context) return VFIT_ERROR_ARGUMENT;
  return guarded(context->state, [&] {
    require(body != nullptr && out != nullptr, "vfit_body_mesh: body or out is NULL");
    *out = nullptr;
    *out = new vfit_mesh_t{context->state, body->posed->mesh};
  });
}

void vfit_body_release(vfit_body body) { delete body; }

// ---- fitting ----

vfit_fit_options vfit_fit_options_default(void) { return vfit_fit_options{1, nullptr, 0.0}; }

vfit_status vfit_fit_garments(vfit_context context, vfit_body body, const vfit_mesh* garments, const char* const* names,
                              size_t count, const vfit_fit_options* options, vfit_fit* out) {
  if (!context) return VFIT_ERROR_ARGUMENT;
  return guarded(context->state, [&] {
    require(body != nullptr && out != nullptr, "vfit_fit_garments: body or out is NULL");
    *out = nullptr;
    require(count > 0 && garments != nullptr, "vfit_fit_garments: no garments");
    std::vector<vfit::FitGarmentInput> inputs(count);
    for (std::size_t g = 0; g < count; ++g) {
      require(garments[g] != nullptr, "vfit_fit_garments: a garment is NULL");
      inputs[g].name = names && names[g] ? names[g] : "garment" + std::to_string(g);
      inputs[g].mesh = garments[g]->mesh;
    }
    vfit::FitOptions fo;
    const vfit_fit_options o = options ? *options : vfit_fit_options_default();
    fo.simulate = o.simulate != 0;
    if (o.fabric) fo.fabric = o.fabric;
    if (o.clearance_m > 0) fo.clearance = o.clearance_m;
    auto fit = std::make_unique<vfit_fit_t>();
    fit->context = context->state;
    fit->body = body->posed;
    fit->at_rest = body->at_rest;
    fit->result = context->state->engine->fit(*body->posed, inputs, fo);
    fit->report_json =
        vfit::fit_report_json(fit->result.report, fo, vfit::fit_report_context(*body->posed, body->made.loaded));
    fit->verdict = vfit::size_verdict_name(fit->result.report.verdict);
    *out = fit.release();
  });
}

size_t vfit_fit_garment_count(vfit_fit fit) { return fit ? fit->result.garments.size() : 0; }

vfit_status vfit_fit_garment(vfit_context context, vfit_fit fit, size_t g, vfit_mesh* out) {
  if (!context) return VFIT_ERROR_ARGUMENT;
  return guarded(context->state, [&] {
    require(fit != nullptr && out != nullptr, "vfit_fit_garment: fit or out is NULL");
    *out = nullptr;
    require(g < fit->result.garments.size(), "vfit_fit_garment: no such garment");
    *out = new vfit_mesh_t{context->state, fit->result.garments[g].mesh};
  });
}

const char* vfit_fit_report_json(vfit_fit fit) { return fit ? fit->report_json.c_str() : ""; }
const char* vfit_fit_verdict(vfit_fit fit) { return fit ? fit->verdict.c_str() : ""; }
void vfit_fit_release(vfit_fit fit) { delete fit; }

// ---- animation ----

vfit_status vfit_character_create(vfit_context context, vfit_body body, vfit_fit fit, int physics, int threads,
                                  vfit_character* out) {
  if (!context) return VFIT_ERROR_ARGUMENT;
  return guarded(context->state, [&] {
    require(body != nullptr && fit != nullptr && out != nullptr, "vfit_character_create: body, fit or out is NULL");
    *out = nullptr;
    require(threads >= 0, "vfit_character_create: threads must be 0 or more");
    vfit::bindings::require_fit_at_rest(*fit->body, fit->at_rest, body->made.body);
    vfit::AnimationOptions options;
    options.physics = physics != 0;
    options.threads = threads > 0 ? threads : context->state->threads;
    auto c = std::make_unique<vfit_character_t>();
    c->context = context->state;
    c->character = std::make_unique<vfit::DressedCharacter>(*fit->body, fit->result.garments, options);
    *out = c.release();
  });
}

vfit_status vfit_character_step(vfit_context context, vfit_character character, const double* pose, double dt) {
  if (!context) return VFIT_ERROR_ARGUMENT;
  return guarded(context->state, [&] {
    require(character != nullptr && pose != nullptr, "vfit_character_step: character or pose is NULL");
    character->last = &character->character->step(vfit::bindings::pose_from_values(pose), dt);
  });
}

size_t vfit_character_garment_count(vfit_character character) {
  return character ? character->character->garment_count() : 0;
}

const float* vfit_character_body_positions(vfit_character character, size_t* vertex_count) {
  if (!character) return nullptr;
  const std::span<const float> p = character->character->body_positions();
  if (vertex_count) *vertex_count = p.size() / 3;
  return p.data();
}

const float* vfit_character_garment_positions(vfit_character character, size_t g, size_t* vertex_count) {
  if (!character || g >= character->character->garment_count()) return nullptr;
  const std::span<const float> p = character->character->garment_positions(g);
  if (vertex_count) *vertex_count = p.size() / 3;
  return p.data();
}

vfit_status vfit_character_last_frame(vfit_character character, size_t* left_inside_1mm, size_t* left_crossing,
                                      double* total_ms) {
  if (!character) return VFIT_ERROR_ARGUMENT;
  const vfit::FrameReport none;
  const vfit::FrameReport& last = character->last ? *character->last : none;
  if (left_inside_1mm) *left_inside_1mm = last.left_inside_1mm;
  if (left_crossing) *left_crossing = last.left_crossing;
  if (total_ms) *total_ms = last.total_ms;
  return VFIT_OK;
}

void vfit_character_release(vfit_character character) { delete character; }

} // extern "C"
