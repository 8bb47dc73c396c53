// The subcommands of the prt tool. Each registers its options on the app and
// returns the function that runs it once the command line is parsed.
#pragma once

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

// "a,b,c" -> three doubles; throws prt::Error naming `option` otherwise.
void parse_triple(const std::string& text, const char* option, double out[3]);

// Validators whose messages say what is expected and what was given; `why`
// (optional) says why the range is what it is, in the message.
CLI::Validator int_range(int lo, int hi, std::string why = {});
CLI::Validator positive_number();

// Calls f(); a prt::Error it throws is re-thrown with "option: " in front.
template <typename F>
auto for_option(const char* option, F&& f) -> decltype(f()) {
  try {
    return f();
  } catch (const Error& e) {
    throw Error(std::string(option) + ": " + e.what());
  }
}

}  // namespace prt::cli
