#include "vog/yaml/config_reader.hpp"

#include "vog/geometry/sonar.hpp"

#include <cmath>
#include <fstream>
#include <limits>
#include <sstream>

namespace vog::yaml {
namespace {

std::string formatNumber(double v) {
  std::ostringstream s;
  s << v;
  return s.str();
}

// A scalar as a finite double; nullopt when it is not one.
std::optional<double> asNumber(const YAML::Node& node) {
  if (!node.IsScalar()) return std::nullopt;
  try {
    const double v = node.as<double>();
    if (!std::isfinite(v)) return std::nullopt;
    return v;
  } catch (const YAML::Exception&) {
    return std::nullopt;
  }
}

}  // namespace

Result<YAML::Node> parseDocument(const std::string& text, const std::string& source_name) {
  try {
    return YAML::Load(text);
  } catch (const YAML::Exception& e) {
    return Error{source_name + ":" + std::to_string(e.mark.line + 1) + ": YAML syntax error: " + e.msg};
  }
}

Result<std::string> readText(const std::filesystem::path& file, const std::string& what) {
  std::ifstream in(file, std::ios::binary);
  if (!in) return Error{"cannot open " + what + " " + file.string()};
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

std::string location(const std::string& source_name, const YAML::Node& node) {
  const int line = node.IsDefined() && node.Mark().line >= 0 ? node.Mark().line + 1 : 0;
  return source_name + ":" + std::to_string(line);
}

Error errorAt(const std::string& source_name, const YAML::Node& node, const std::string& key, const std::string& what) {
  return Error{location(source_name, node) + ": " + key + ": " + what};
}

Result<std::unique_ptr<ConfigReader>> ConfigReader::parse(const std::string& text, const std::string& source_name) {
  auto document = parseDocument(text, source_name);
  if (!document) return document.error();
  YAML::Node root = document.value();
  if (root.IsNull()) root = YAML::Node(YAML::NodeType::Map);
  if (!root.IsMap()) return Error{source_name + ":1: the configuration must be a mapping of sections"};
  return std::unique_ptr<ConfigReader>(new ConfigReader(source_name, root));
}

Status ConfigReader::status() const {
  if (error_) return *error_;
  return Status::success();
}

void ConfigReader::fail(const YAML::Node& node, const std::string& key, const std::string& what) {
  if (error_) return;
  error_ = errorAt(source_, node, key, what);
}

std::string ConfigMap::path(const std::string& key) const { return path_.empty() ? key : path_ + "." + key; }

bool ConfigMap::has(const std::string& key) const { return node_.IsMap() && node_[key].IsDefined(); }

std::string ConfigMap::location(const std::string& key) const {
  return yaml::location(reader_->source_, has(key) ? node_[key] : node_);
}

std::optional<YAML::Node> ConfigMap::get(const std::string& key) {
  read_.insert(key);
  if (reader_->failed() || !node_.IsMap()) return std::nullopt;
  YAML::Node n = node_[key];
  if (!n.IsDefined() || n.IsNull()) return std::nullopt;
  return n;
}

void ConfigMap::fail(const std::string& key, const std::string& what) {
  const YAML::Node n = node_.IsMap() && node_[key].IsDefined() ? node_[key] : node_;
  reader_->fail(n, path(key), what);
}

ConfigMap ConfigMap::map(const std::string& key) {
  auto n = get(key);
  if (!n) return ConfigMap(reader_, YAML::Node(YAML::NodeType::Map), path(key));
  if (!n->IsMap()) {
    reader_->fail(*n, path(key), "must be a mapping of keys");
    return ConfigMap(reader_, YAML::Node(YAML::NodeType::Map), path(key));
  }
  return ConfigMap(reader_, *n, path(key));
}

void ConfigMap::number(const std::string& key, double& field, double min, double max) {
  auto n = get(key);
  if (!n) return;
  const auto v = asNumber(*n);
  if (!v)
    return reader_->fail(*n, path(key),
                         "must be a number, got '" + (n->IsScalar() ? n->Scalar() : "a list or mapping") + "'");
  if (*v < min || *v > max)
    return reader_->fail(*n, path(key),
                         "must be in [" + formatNumber(min) + ", " + formatNumber(max) + "], got " + formatNumber(*v));
  field = *v;
}

void ConfigMap::degrees(const std::string& key, double& field_rad, double min_deg, double max_deg) {
  double deg = geometry::rad2deg(field_rad);
  const bool present = has(key);
  number(key, deg, min_deg, max_deg);
  if (present && !reader_->failed()) field_rad = geometry::deg2rad(deg);
}

void ConfigMap::integer(const std::string& key, int& field, int min, int max) {
  auto n = get(key);
  if (!n) return;
  const auto v = asNumber(*n);
  if (!v || std::floor(*v) != *v)
    return reader_->fail(*n, path(key),
                         "must be an integer, got '" + (n->IsScalar() ? n->Scalar() : "a list or mapping") + "'");
  if (*v < min || *v > max)
    return reader_->fail(
        *n, path(key),
        "must be in [" + std::to_string(min) + ", " + std::to_string(max) + "], got " + formatNumber(*v));
  field = static_cast<int>(*v);
}

void ConfigMap::unsignedInteger(const std::string& key, std::uint64_t& field, std::uint64_t min, std::uint64_t max) {
  auto n = get(key);
  if (!n) return;
  std::uint64_t v = 0;
  try {
    if (!n->IsScalar() || n->Scalar().empty() || n->Scalar()[0] == '-') throw YAML::Exception(n->Mark(), "sign");
    v = n->as<std::uint64_t>();
  } catch (const YAML::Exception&) {
    return reader_->fail(
        *n, path(key),
        "must be a non-negative integer, got '" + (n->IsScalar() ? n->Scalar() : "a list or mapping") + "'");
  }
  if (v < min || v > max)
    return reader_->fail(
        *n, path(key),
        "must be in [" + std::to_string(min) + ", " + std::to_string(max) + "], got " + std::to_string(v));
  field = v;
}

void ConfigMap::boolean(const std::string& key, bool& field) {
  auto n = get(key);
  if (!n) return;
  try {
    if (!n->IsScalar()) throw YAML::Exception(n->Mark(), "not scalar");
    field = n->as<bool>();
  } catch (const YAML::Exception&) {
    reader_->fail(*n, path(key),
                  "must be true or false, got '" + (n->IsScalar() ? n->Scalar() : "a list or mapping") + "'");
  }
}

void ConfigMap::text(const std::string& key, std::string& field, bool required) {
  auto n = get(key);
  if (!n) {
    if (required && !reader_->failed()) reader_->fail(node_, path(key), "missing required key");
    return;
  }
  if (!n->IsScalar()) return reader_->fail(*n, path(key), "must be a string");
  field = n->Scalar();
}

void ConfigMap::choice(const std::string& key, std::string& field, std::span<const char* const> allowed) {
  auto n = get(key);
  if (!n) return;
  std::string list;
  for (const char* a : allowed) {
    if (n->IsScalar() && n->Scalar() == a) {
      field = a;
      return;
    }
    list += (list.empty() ? "" : ", ") + std::string(a);
  }
  reader_->fail(*n, path(key),
                "must be one of " + list + ", got '" + (n->IsScalar() ? n->Scalar() : "a list or mapping") + "'");
}

void ConfigMap::vector3(const std::string& key, Eigen::Vector3d& field, double min, double max) {
  auto n = get(key);
  if (!n) return;
  if (!n->IsSequence() || n->size() != 3) return reader_->fail(*n, path(key), "must be a list of 3 numbers [x, y, z]");
  Eigen::Vector3d v;
  for (std::size_t i = 0; i < 3; ++i) {
    const auto x = asNumber((*n)[i]);
    if (!x) return reader_->fail(*n, path(key), "element " + std::to_string(i) + " is not a number");
    if (*x < min || *x > max)
      return reader_->fail(*n, path(key),
                           "element " + std::to_string(i) + " must be in [" + formatNumber(min) + ", " +
                               formatNumber(max) + "], got " + formatNumber(*x));
    v[static_cast<Eigen::Index>(i)] = *x;
  }
  field = v;
}

void ConfigMap::finish() {
  if (reader_->failed() || !node_.IsMap()) return;
  for (const auto& kv : node_) {
    const std::string k = kv.first.IsScalar() ? kv.first.Scalar() : std::string("?");
    if (read_.count(k) == 0) {
      std::string list;
      for (const auto& r : read_) list += (list.empty() ? "" : ", ") + r;
      return reader_->fail(kv.first, path(k), "unknown key (allowed here: " + list + ")");
    }
  }
}

}  // namespace vog::yaml
