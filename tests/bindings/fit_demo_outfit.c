/* SPDX-License-Identifier: Apache-2.0 */
/* A C program (compiled as C11) on the C API: the demo outfit, a catalogue tee over trousers
 * modelled in T-pose, fitted onto the mannequin in the "demo" pose, then the same garments
 * modelled in the A-pose dressed on the body at rest and stepped through a few frames of a
 * raised arm. Exits 0 when every call succeeds and every check holds; prints what failed. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "vfit/vfit.h"

static int failures = 0;

#define CHECK(condition, ...)                                                                      \
  do {                                                                                             \
    if (!(condition)) {                                                                            \
      fprintf(stderr, "fit_demo_outfit.c:%d: ", __LINE__);                                         \
      fprintf(stderr, __VA_ARGS__);                                                                \
      fprintf(stderr, "\n");                                                                       \
      ++failures;                                                                                  \
    }                                                                                              \
  } while (0)

#define CALL(context, call)                                                                        \
  do {                                                                                             \
    vfit_status status_ = (call);                                                                  \
    if (status_ != VFIT_OK) {                                                                      \
      fprintf(stderr, "fit_demo_outfit.c:%d: %s: status %d: %s\n", __LINE__, #call, (int)status_,  \
              vfit_context_error_message(context));                                                \
      exit(1);                                                                                     \
    }                                                                                              \
  } while (0)

static int all_finite(const float* values, size_t count) {
  for (size_t i = 0; i < count; ++i)
    if (!isfinite(values[i])) return 0;
  return 1;
}

int main(void) {
  vfit_context context = NULL;
  if (vfit_context_create(VFIT_BACKEND_TBB, NULL, 2, &context) != VFIT_OK) {
    fprintf(stderr, "fit_demo_outfit.c: no context: %s\n", vfit_context_create_error());
    return 1;
  }
  printf("vfit %s on %s\n", vfit_version(), vfit_context_description(context));

  /* Errors come back as a status and a message naming the input; nothing is returned. */
  vfit_mesh missing = NULL;
  CHECK(vfit_mesh_read(context, "no/such/garment.obj", &missing) == VFIT_ERROR_INPUT, "a missing file is an input error");
  CHECK(missing == NULL, "nothing is returned on error");
  CHECK(strstr(vfit_context_error_message(context), "no/such/garment.obj") != NULL, "the message names the file: %s",
        vfit_context_error_message(context));
  CHECK(vfit_mesh_catalogue(context, "cape", NULL, NULL, 2000, &missing) == VFIT_ERROR_INPUT, "unknown garment type");
  CHECK(vfit_fit_garments(context, NULL, NULL, NULL, 0, NULL, NULL) == VFIT_ERROR_ARGUMENT, "NULL arguments");

  /* The demo: T-pose garments onto the mannequin in the demo pose. */
  vfit_body body = NULL;
  CALL(context, vfit_body_mannequin(context, NULL, NULL, 0, &body));
  CALL(context, vfit_body_set_named_pose(context, body, "demo"));
  vfit_mesh outfit[2] = {NULL, NULL};
  CALL(context, vfit_mesh_catalogue(context, "trousers", "P2", "tpose", 2000, &outfit[0]));
  CALL(context, vfit_mesh_catalogue(context, "tee", "M", "tpose", 2000, &outfit[1]));
  CHECK(vfit_mesh_vertex_count(outfit[1]) == 2000, "the tee has %zu vertices", vfit_mesh_vertex_count(outfit[1]));
  const char* names[2] = {"trousers", "tee"};
  vfit_fit fit = NULL;
  CALL(context, vfit_fit_garments(context, body, outfit, names, 2, NULL, &fit));
  CHECK(vfit_fit_garment_count(fit) == 2, "two garments fitted");
  const char* report = vfit_fit_report_json(fit);
  CHECK(strstr(report, "\"verdict\"") != NULL && strstr(report, "\"tee\"") != NULL, "the report names the tee");
  CHECK(strstr(report, "\"vfit\"") != NULL, "the report names the vfit that made it");
  for (size_t g = 0; g < 2; ++g) {
    vfit_mesh fitted = NULL;
    CALL(context, vfit_fit_garment(context, fit, g, &fitted));
    CHECK(vfit_mesh_vertex_count(fitted) > 0 && all_finite(vfit_mesh_positions(fitted), 3 * vfit_mesh_vertex_count(fitted)),
          "garment %zu is finite", g);
    vfit_mesh_release(fitted);
  }
  printf("demo outfit fitted: %s\n", vfit_fit_verdict(fit));
  CHECK(vfit_character_create(context, body, fit, 1, 0, NULL) == VFIT_ERROR_ARGUMENT, "out is NULL");
  vfit_character refused = NULL;
  CHECK(vfit_character_create(context, body, fit, 1, 0, &refused) == VFIT_ERROR_ARGUMENT && refused == NULL,
        "a fit onto a posed body cannot be animated");
  vfit_fit_release(fit);
  vfit_mesh_release(outfit[0]);
  vfit_mesh_release(outfit[1]);

  /* In motion: A-pose garments on the body at rest, then the left arm raised over 10 frames. */
  double pose[75] = {0};
  CALL(context, vfit_body_set_pose(context, body, pose));
  CALL(context, vfit_mesh_catalogue(context, "trousers", "P2", "apose", 2000, &outfit[0]));
  CALL(context, vfit_mesh_catalogue(context, "tee", "M", "apose", 2000, &outfit[1]));
  vfit_fit_options options = vfit_fit_options_default();
  options.simulate = 0;
  CALL(context, vfit_fit_garments(context, body, outfit, names, 2, &options, &fit));
  vfit_character character = NULL;
  CALL(context, vfit_character_create(context, body, fit, 1, 0, &character));
  CHECK(vfit_character_garment_count(character) == 2, "two garments in motion");
  for (int frame = 0; frame < 10; ++frame) {
    pose[3 * 16 + 2] = -0.05 * frame; /* left shoulder, about z */
    CALL(context, vfit_character_step(context, character, pose, 1.0 / 30));
    size_t inside = 0, crossing = 0;
    double ms = 0;
    CALL(context, vfit_character_last_frame(character, &inside, &crossing, &ms));
    for (size_t g = 0; g < 2; ++g) {
      size_t n = 0;
      const float* p = vfit_character_garment_positions(character, g, &n);
      CHECK(p != NULL && n > 0 && all_finite(p, 3 * n), "frame %d: garment %zu finite", frame, g);
    }
    if (frame == 9) printf("frame %d: %.1f ms, %zu vertices over 1 mm inside, %zu edges through\n", frame, ms, inside, crossing);
  }
  vfit_character_release(character);
  vfit_fit_release(fit);
  vfit_mesh_release(outfit[0]);
  vfit_mesh_release(outfit[1]);
  vfit_body_release(body);
  vfit_context_release(context);
  if (failures) fprintf(stderr, "fit_demo_outfit.c: %d checks failed\n", failures);
  return failures ? 1 : 0;
}
