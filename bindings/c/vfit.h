/* SPDX-License-Identifier: Apache-2.0 */
#ifndef VFIT_VFIT_H
#define VFIT_VFIT_H
/*
 * vfit's C API: garments fitted onto bodies and dressed characters stepped frame by frame,
 * through opaque handles, for C programs and for game engines that load a C ABI (libvfit_c).
 *
 * Conventions
 * - Every call that can fail returns a vfit_status; VFIT_OK is 0. On failure nothing is
 *   returned through the out-pointers (they are set to NULL / left unchanged for sizes) and the
 *   context keeps a message, vfit_context_error_message(), valid until the context's next call.
 *   No C++ exception ever crosses this boundary.
 * - Handles are created by vfit_*_create/read/... and freed by vfit_*_release (NULL is
 *   ignored). Every handle keeps its context alive: the context may be released first.
 * - Units and layouts: lengths in metres, Y up, the body facing +Z; positions are #V × 3 floats
 *   (x y z per vertex, vertex-major), triangles #T × 3 int32 vertex indices, counter-clockwise
 *   seen from outside. A pose is 75 doubles: 24 joints × (x y z) axis-angle rotations in
 *   radians, each relative to its parent in the skeleton's joint order (SMPL's: pelvis, left
 *   hip, right hip, spine1, left knee, right knee, spine2, left ankle, right ankle, spine3, left
 *   foot, right foot, neck, left collar, right collar, head, left shoulder, right shoulder, left
 *   elbow, right elbow, left wrist, right wrist, left hand, right hand), then the root's
 *   translation (x y z, metres). All zeros is the body's rest pose.
 * - Pointers returned by accessors (positions, messages, JSON) belong to the handle and stay
 *   valid until the handle's next modifying call or its release.
 * - Threads: a context and the handles made with it are used by one thread at a time; separate
 *   contexts may run concurrently. Work inside a call runs on the context's threads.
 */
#include <stddef.h>
#include <stdint.h>

#if defined(_WIN32)
#define VFIT_API __declspec(dllexport)
#else
#define VFIT_API __attribute__((visibility("default")))
#endif

