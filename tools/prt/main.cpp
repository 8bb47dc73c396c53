// prt: command-line front end. Parses, validates, calls the libraries,
// writes output; all the work is in the prt:: libraries.
#include "commands.h"

#include <prt/error.h>
#include <prt/mpi.h>

#include <fmt/core.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <string>

// Exit status: 0 success, 1 a user error (bad file, bad data), 2 a usage
// error (bad option: every bad option value, whether CLI11's validators or a
// command's UsageError find it), 3 an internal error (a bug), 130
// interrupted (Ctrl-C; nothing written).
namespace {
int run_command(int argc, char** argv);
}  // namespace

// Under mpirun (prt/mpi.h) every process runs the command; one that fails
// ends the whole job (MPI_Abort) with its status, so no process waits for it
// in an exchange.
int main(int argc, char** argv) {
  if (!prt::mpi::launched()) return run_command(argc, argv);
  try {
    prt::mpi::init(&argc, &argv);
  } catch (const prt::Error& e) {
    fmt::print(stderr, "prt: error: {}\n", e.what());
    return 1;
  }
  const int rc = run_command(argc, argv);
  if (rc != 0 && prt::mpi::world().size() > 1) prt::mpi::abort(rc);
  prt::mpi::finalize();
  return rc;
}

namespace {

int run_command(int argc, char** argv) {
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
  add(prt::cli::add_compress);
  add(prt::cli::add_relight);
  add(prt::cli::add_export);
  add(prt::cli::add_unwrap);
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
  // Usage errors look alike, from CLI11 or from a command (UsageError):
  // "prt CMD: error: --option: what is wrong", and where the options are.
  const std::string command = argc > 1 && argv[1][0] != '-' ? argv[1] : "";
  // Under mpirun with several processes each message says whose it is.
  const int ranks = prt::mpi::launched() ? prt::mpi::world().size() : 1;
  const std::string rank_tag =
      ranks > 1 ? fmt::format(" (rank {} of {})", prt::mpi::world().rank(), ranks) : std::string();
  const std::string who = command.empty() ? "prt" : "prt " + command;
  const auto usage_message = [who, rank_tag](const std::string& what) {
    return fmt::format("{0}{2}: error: {1}\nRun '{0} --help' for the options.\n", who, what, rank_tag);
  };
  app.failure_message([usage_message](const CLI::App*, const CLI::Error& e) -> std::string {
    return usage_message(e.what());
  });
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
      // Test hook (tests/test_cli.cpp, CliExitStatus): the command fails as
      // a bug in prt would, to pin exit status 3 and its message.
      if (std::getenv("PRT_TEST_INTERNAL_ERROR")) PRT_CHECK(!"PRT_TEST_INTERNAL_ERROR is set");
      return run();
    } catch (const prt::cli::UsageError& e) {
      fmt::print(stderr, "{}", usage_message(e.what()));
      return 2;
    } catch (const prt::Error& e) {
      fmt::print(stderr, "prt {}{}: error: {}\n", sub->get_name(), rank_tag, e.what());
      return 1;
    } catch (const prt::InternalError& e) {
      fmt::print(stderr, "prt {}{}: {}\nThis is a bug in prt; please report it.\n", sub->get_name(), rank_tag, e.what());
      return 3;
    } catch (const std::bad_alloc&) {
      fmt::print(stderr, "prt {}{}: error: out of memory\n", sub->get_name(), rank_tag);
      return 1;
    }
  }
  return 2;
}

}  // namespace
