// grainbath command-line interface: run / check / theory / list-models / report.
#include <CLI/CLI.hpp>

#include <atomic>
#include <cerrno>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <iostream>
#include <set>
#include <string_view>

#include "cli/commands.hpp"
#include "core/case_file.hpp"
#include "dsmc/decomposition.hpp"

namespace {
const char* kUnits = R"(Units (scaled, Bisi & Spiga):
  DSMC:  lengths in grain-grain mean free paths (both collision cross-sections = 1:
         the path 1/(n sigma) at n = 1; the measured mean free path of a Maxwellian
         gas, resolution.mean_free_path, is 1/sqrt(2) = 0.71 of it),
         grain mass m ([grains] mass, default 1), temperatures in energy units (k_B = 1),
         velocities in sqrt(energy/mass), time in length/velocity.
         Background mass mB = alpha m / (1 - alpha), alpha = [background] mass_ratio;
         background collision rate (nB/eps)|v-w|, eps = [background] knudsen.
  EDMD:  lengths in grain diameters (sigma = 1), m = 1, temperatures in energy units.
See docs/CASE_FILE.md for every key, its default and its unit.
Environment: GRAINBATH_SIMD=sse2 forces the baseline SIMD paths of the DSMC kernels,
GRAINBATH_SIMD=avx2 rules out AVX-512 (default auto: AVX2 and AVX-512 where the CPU has
them; the results are the same bits).)";
}

