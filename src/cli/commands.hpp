#pragma once
#include <string>
#include <vector>

namespace grainbath::cli {

struct RunArgs {
  std::string case_dir;
  std::vector<std::string> overrides;
  std::string out_dir;
  bool quiet = false;
  bool resume = false;
  bool alone = false;  // MPI build: run in this process only (an ensemble replica), not split over the ranks
};

struct SweepArgs {
  std::string case_dir;
  std::vector<std::string> overrides;  // section.key=v1,v2,...
  std::string out_dir;
  int jobs = 0;                        // 0: number of cores
  bool resume = false;                 // continue an interrupted sweep in out_dir
  bool quiet = false;                  // no progress lines (failures, warnings, errors still)
};

// Stop requests (SIGINT, SIGTERM, SIGHUP, SIGUSR1, SIGXCPU; commands.cpp on_signal): installs
// the handler, and says whether one arrived. A sweep uses them to stop starting variants.
void install_stop_handlers();
bool stop_requested();
const std::vector<int>& stop_signals();  // SIGINT, SIGTERM, SIGHUP, SIGUSR1, SIGXCPU

// Exit codes: 0 success, 1 run failure, 2 bad input (case file, overrides, paths).
int command_run(const RunArgs&);
int command_check(const RunArgs&);
// The case-file problems of a case with its overrides, one message each (none: valid).
std::vector<std::string> case_problems(const RunArgs&);
// "key=value" for every checksum of a file the case names (CaseReader::record_file_checksum),
// empty when the case has problems: part of what a sweep is (sweep.identity).
std::vector<std::string> case_file_checksums(const RunArgs&);
int command_sweep(const SweepArgs&);
int command_theory(const RunArgs&);
int command_list_models();
struct ReportArgs {
  std::string dir;
  std::string out_dir;  // "": report.py's default (OUTPUT_DIR/report)
  bool strict = false;
  std::string x_key;    // "": a sweep report's default x axis (docs/OUTPUT.md, "Sweep directories")
};
// Runs python/report.py (no shell in between) and returns its exit status: 0 done, 2 bad
// input, 3 a Python module missing (python/README.md); 1 when report.py cannot be found (or
// $GRAINBATH_PYTHON_DIR has none), 127 when Python cannot be run.
int command_report(const ReportArgs&);

// The git commit of this build ("unknown" outside a git checkout; "-dirty" with uncommitted
// changes): `grainbath --version` and summary.json run.commit.
const char* build_commit();

}  // namespace grainbath::cli
