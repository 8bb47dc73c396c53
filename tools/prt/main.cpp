// prt: command-line front end. Parses, validates, calls the libraries,
// writes output; all the work is in the prt:: libraries.
#include "commands.h"

#include <prt/error.h>

#include <fmt/core.h>

#include <cmath>
#include <cstdio>
#include <map>
#include <string>

namespace prt::cli {

void parse_triple(const std::string& text, const char* option, double out[3]) {
  std::size_t pos = 0;
  for (int i = 0; i < 3; ++i) {
    std::size_t used = 0;
    try {
      out[i] = std::stod(text.substr(pos), &used);
    } catch (const std::exception&) {
      throw Error(std::string(option) + ": expected three numbers a,b,c, got '" + text + "'");
    }
    pos += used;
    if (i < 2) {
      if (pos >= text.size() || text[pos] != ',')
        throw Error(std::string(option) + ": expected three numbers a,b,c, got '" + text + "'");
      ++pos;
    }
  }
  if (pos != text.size()) throw Error(std::string(option) + ": expected three numbers a,b,c, got '" + text + "'");
  for (int i = 0; i < 3; ++i)
    if (!std::isfinite(out[i])) throw Error(std::string(option) + ": numbers must be finite, got '" + text + "'");
}

CLI::Validator int_range(int lo, int hi, std::string why) {
  return CLI::Validator(
      [lo, hi, why](std::string& s) -> std::string {
        std::size_t used = 0;
        long v = 0;
        try {
          v = std::stol(s, &used);
        } catch (const std::exception&) {
          used = 0;
        }
        if (used == 0 || used != s.size() || v < lo || v > hi)
          return fmt::format("must be a whole number from {} to {}{}, got '{}'", lo, hi,
                             why.empty() ? "" : " (" + why + ")", s);
        return {};
      },
      fmt::format("INT in [{}, {}]", lo, hi));
}

CLI::Validator positive_number() {
  return CLI::Validator(
      [](std::string& s) -> std::string {
        std::size_t used = 0;
        double v = 0;
        try {
          v = std::stod(s, &used);
        } catch (const std::exception&) {
          used = 0;
        }
        if (used == 0 || used != s.size() || !(v > 0) || !std::isfinite(v))
          return "must be a positive number, got '" + s + "'";
        return {};
      },
      "POSITIVE");
}

}  // namespace prt::cli

// Exit status: 0 success, 1 a user error (bad file, bad data), 2 a usage
// error (bad option), 3 an internal error (a bug), 130 interrupted (Ctrl-C).
int main(int argc, char** argv) {
  CLI::App app{"prt: Precomputed Radiance Transfer toolkit (spherical harmonics and wavelets).\n"
               "Conventions: docs/CONVENTIONS.md. Each subcommand has --help.",
               "prt"};
  app.set_version_flag("--version", std::string("prt " PRT_VERSION));
  app.require_subcommand(1);
  std::map<CLI::App*, prt::cli::Run> commands;
  auto add = [&](prt::cli::Run (*f)(CLI::App&)) {
    const std::size_t before = app.get_subcommands({}).size();
    prt::cli::Run run = f(app);
    commands[app.get_subcommands({})[before]] = std::move(run);
  };
  add(prt::cli::add_project);
  add(prt::cli::add_precompute);
  add(prt::cli::add_relight);
  add(prt::cli::add_render);
  add(prt::cli::add_reference);
  add(prt::cli::add_compare);
  add(prt::cli::add_info);
  add(prt::cli::add_verify);
  add(prt::cli::add_view);
  add(prt::cli::add_report);

  // CLI11 reports an unknown command as "a subcommand is required"; name it.
  if (argc > 1 && argv[1][0] != '-') {
    bool known = false;
    std::string names;
    for (const auto& [sub, run] : commands) {
      known |= sub->get_name() == argv[1];
      names += (names.empty() ? "" : ", ") + sub->get_name();
    }
    if (!known) {
      fmt::print(stderr, "prt: unknown command '{}' (commands: {}; see prt --help)\n", argv[1], names);
      return 2;
    }
  }
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    // CLI11 prints the message (or the help); its own codes (105, ...) become
    // the conventional usage-error status 2.
    return app.exit(e) == 0 ? 0 : 2;
  }
  for (auto& [sub, run] : commands) {
    if (!sub->parsed()) continue;
    try {
      return run();
    } catch (const prt::Error& e) {
      fmt::print(stderr, "prt {}: error: {}\n", sub->get_name(), e.what());
      return 1;
    } catch (const prt::InternalError& e) {
      fmt::print(stderr, "prt {}: {}\nThis is a bug in prt; please report it.\n", sub->get_name(), e.what());
      return 3;
    } catch (const std::bad_alloc&) {
      fmt::print(stderr, "prt {}: error: out of memory\n", sub->get_name());
      return 1;
    }
  }
  return 2;
}