#ifdef __cplusplus
extern "C" {
#endif
/* C names, lower_case as C libraries name their types, not the C++ sources' naming rules:
 * NOLINTBEGIN(readability-identifier-naming) */

typedef enum vfit_status {
  VFIT_OK = 0,
  VFIT_ERROR_ARGUMENT = 1, /* a NULL handle or pointer, a count or value out of range */
  VFIT_ERROR_INPUT = 2,    /* a file or mesh that cannot be read or used (the message names it) */
  VFIT_ERROR_BACKEND = 3,  /* the requested backend or device is not available */
  VFIT_ERROR_MEMORY = 4,   /* out of memory */
  VFIT_ERROR_INTERNAL = 5  /* anything else (a bug: please report the message) */
} vfit_status;

typedef enum vfit_backend { VFIT_BACKEND_TBB = 0, VFIT_BACKEND_SERIAL = 1, VFIT_BACKEND_OPENCL = 2 } vfit_backend;

typedef struct vfit_context_t* vfit_context;     /* backend, threads, the last error */
typedef struct vfit_mesh_t* vfit_mesh;           /* a triangle mesh */
typedef struct vfit_body_t* vfit_body;           /* a rigged body, at rest and posed */
typedef struct vfit_fit_t* vfit_fit;             /* fitted garments and the fit report */
typedef struct vfit_character_t* vfit_character; /* a dressed character in motion */

/* "0.1.0 (5b6c6f2)": the version and the git commit the library was built from. */
VFIT_API const char* vfit_version(void);

/* ---- context ---------------------------------------------------------------------------- */

/* backend: where the data-parallel kernels run; device: an OpenCL device selector (NULL or ""
 * for VFIT_OPENCL_DEVICE or the first device; ignored for the CPU backends); threads: worker
 * threads, 0 for every core. VFIT_ERROR_BACKEND when the backend cannot be had, with the reason
 * in vfit_context_create_error() (there is no context to hold it). */
VFIT_API vfit_status vfit_context_create(vfit_backend backend, const char* device, int threads, vfit_context* out);
/* The message of the last failed vfit_context_create() on this thread ("" when none). */
VFIT_API const char* vfit_context_create_error(void);
/* The status and message of this context's last failed call (VFIT_OK and "" when none). */
VFIT_API vfit_status vfit_context_error(vfit_context context);
VFIT_API const char* vfit_context_error_message(vfit_context context);
/* "tbb (2 threads)", "serial" or "opencl: <device> (<platform>)". */
VFIT_API const char* vfit_context_description(vfit_context context);
VFIT_API void vfit_context_release(vfit_context context);

/* ---- meshes ----------------------------------------------------------------------------- */

/* A mesh from arrays (copied): positions vertex_count × 3, triangles triangle_count × 3. The
 * garment's unit and up axis are detected when it is fitted, as `vfit fit` does. */
VFIT_API vfit_status vfit_mesh_create(vfit_context context, const float* positions, size_t vertex_count,
                                      const int32_t* triangles, size_t triangle_count, vfit_mesh* out);
/* Reads OBJ, PLY, OFF, STL or glTF/GLB (all meshes of the file merged). */
VFIT_API vfit_status vfit_mesh_read(vfit_context context, const char* path, vfit_mesh* out);
/* A catalogue garment: type "tee", "long_sleeve", "trousers", "shorts", "dress" or "skirt";
 * size "XS".."XXL" (or "P1".."P4" for trousers and shorts), NULL for "M"; rest_pose "tpose" or
 * "apose", NULL for "tpose"; exactly vertex_count vertices (1,000 – 2,000,000). */
VFIT_API vfit_status vfit_mesh_catalogue(vfit_context context, const char* type, const char* size,
                                         const char* rest_pose, size_t vertex_count, vfit_mesh* out);
/* Writes OBJ, PLY, OFF, STL or GLB, by the path's extension, atomically. */
VFIT_API vfit_status vfit_mesh_write(vfit_context context, vfit_mesh mesh, const char* path);
VFIT_API size_t vfit_mesh_vertex_count(vfit_mesh mesh);
VFIT_API size_t vfit_mesh_triangle_count(vfit_mesh mesh);
VFIT_API const float* vfit_mesh_positions(vfit_mesh mesh);
VFIT_API const int32_t* vfit_mesh_triangles(vfit_mesh mesh);
VFIT_API void vfit_mesh_release(vfit_mesh mesh);

/* ---- bodies ----------------------------------------------------------------------------- */

/* The 11 measurements of the parametric mannequin, metres, in this order. */
enum {
  VFIT_HEIGHT = 0,
  VFIT_CROTCH_HEIGHT,
  VFIT_KNEE_HEIGHT,
  VFIT_ARM_LENGTH,
  VFIT_FOREARM_LENGTH,
  VFIT_SHOULDER_WIDTH,
  VFIT_CHEST,
  VFIT_WAIST,
  VFIT_HIP,
  VFIT_THIGH,
  VFIT_CALF,
  VFIT_MEASUREMENT_COUNT
};

/* The mannequin: measurements VFIT_MEASUREMENT_COUNT values (NULL: an average adult), rest_pose
 * "apose" or "tpose" (NULL: "apose"), vertex_count vertices (0: 7,000). */
VFIT_API vfit_status vfit_body_mannequin(vfit_context context, const double* measurements, const char* rest_pose,
                                         size_t vertex_count, vfit_body* out);
/* A body from a file: SMPL-format .npz, rigged .glb/.gltf, or a mesh (units and joints
 * detected), as `vfit body --body FILE` reads it. */
VFIT_API vfit_status vfit_body_read(vfit_context context, const char* path, vfit_body* out);
/* Poses the body: 75 doubles (see the conventions), or a built-in pose name ("demo",
 * "arms_down", ...) or a pose JSON file. */
VFIT_API vfit_status vfit_body_set_pose(vfit_context context, vfit_body body, const double* pose);
VFIT_API vfit_status vfit_body_set_named_pose(vfit_context context, vfit_body body, const char* name_or_file);
/* The posed body's mesh, as a new mesh handle. */
VFIT_API vfit_status vfit_body_mesh(vfit_context context, vfit_body body, vfit_mesh* out);
VFIT_API void vfit_body_release(vfit_body body);

/* ---- fitting ---------------------------------------------------------------------------- */

typedef struct vfit_fit_options {
  int simulate;       /* 1: drape with the cloth simulation (the default), 0: skip it */
  const char* fabric; /* "cotton_jersey" (NULL), "denim", "silk" or "wool" */
  double clearance_m; /* m: the gap kept to the body; <= 0: the default (3 mm) */
} vfit_fit_options;

/* Default options (simulate on, the default fabric and clearance). */
VFIT_API vfit_fit_options vfit_fit_options_default(void);
/* Fits garments[0..count) (inner first, as dressed) onto the body in its current pose.
 * names: count strings naming them in the report (NULL: "garment0", ...). options: NULL for
 * the defaults. */
VFIT_API vfit_status vfit_fit_garments(vfit_context context, vfit_body body, const vfit_mesh* garments,
                                       const char* const* names, size_t count, const vfit_fit_options* options,
                                       vfit_fit* out);
VFIT_API size_t vfit_fit_garment_count(vfit_fit fit);
/* Fitted garment g (metres, the body's frame), as a new mesh handle. */
VFIT_API vfit_status vfit_fit_garment(vfit_context context, vfit_fit fit, size_t g, vfit_mesh* out);
/* The fit report as JSON text, as `vfit fit --report` writes it (docs/cli.md). */
VFIT_API const char* vfit_fit_report_json(vfit_fit fit);
/* The worst size verdict over the garments: "good", "tight", "loose" or "falls off". */
VFIT_API const char* vfit_fit_verdict(vfit_fit fit);
VFIT_API void vfit_fit_release(vfit_fit fit);

/* ---- animation -------------------------------------------------------------------------- */

/* A dressed character: the body and the garments of `fit`, which must have been fitted onto
 * this body in its rest pose (all-zero pose; VFIT_ERROR_ARGUMENT otherwise). physics: 1 for
 * the cloth blended with skinning (seed 001 eq. 8-9), 0 for skinning and the clean-up only.
 * threads: step()'s threads, 0 for the context's. */
VFIT_API vfit_status vfit_character_create(vfit_context context, vfit_body body, vfit_fit fit, int physics, int threads,
                                           vfit_character* out);
/* One frame: the body in `pose` (75 doubles), dt seconds after the previous frame (dt <= 0
 * restarts the cloth, as a cut in the motion does). */
VFIT_API vfit_status vfit_character_step(vfit_context context, vfit_character character, const double* pose, double dt);
VFIT_API size_t vfit_character_garment_count(vfit_character character);
/* Positions after the last step (before the first: at rest); *vertex_count receives #V. */
VFIT_API const float* vfit_character_body_positions(vfit_character character, size_t* vertex_count);
VFIT_API const float* vfit_character_garment_positions(vfit_character character, size_t g, size_t* vertex_count);
/* Of the last step: vertices left over 1 mm inside the body and edges left through it (what
 * the per-frame clean-up could not remove), and the step's time in milliseconds. */
VFIT_API vfit_status vfit_character_last_frame(vfit_character character, size_t* left_inside_1mm, size_t* left_crossing,
                                               double* total_ms);
VFIT_API void vfit_character_release(vfit_character character);

/* NOLINTEND(readability-identifier-naming) */
#ifdef __cplusplus
}
#endif
#endif /* VFIT_VFIT_H */
