#pragma once
// How the evaluation tools and the benchmarks report figures: a flat JSON object, medians and
// percentiles.

#include <cstdint>
#include <string>
#include <utility>
#include <vector>

namespace vog::eval {

// Insertion-ordered flat JSON object of numbers and strings, printed one key per line; a non-finite
// number is printed as null.
class JsonObject {
 public:
  void add(const std::string& key, double value);
  void add(const std::string& key, std::int64_t value);
  void add(const std::string& key, int value) { add(key, static_cast<std::int64_t>(value)); }
  void add(const std::string& key, const std::string& value);
  std::string str() const;

 private:
  std::vector<std::pair<std::string, std::string>> fields_;
};

// Linear interpolation between the order statistics; NaN for no values.
double percentile(std::vector<double> values, double p);  // p in [0, 1]
double median(std::vector<double> values);

}  // namespace vog::eval
