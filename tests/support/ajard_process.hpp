// The one launcher of the real ajard binary, for the end-to-end tests (tests/daemon, tests/tls) and
// the benchmark harnesses (tests/bench/harness.hpp's Daemon): a child process whose stdout and
// stderr go to files in a directory, in an environment stripped of systemd's variables (so that
// ajard logs to stderr and sends no notifications). The destructor kills what still runs (SIGKILL)
// and reaps it; stop() ends it gracefully (SIGTERM) first.
#pragma once

#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <optional>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

extern char** environ;

namespace ajar::test {

inline std::string read_text_file(const std::string& path) {
  std::ifstream in(path);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

class AjardProcess {
 public:
  // Which ajard binary to run (the tests' default is AJARD_PATH, the build tree's).
  struct Program {
    std::string path;
  };

  // Starts `program args...`; output in `dir`/NAME.stdout and .stderr (truncated). `extra_env`
  // ("NAME=value" each) is added to the environment. started() says whether the spawn worked.
  AjardProcess(Program program, const std::vector<std::string>& args, const std::string& dir,
               const std::string& name = "ajard", const std::vector<std::string>& extra_env = {})
      : stdout_path_(dir + "/" + name + ".stdout"), stderr_path_(dir + "/" + name + ".stderr") {
    std::vector<std::string> argv_text{program.path};
    argv_text.insert(argv_text.end(), args.begin(), args.end());
    std::vector<char*> argv;
    for (auto& a : argv_text)
      argv.push_back(a.data());
    argv.push_back(nullptr);
    std::vector<std::string> env_text;
    for (char** e = environ; *e != nullptr; ++e) {
      const std::string entry(*e);
      if (entry.starts_with("NOTIFY_SOCKET=") || entry.starts_with("INVOCATION_ID=") ||
          entry.starts_with("JOURNAL_STREAM=") || entry.starts_with("WATCHDOG_")) {
        continue;
      }
      env_text.push_back(entry);
    }
    env_text.insert(env_text.end(), extra_env.begin(), extra_env.end());
    std::vector<char*> envp;
    for (auto& e : env_text)
      envp.push_back(e.data());
    envp.push_back(nullptr);

    posix_spawn_file_actions_t actions;
    posix_spawn_file_actions_init(&actions);
    posix_spawn_file_actions_addopen(&actions, 1, stdout_path_.c_str(),
                                     O_WRONLY | O_CREAT | O_TRUNC, 0644);
    posix_spawn_file_actions_addopen(&actions, 2, stderr_path_.c_str(),
                                     O_WRONLY | O_CREAT | O_TRUNC, 0644);
    const int rc =
        posix_spawn(&pid_, program.path.c_str(), &actions, nullptr, argv.data(), envp.data());
    posix_spawn_file_actions_destroy(&actions);
    if (rc != 0) pid_ = -1;
  }
#ifdef AJARD_PATH
  // The build tree's ajard (the test targets define AJARD_PATH).
  AjardProcess(const std::vector<std::string>& args, const std::string& dir,
               const std::string& name = "ajard", const std::vector<std::string>& extra_env = {})
      : AjardProcess(Program{AJARD_PATH}, args, dir, name, extra_env) {}
#endif
  ~AjardProcess() {
    if (running()) {
      ::kill(pid_, SIGKILL);
      int status = 0;
      ::waitpid(pid_, &status, 0);
    }
  }
  AjardProcess(const AjardProcess&) = delete;
  AjardProcess& operator=(const AjardProcess&) = delete;

  bool started() const {
    return pid_ > 0;
  }
  bool running() const {
    return pid_ > 0 && !exit_code_;
  }
  pid_t pid() const {
    return pid_;
  }  // -1 when the spawn failed (stays valid after the exit)
  void signal(int signal_number) const {
    if (running()) ::kill(pid_, signal_number);
  }

  // The exit code (128 + N when killed by signal N), or nullopt when still running at the deadline.
  std::optional<int> wait_exit(std::chrono::milliseconds timeout = std::chrono::seconds(30)) {
    const auto deadline = std::chrono::steady_clock::now() + timeout;
    while (!exit_code_ && pid_ > 0) {
      int status = 0;
      const pid_t r = ::waitpid(pid_, &status, WNOHANG);
      if (r == pid_) {
        exit_code_ = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
        break;
      }
      if (std::chrono::steady_clock::now() > deadline) break;
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    return exit_code_;
  }
  // SIGTERM (ajard's orderly shutdown) and waits up to `timeout` for the exit; the destructor
  // kills it if it still runs then. The exit code as wait_exit's.
  std::optional<int> stop(std::chrono::milliseconds timeout = std::chrono::seconds(30)) {
    signal(SIGTERM);
    return wait_exit(timeout);
  }

  std::string out() const {
    return read_text_file(stdout_path_);
  }
  std::string err() const {
    return read_text_file(stderr_path_);
  }
  // Whether stderr holds `text` within `timeout`. ajard logs through an asynchronous logger: a
  // line it logged before something the test saw (its port file, a reply, an event) reaches
  // stderr a little later, so a test reading the log of a running ajard waits for the line (the
  // deadline is for a loaded machine; nothing asserts how long it took). After the exit, err().
  bool err_shows(const std::string& text,
                 std::chrono::milliseconds timeout = std::chrono::seconds(20)) const {
    const auto deadline = std::chrono::steady_clock::now() + timeout;
    for (;;) {
      if (err().find(text) != std::string::npos) return true;
      if (std::chrono::steady_clock::now() > deadline) return false;
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
  }
  const std::string& stderr_path() const {
    return stderr_path_;
  }

 private:
  std::string stdout_path_;
  std::string stderr_path_;
  pid_t pid_ = -1;
  std::optional<int> exit_code_;
};

// Waits until `path` holds a whole port number (ajard --port-file writes "PORT\n") or the process
// exits; nullopt then, or at the deadline. Looks every `interval` (the benchmarks' start-up figure
// wants a fine one).
inline std::optional<std::uint16_t> wait_for_port_file(
    const std::string& path, AjardProcess& process,
    std::chrono::milliseconds timeout = std::chrono::seconds(30),
    std::chrono::microseconds interval = std::chrono::milliseconds(10)) {
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  while (std::chrono::steady_clock::now() < deadline) {
    const std::string text = read_text_file(path);
    if (!text.empty() && text.back() == '\n') return static_cast<std::uint16_t>(std::stoul(text));
    if (process.wait_exit(std::chrono::milliseconds(0))) return std::nullopt;
    std::this_thread::sleep_for(interval);
  }
  return std::nullopt;
}

}  // namespace ajar::test
