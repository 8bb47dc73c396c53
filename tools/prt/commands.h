// The subcommands of the prt tool. Each registers its options on the app and
// returns the function that runs it once the command line is parsed.
#pragma once

#include "shared_options.h"

#include <prt/error.h>

#include <CLI/CLI.hpp>

#include <functional>

namespace prt::cli {

using Run = std::function<int()>;

Run add_project(CLI::App& app);    // cmd_project.cpp
Run add_verify(CLI::App& app);     // cmd_verify.cpp
Run add_precompute(CLI::App& app); // cmd_precompute.cpp
Run add_relight(CLI::App& app);    // cmd_relight.cpp
Run add_render(CLI::App& app);     // cmd_render.cpp
Run add_reference(CLI::App& app);  // cmd_reference.cpp
Run add_compare(CLI::App& app);    // cmd_compare.cpp
Run add_info(CLI::App& app);       // cmd_info.cpp
Run add_view(CLI::App& app);       // cmd_view.cpp
Run add_report(CLI::App& app);     // cmd_report.cpp
Run add_compress(CLI::App& app);   // cmd_compress.cpp
Run add_export(CLI::App& app);     // cmd_export.cpp
Run add_unwrap(CLI::App& app);     // cmd_unwrap.cpp

}  // namespace prt::cli