namespace {
// `--out ""` (an unset shell variable: --out "$DIR") would silently mean the default directory,
// whose earlier output.previous a run then deletes; and CLI11 reads `--out=` (--out="$DIR") as
// taking the next word, so `--out= -q` wrote into a directory named "-q". Both are refused.
const CLI::Validator kNotEmpty(
    [](const std::string& s) {
      if (s.empty())
        return std::string("an empty path (an unset shell variable?): give a directory, or leave --out out for the "
                           "default");
      if (s.front() == '-')
        return "'" + s + "' looks like an option (an empty --out= takes the next word): give a directory (./" + s +
               " for one so named)";
      return std::string();
    },
    "", "not empty");

// theory, check and list-models: their standard output is what they make, so a write of it
// that failed is a failure (exit 1, said on stderr): `grainbath theory CASE > theory.json` on a
// full disk exited 0 with the file empty. A run's or a sweep's table is a copy of files they
// write, and a run goes on when its stdout is gone (`| head`): not checked there.
int written_to_stdout(int code, const char* command) {
  errno = 0;
  if (std::fflush(stdout) == 0 && !std::ferror(stdout)) return code;
  const int err = errno;
  std::fprintf(stderr, "error: %s: cannot write its output to standard output (%s)\n", command,
               err != 0 ? std::strerror(err) : "a write failed");
  return code == 0 ? 1 : code;
}

int cli_main(int argc, char** argv) {
  // A file-size limit (ulimit -f) must surface as a failed write with a clear message,
  // not kill the run and leave its temporary output behind.
  std::signal(SIGXFSZ, SIG_IGN);
  CLI::App app{"grainbath: kinetic theory and simulation of granular gases in a background medium"};
  app.footer(kUnits);
  app.require_subcommand(1);
  app.set_version_flag("--version", std::string("grainbath ") + GRAINBATH_VERSION + " (git " +
                                        grainbath::cli::build_commit() + ")");

  grainbath::cli::RunArgs run_args;
  auto* run = app.add_subcommand("run", "Run the case in CASE_DIR/case.toml; write OUT/results.h5 and OUT/summary.json");
  run->add_option("case_dir", run_args.case_dir, "Case directory holding case.toml")->required();
  run->add_option("--set", run_args.overrides, "Override a case key: section.key=value (repeatable)");
  run->add_option("--out", run_args.out_dir, "Output directory (default CASE_DIR/output)")->check(kNotEmpty);
  run->add_flag("--quiet,-q", run_args.quiet, "No progress line");
  run->add_flag("--resume", run_args.resume, "Continue from the newest valid checkpoint");
  run->footer(kUnits);

  grainbath::cli::RunArgs check_args;
  auto* check = app.add_subcommand("check", "Validate CASE_DIR/case.toml without running it");
  check->add_option("case_dir", check_args.case_dir, "Case directory holding case.toml")->required();
  check->add_option("--set", check_args.overrides, "Override a case key: section.key=value (repeatable)");

  grainbath::cli::RunArgs theory_args;
  auto* theory = app.add_subcommand("theory", "Print the theory (closures, expansions, hydrodynamic limit) for a case as JSON");
  theory->add_option("case_dir", theory_args.case_dir, "Case directory holding case.toml")->required();
  theory->add_option("--set", theory_args.overrides, "Override a case key: section.key=value (repeatable)");

  auto* list = app.add_subcommand("list-models", "List every restitution law, heat bath, boundary and background profile with its keys");

  grainbath::cli::SweepArgs sweep_args;
  auto* sweep = app.add_subcommand("sweep", "Run every combination of --set section.key=v1,v2,... and tabulate the results");
  sweep->add_option("case_dir", sweep_args.case_dir, "Case directory holding case.toml")->required();
  sweep->add_option("--set", sweep_args.overrides, "section.key=v1,v2,... (repeatable: the cartesian product is run)")->required();
  sweep->add_option("--out", sweep_args.out_dir, "Sweep directory (default CASE_DIR/sweep)")->check(kNotEmpty);
  sweep->add_option("--jobs,-j", sweep_args.jobs, "Variants run at once, >= 1 (default: the cores not busy with other processes)")
      ->check(CLI::Range(1, 4096));
  sweep->add_flag("--quiet,-q", sweep_args.quiet,
                  "No progress lines (a failed variant, warnings and errors are still reported)");
  sweep->add_flag("--resume", sweep_args.resume,
                  "Continue an interrupted sweep in its directory: finished variants are kept, stopped ones resume "
                  "from their checkpoints");

  grainbath::cli::ReportArgs report_args;
  auto* report = app.add_subcommand("report", "Make plots and report.md/report.html from a run's output");
  report->add_option("dir", report_args.dir, "Case directory or output directory")->required();
  report->add_option("--out", report_args.out_dir,
                     "Report directory (default OUTPUT_DIR/report): a new or empty directory, or one a report wrote")
      ->check(kNotEmpty);
  report->add_flag("--strict", report_args.strict, "Exit with an error when a section cannot be made");
  report->add_option("--x", report_args.x_key,
                     "Sweep report: the swept key to plot against (default: the numeric swept key with the most "
                     "values, as sweep.png; docs/OUTPUT.md)")
      ->check(kNotEmpty);

  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    if (e.get_exit_code() == 0) return app.exit(e);  // --help, --version
    // a command-line mistake (unknown option, missing argument, a value out of range) is bad
    // input like any other: exit 2 (docs/RELIABILITY.md), named by the subcommand it was for
    std::string command = "grainbath";
    for (const CLI::App* sub : app.get_subcommands()) command += " " + sub->get_name();
    // a first word that is no subcommand: say so and name the subcommands (review 4: "runn"
    // got "A subcommand is required")
    if (app.get_subcommands().empty() && argc > 1 && argv[1][0] != '-') {
      std::set<std::string> names;
      for (const CLI::App* sub : app.get_subcommands({})) names.insert(sub->get_name());
      const std::string hint = grainbath::closest_name(argv[1], names);
      std::string all;
      for (const auto& n : names) all += (all.empty() ? "" : ", ") + n;
      std::fprintf(stderr, "error: grainbath: unknown subcommand '%s'%s; the subcommands are %s\nRun 'grainbath --help' "
                   "for more information.\n",
                   argv[1], hint.empty() ? "" : (" (did you mean '" + hint + "'?)").c_str(), all.c_str());
      return 2;
    }
    std::fprintf(stderr, "error: %s: %s\nRun '%s --help' for more information.\n", command.c_str(), e.what(),
                 command.c_str());
    return 2;
  }
  // GRAINBATH_SIMD chooses the SIMD paths of the hot DSMC kernels (operators/random.hpp,
  // Philox4x32Lanes::have_avx2, have_avx512): unset or "auto" = AVX2 (and the AVX-512
  // paths) where the CPU has them, "avx2" = no AVX-512, "sse2" = the baseline; the
  // results are the same bits either way. A misspelt value is an error, not a silent "auto".
  if (const char* simd = std::getenv("GRAINBATH_SIMD"); simd != nullptr && std::string_view(simd) != "auto" &&
                                                         std::string_view(simd) != "avx2" &&
                                                         std::string_view(simd) != "sse2") {
    std::cerr << "error: environment variable GRAINBATH_SIMD: expected \"auto\", \"avx2\" or \"sse2\", found \""
              << simd << "\"\n";
    return 2;
  }
#ifndef GRAINBATH_MPI
  // This build has no MPI; under mpirun every process would run the whole case into the
  // same output (the last to finish wins, the others end up in OUT.previous)
  if (*run || *sweep) {
    const char* size = std::getenv("OMPI_COMM_WORLD_SIZE");
    if (size == nullptr) size = std::getenv("PMI_SIZE");
    if (size != nullptr && std::atoi(size) > 1) {
      const char* rank = std::getenv("OMPI_COMM_WORLD_RANK");
      if (rank == nullptr) rank = std::getenv("PMI_RANK");
      if (rank == nullptr || std::atoi(rank) == 0)
        std::fprintf(stderr,
                     "error: this grainbath was built without MPI, but runs as one of %s MPI processes: each would run "
                     "the whole case into the same output. Use the MPI build (cmake -DGRAINBATH_MPI=ON, e.g. "
                     "build-mpi/grainbath), or run without mpirun\n",
                     size);
      return 2;
    }
  }
#endif
  if (*run) return grainbath::cli::command_run(run_args);
  if (*check) return written_to_stdout(grainbath::cli::command_check(check_args), "check");
  if (*theory) return written_to_stdout(grainbath::cli::command_theory(theory_args), "theory");
  if (*list) return written_to_stdout(grainbath::cli::command_list_models(), "list-models");
  if (*sweep) return grainbath::cli::command_sweep(sweep_args);
  if (*report) return grainbath::cli::command_report(report_args);
  return 1;
}
}  // namespace

int main(int argc, char** argv) {
  // MPI build under mpirun: MPI is initialised here (src/dsmc/decomposition.cpp, mpi_env)
  grainbath::dsmc::mpi_env::init(&argc, &argv);
  const int code = cli_main(argc, argv);
  grainbath::dsmc::mpi_env::finalize();
  return code;
}
