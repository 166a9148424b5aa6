#pragma once
// A process's CPU time and memory from /proc, for the benches that run vogd or vog-console as a child.

#include <sys/types.h>
#include <unistd.h>

#include <chrono>
#include <fstream>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

namespace vog::bench {

struct ProcSample {
  double t_s = 0.0;    // steady clock when sampled
  double cpu_s = 0.0;  // user + system
  double rss_mb = 0.0;
  double hwm_mb = 0.0;
};

inline std::optional<ProcSample> sampleProc(pid_t pid) {
  std::ifstream stat("/proc/" + std::to_string(pid) + "/stat");
  std::string line;
  if (!std::getline(stat, line)) return std::nullopt;
  // Fields after the parenthesised command name: state is field 3, utime 14, stime 15.
  std::istringstream rest(line.substr(line.rfind(')') + 2));
  std::vector<std::string> f;
  for (std::string w; rest >> w;) f.push_back(w);
  if (f.size() < 13) return std::nullopt;
  ProcSample s;
  s.t_s = std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
  s.cpu_s = (std::stod(f[11]) + std::stod(f[12])) / static_cast<double>(::sysconf(_SC_CLK_TCK));
  std::ifstream status("/proc/" + std::to_string(pid) + "/status");
  for (std::string l; std::getline(status, l);) {
    if (l.rfind("VmRSS:", 0) == 0) s.rss_mb = std::stod(l.substr(6)) / 1024.0;
    if (l.rfind("VmHWM:", 0) == 0) s.hwm_mb = std::stod(l.substr(6)) / 1024.0;
  }
  return s;
}

}  // namespace vog::bench
