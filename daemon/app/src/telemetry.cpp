#include "vog/app/telemetry.hpp"

namespace vog::app {
namespace {

double seconds(std::int64_t stamp_ns) { return 1e-9 * static_cast<double>(stamp_ns); }

Status openCsv(std::ofstream& f, const std::filesystem::path& file, const char* header) {
  const bool fresh = !std::filesystem::exists(file);
  f.open(file, std::ios::app);
  if (!f) return Error{"cannot open " + file.string()};
  if (fresh) f << header << "\n" << std::flush;
  return {};
}

}  // namespace

Result<std::unique_ptr<TelemetryFiles>> TelemetryFiles::open(const std::filesystem::path& mission_dir) {
  std::unique_ptr<TelemetryFiles> t(new TelemetryFiles());
  if (Status st = openCsv(t->plans_, mission_dir / "iterations.csv",
                          "iteration,sim_s,n_submaps,plan_ms,status,best_gain,tree_size,coverage");
      !st)
    return st.error();
  if (Status st = openCsv(t->merges_, mission_dir / "merges.csv", "sim_s,n_submaps,merge_ms,remerged"); !st)
    return st.error();
  return t;
}

void TelemetryFiles::plan(std::int64_t stamp_ns, std::size_t n_submaps, double ms, const plan::PlanResult& result) {
  plans_ << plan_iteration_++ << ',' << seconds(stamp_ns) << ',' << n_submaps << ',' << ms << ','
         << plan::toString(result.status) << ',' << result.best_gain << ',' << result.tree_size << ",\n"
         << std::flush;
}

void TelemetryFiles::merge(std::int64_t stamp_ns, const map::MergeRecord& record) {
  merges_ << seconds(stamp_ns) << ',' << record.n_submaps << ',' << record.merge_ms << ',' << record.stats.remerged
          << '\n'
          << std::flush;
}

}  // namespace vog::app
