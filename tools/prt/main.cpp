// prt: command-line front end. Parses, validates, calls the libraries,
// writes output; all the work is in the prt:: libraries.
#include "commands.h"

#include <prt/error.h>

#include <fmt/core.h>

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
}

}  // namespace prt::cli

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
  add(prt::cli::add_verify);

  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
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
