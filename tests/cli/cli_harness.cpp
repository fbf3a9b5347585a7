#include "tests/cli/cli_harness.hpp"

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <thread>
#include <optional>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <sstream>
#include <stdexcept>

namespace grainbath::testing {

TempDir::TempDir() {
  const char* base = std::getenv("TMPDIR");
  std::string tmpl = std::string(base && *base ? base : "/tmp") + "/grainbath-cli-XXXXXX";
  std::vector<char> buf(tmpl.begin(), tmpl.end());
  buf.push_back('\0');
  if (!::mkdtemp(buf.data())) throw std::runtime_error("mkdtemp failed");
  path_ = fs::path(buf.data());
}

TempDir::~TempDir() {
  std::error_code ec;
  // Make everything removable again (tests chmod things).
  for (auto it = fs::recursive_directory_iterator(path_, fs::directory_options::skip_permission_denied, ec);
       !ec && it != fs::recursive_directory_iterator(); it.increment(ec)) {
    std::error_code ec2;
    if (it->is_directory(ec2)) fs::permissions(it->path(), fs::perms::owner_all, fs::perm_options::add, ec2);
  }
  fs::permissions(path_, fs::perms::owner_all, fs::perm_options::add, ec);
  fs::remove_all(path_, ec);
}

std::string RunResult::describe() const {
  std::string s = timed_out ? "timed out" : exited ? "exit " + std::to_string(code) : "signal " + std::to_string(signal);
  return s + "\n--- stderr:\n" + err + "--- stdout:\n" + out;
}

RunResult run_binary(const std::vector<std::string>& args, const RunOptions& opt) {
  int out_pipe[2], err_pipe[2];
  if (::pipe2(out_pipe, O_CLOEXEC) != 0 || ::pipe2(err_pipe, O_CLOEXEC) != 0) throw std::runtime_error("pipe failed");
  std::vector<std::string> argv_s = args;
  std::vector<char*> argv;
  for (auto& a : argv_s) argv.push_back(a.data());
  argv.push_back(nullptr);
  const pid_t pid = ::fork();
  if (pid < 0) throw std::runtime_error("fork failed");
  if (pid == 0) {
    ::dup2(out_pipe[1], 1);
    ::dup2(err_pipe[1], 2);
    if (opt.stdout_to_dev_full) {
      const int full = ::open("/dev/full", O_WRONLY);
      if (full < 0) ::_exit(123);
      ::dup2(full, 1);
    }
    const int devnull = ::open("/dev/null", O_RDONLY);
    if (devnull >= 0) ::dup2(devnull, 0);
    if (!opt.cwd.empty() && ::chdir(opt.cwd.c_str()) != 0) ::_exit(120);
    if (opt.file_size_limit) {
      if (opt.ignore_sigxfsz) ::signal(SIGXFSZ, SIG_IGN);  // inherited across exec
      struct rlimit rl {*opt.file_size_limit, *opt.file_size_limit};
      if (::setrlimit(RLIMIT_FSIZE, &rl) != 0) ::_exit(121);
    }
    if (opt.address_space_limit) {
      struct rlimit rl {*opt.address_space_limit, *opt.address_space_limit};
      if (::setrlimit(RLIMIT_AS, &rl) != 0) ::_exit(122);
    }
    for (const auto& [name, value] : opt.env) ::setenv(name.c_str(), value.c_str(), 1);
    // the stop signals at their defaults whatever the test was started with (a background job
    // of a non-interactive shell ignores SIGINT, and grainbath keeps an ignored signal ignored),
    // then those the test wants ignored
    for (const int sig : {SIGINT, SIGTERM, SIGHUP, SIGUSR1, SIGXCPU}) ::signal(sig, SIG_DFL);
    for (const int sig : opt.ignored_signals) ::signal(sig, SIG_IGN);  // inherited across exec
    ::execv(argv[0], argv.data());
    ::_exit(127);
  }
  ::close(out_pipe[1]);
  ::close(err_pipe[1]);
  RunResult r;
  pollfd fds[2] = {{out_pipe[0], POLLIN, 0}, {err_pipe[0], POLLIN, 0}};
  std::string* sinks[2] = {&r.out, &r.err};
  int open_fds = 2;
  if (opt.close_stdout) {  // the child's writes to stdout then fail (EPIPE, or SIGPIPE unless ignored)
    ::close(out_pipe[0]);
    fds[0].fd = -1;
    --open_fds;
  }
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(opt.timeout_s);
  bool sent = false, sent_again = false;
  std::optional<std::chrono::steady_clock::time_point> send_at;
  while (open_fds > 0) {
    if (opt.send_signal && !sent) {
      std::error_code ec;
      if (!send_at && r.err.find(opt.send_when) != std::string::npos &&
          (opt.send_when_exists.empty() || fs::exists(opt.send_when_exists, ec)))
        send_at = std::chrono::steady_clock::now() + std::chrono::milliseconds(300);
      if (send_at && std::chrono::steady_clock::now() >= *send_at) {
        ::kill(pid, opt.send_signal);
        sent = true;
      }
    } else if (opt.send_signal && !opt.send_again_when.empty() && !sent_again &&
               r.err.find(opt.send_again_when) != std::string::npos) {
      if (opt.pause_before_again_s > 0) {
        ::kill(pid, SIGSTOP);
        std::this_thread::sleep_for(std::chrono::duration<double>(opt.pause_before_again_s));
        ::kill(pid, opt.send_signal);  // pending until the child continues
        ::kill(pid, SIGCONT);
      } else {
        ::kill(pid, opt.send_signal);
      }
      sent_again = true;
    }
    const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - std::chrono::steady_clock::now());
    if (left.count() <= 0) {
      ::kill(pid, SIGKILL);
      r.timed_out = true;
      break;
    }
    const bool waiting_to_send = opt.send_signal && (!sent || (!opt.send_again_when.empty() && !sent_again));
    const int wait_ms = waiting_to_send ? 50 : static_cast<int>(left.count());
    if (::poll(fds, 2, std::min(wait_ms, static_cast<int>(left.count()))) < 0) break;
    for (int k = 0; k < 2; ++k) {
      if (fds[k].fd < 0 || !(fds[k].revents & (POLLIN | POLLHUP | POLLERR))) continue;
      char buf[4096];
      const ssize_t n = ::read(fds[k].fd, buf, sizeof buf);
      if (n > 0) {
        sinks[k]->append(buf, static_cast<std::size_t>(n));
      } else {
        ::close(fds[k].fd);
        fds[k].fd = -1;
        --open_fds;
      }
    }
  }
  for (auto& f : fds)
    if (f.fd >= 0) ::close(f.fd);
  int status = 0;
  ::waitpid(pid, &status, 0);
  if (WIFEXITED(status)) {
    r.exited = !r.timed_out;
    r.code = WEXITSTATUS(status);
  } else if (WIFSIGNALED(status)) {
    r.signal = WTERMSIG(status);
  }
  return r;
}

std::map<std::string, long long> listing(const fs::path& root) {
  std::map<std::string, long long> out;
  std::error_code ec;
  for (auto it = fs::recursive_directory_iterator(root, fs::directory_options::skip_permission_denied, ec);
       !ec && it != fs::recursive_directory_iterator(); it.increment(ec)) {
    std::error_code ec2;
    const bool dir = it->is_directory(ec2);
    out[fs::relative(it->path(), root).string()] = dir ? -1 : static_cast<long long>(it->file_size(ec2));
  }
  return out;
}

void write_text(const fs::path& p, const std::string& text) {
  fs::create_directories(p.parent_path());
  std::ofstream f(p, std::ios::binary | std::ios::trunc);
  f << text;
  if (!f) throw std::runtime_error("cannot write " + p.string());
}

std::string read_text(const fs::path& p) {
  std::ifstream f(p, std::ios::binary);
  std::ostringstream ss;
  ss << f.rdbuf();
  return ss.str();
}

}  // namespace grainbath::testing
