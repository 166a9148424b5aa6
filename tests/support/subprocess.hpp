#pragma once
// A child process for bench and process tests: posix_spawn with extra environment variables and
// stdout/stderr appended to a log file; waited for with a timeout; killed (SIGKILL) and reaped on
// destruction if still running. And the line protocol of a child's control socket.

#include <sys/types.h>

#include <filesystem>
#include <string>
#include <vector>

namespace vog::test {

class Subprocess {
 public:
  // args[0] is the executable's path. started() tells whether the spawn succeeded.
  Subprocess(const std::vector<std::string>& args, const std::vector<std::string>& extra_env,
             const std::filesystem::path& log_file);
  ~Subprocess();
  Subprocess(const Subprocess&) = delete;
  Subprocess& operator=(const Subprocess&) = delete;

  bool started() const { return started_; }
  pid_t pid() const { return pid_; }
  bool running();
  // The exit status (128 + signal when killed by one) within the timeout, else -1.
  int wait(double timeout_s);
  void signal(int sig) const;

 private:
  pid_t pid_ = -1;
  bool started_ = false;
  bool reaped_ = false;
  int exit_status_ = -1;
};

// The whole content of a text file (empty if it cannot be read).
std::string readTextFile(const std::filesystem::path& file);

// One line to a child's Unix-domain control socket and its one-line reply (without the LF);
// "connect failed" or the part read before the timeout when the child does not answer.
std::string controlRequest(const std::filesystem::path& socket, const std::string& line, double timeout_s = 2.0);

}  // namespace vog::test
