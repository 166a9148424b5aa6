#include "vog/eval/figures.hpp"

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <sstream>

namespace vog::eval {

void JsonObject::add(const std::string& key, double value) {
  std::ostringstream os;
  if (std::isfinite(value)) {
    os << std::setprecision(10) << value;
  } else {
    os << "null";
  }
  fields_.emplace_back(key, os.str());
}

void JsonObject::add(const std::string& key, std::int64_t value) { fields_.emplace_back(key, std::to_string(value)); }

void JsonObject::add(const std::string& key, const std::string& value) {
  std::string quoted = "\"";
  for (char c : value) {
    if (c == '"' || c == '\\') quoted += '\\';
    quoted += c;
  }
  fields_.emplace_back(key, quoted + "\"");
}

std::string JsonObject::str() const {
  std::string out = "{\n";
  for (std::size_t i = 0; i < fields_.size(); ++i) {
    out += "  \"" + fields_[i].first + "\": " + fields_[i].second + (i + 1 < fields_.size() ? ",\n" : "\n");
  }
  return out + "}";
}

double median(std::vector<double> values) { return percentile(std::move(values), 0.5); }

double percentile(std::vector<double> values, double p) {
  if (values.empty()) return std::nan("");
  std::sort(values.begin(), values.end());
  const double pos = p * static_cast<double>(values.size() - 1);
  const auto lo = static_cast<std::size_t>(std::floor(pos));
  const auto hi = static_cast<std::size_t>(std::ceil(pos));
  return values[lo] + (values[hi] - values[lo]) * (pos - static_cast<double>(lo));
}

}  // namespace vog::eval
