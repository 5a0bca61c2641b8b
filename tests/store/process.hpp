#pragma once
// Running the built `varbo` executable from tests: wait for it, or kill it with SIGKILL after a delay.
#include <fcntl.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <string>
#include <thread>
#include <vector>

namespace varbo::test {

struct ProcessResult {
  int exit_code = -1;   ///< -1 when killed by a signal
  bool killed = false;
};

/// Starts `args` (args[0] is the program) with stdout/stderr sent to `log` (appended).
inline pid_t spawn(const std::vector<std::string>& args, const std::string& log) {
  const pid_t pid = fork();
  if (pid == 0) {
    const int fd = ::open(log.c_str(), O_WRONLY | O_CREAT | O_APPEND, 0644);
    if (fd >= 0) {
      dup2(fd, 1);
      dup2(fd, 2);
      close(fd);
    }
    std::vector<char*> argv;
    for (const auto& a : args) argv.push_back(const_cast<char*>(a.c_str()));
    argv.push_back(nullptr);
    execv(argv[0], argv.data());
    _exit(127);
  }
  return pid;
}

inline ProcessResult wait_for(pid_t pid) {
  int status = 0;
  waitpid(pid, &status, 0);
  ProcessResult r;
  if (WIFEXITED(status)) r.exit_code = WEXITSTATUS(status);
  r.killed = WIFSIGNALED(status);
  return r;
}

inline ProcessResult run(const std::vector<std::string>& args, const std::string& log = "/dev/null") {
  return wait_for(spawn(args, log));
}

/// Runs `args` and sends SIGKILL after `seconds` unless it ended before.
inline ProcessResult run_and_kill(const std::vector<std::string>& args, double seconds, const std::string& log) {
  const pid_t pid = spawn(args, log);
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds);
  int status = 0;
  while (std::chrono::steady_clock::now() < deadline) {
    if (waitpid(pid, &status, WNOHANG) == pid) {
      ProcessResult r;
      if (WIFEXITED(status)) r.exit_code = WEXITSTATUS(status);
      r.killed = WIFSIGNALED(status);
      return r;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
  kill(pid, SIGKILL);
  return wait_for(pid);
}

}  // namespace varbo::test
