// SPDX-License-Identifier: Apache-2.0
#pragma once
// The `vfit` subcommands. Each takes its arguments (after the subcommand name), writes its
// result, and returns the exit code; bad input throws vfit::Error (exit 2).

#include "args.h"

namespace vfit::cli {

int run_info(Args& args);
int run_convert(Args& args);
int run_devices(Args& args);
int run_demo(Args& args);
int run_body(Args& args);
int run_garment(Args& args);
int run_measure(Args& args);
int run_render(Args& args);
int run_fit(Args& args);
int run_animate(Args& args);
int run_bench(Args& args);

} // namespace vfit::cli
