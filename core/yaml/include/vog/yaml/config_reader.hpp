#pragma once
// Reading a YAML configuration into structs of defaulted fields, one mapping at a time. Each call
// names a key, binds it to a field and states the allowed range; a key that is absent keeps the
// field's default. finish() rejects every key of the mapping that no call asked for. Every error
// names the file, the line, the full key and what was allowed, e.g.
//   "vogd.yaml:12: mapping.grid.resolution_m: must be in [0.01, 1], got 5".
//
// Lifecycle: a ConfigReader owns the parsed document; root() and map() hand out ConfigMap views that
// record which keys were read; check the first error with ConfigReader::status(). Parsing stops
// binding after the first error (later calls are no-ops), so the first problem is the one reported.

#include "vog/core/result.hpp"

#include <Eigen/Core>
#include <yaml-cpp/yaml.h>

#include <filesystem>

#include <cstdint>
#include <initializer_list>
#include <memory>
#include <optional>
#include <set>
#include <string>
#include <utility>
#include <span>
#include <vector>

namespace vog::yaml {

// The YAML document of `text`; a syntax error is "source:line: YAML syntax error: ...". An empty
// document is a null node.
Result<YAML::Node> parseDocument(const std::string& text, const std::string& source_name);
// The whole of `file` as text; the error names the file and `what` it was meant to be.
Result<std::string> readText(const std::filesystem::path& file, const std::string& what);
// "source:line" of a node of the document (line 0 for a node that is not in the file).
std::string location(const std::string& source_name, const YAML::Node& node);
// "source:line: key: what", the form of every error about a value of the document.
Error errorAt(const std::string& source_name, const YAML::Node& node, const std::string& key, const std::string& what);

class ConfigReader;

class ConfigMap {
 public:
  // A sub-mapping; an absent key gives an empty mapping (every field keeps its default).
  ConfigMap map(const std::string& key);
  void number(const std::string& key, double& field, double min, double max);
  // A number given in degrees in the file, stored in radians.
  void degrees(const std::string& key, double& field_rad, double min_deg, double max_deg);
  void integer(const std::string& key, int& field, int min, int max);
  void unsignedInteger(const std::string& key, std::uint64_t& field, std::uint64_t min, std::uint64_t max);
  void boolean(const std::string& key, bool& field);
  void text(const std::string& key, std::string& field, bool required = false);
  void choice(const std::string& key, std::string& field, std::initializer_list<const char*> allowed) {
    choice(key, field, std::span<const char* const>(allowed.begin(), allowed.size()));
  }
  void choice(const std::string& key, std::string& field, std::span<const char* const> allowed);
  // An enumeration named in the file by one of `names` (the same errors as choice()).
  template <class E>
  void enumeration(const std::string& key, E& field, std::initializer_list<std::pair<const char*, E>> names) {
    std::vector<const char*> allowed;
    std::string text;
    for (const auto& [name, value] : names) {
      allowed.push_back(name);
      if (value == field) text = name;
    }
    choice(key, text, allowed);
    for (const auto& [name, value] : names) {
      if (text == name) field = value;
    }
  }
  void vector3(const std::string& key, Eigen::Vector3d& field, double min, double max);
  // Reports every key that no call asked for.
  void finish();
  // Records an error for `key` of this mapping (cross-field checks).
  void fail(const std::string& key, const std::string& what);
  bool has(const std::string& key) const;
  // "source:line" of `key`'s value, or of this mapping when the key is absent (for later errors).
  std::string location(const std::string& key) const;
  std::string path(const std::string& key) const;

 private:
  friend class ConfigReader;
  ConfigMap(ConfigReader* reader, YAML::Node node, std::string path)
      : reader_(reader), node_(node), path_(std::move(path)) {}
  std::optional<YAML::Node> get(const std::string& key);

  ConfigReader* reader_;
  YAML::Node node_;
  std::string path_;
  std::set<std::string> read_;
};

class ConfigReader {
 public:
  // Errors: YAML syntax error (with its line), a top level that is not a mapping.
  static Result<std::unique_ptr<ConfigReader>> parse(const std::string& text, const std::string& source_name);

  ConfigMap root() { return ConfigMap(this, root_, ""); }
  // The first error recorded, or ok.
  Status status() const;
  const std::string& source() const { return source_; }

 private:
  friend class ConfigMap;
  ConfigReader(std::string source, YAML::Node root) : source_(std::move(source)), root_(root) {}
  void fail(const YAML::Node& node, const std::string& key, const std::string& what);
  bool failed() const { return error_.has_value(); }

  std::string source_;
  YAML::Node root_;
  std::optional<Error> error_;
};

}  // namespace vog::yaml
