/* SPDX-License-Identifier: Apache-2.0 */
/* A C consumer of the installed package: the C API (vfit::c) fits a catalogue tee onto a small
 * mannequin and prints one line the package test checks. */
#include <stdio.h>

#include "vfit/vfit.h"

int main(void) {
  vfit_context context = NULL;
  if (vfit_context_create(VFIT_BACKEND_TBB, NULL, 2, &context) != VFIT_OK) {
    fprintf(stderr, "c_consumer: %s\n", vfit_context_create_error());
    return 1;
  }
  vfit_body body = NULL;
  vfit_mesh tee = NULL;
  vfit_fit fit = NULL;
  vfit_fit_options options = vfit_fit_options_default();
  options.simulate = 0;
  if (vfit_body_mannequin(context, NULL, NULL, 2000, &body) != VFIT_OK ||
      vfit_mesh_catalogue(context, "tee", "M", NULL, 1000, &tee) != VFIT_OK ||
      vfit_fit_garments(context, body, &tee, NULL, 1, &options, &fit) != VFIT_OK) {
    fprintf(stderr, "c_consumer: %s\n", vfit_context_error_message(context));
    return 1;
  }
  printf("c_consumer: vfit %s fitted a tee: %s\n", vfit_version(), vfit_fit_verdict(fit));
  vfit_fit_release(fit);
  vfit_mesh_release(tee);
  vfit_body_release(body);
  vfit_context_release(context);
  return 0;
}
