// The subcommands of the prt tool. Each registers its options on the app and
// returns the function that runs it once the command line is parsed.
#pragma once

#include <CLI/CLI.hpp>

#include <functional>

namespace prt::cli {

using Run = std::function<int()>;

Run add_project(CLI::App& app);
Run add_verify(CLI::App& app);

// "a,b,c" -> three doubles; throws prt::Error naming `option` otherwise.
void parse_triple(const std::string& text, const char* option, double out[3]);

}  // namespace prt::cli
