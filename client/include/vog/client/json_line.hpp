#pragma once
// One flat JSON object per line (JSON Lines), enough for vogctl's machine-readable output.

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <string>
#include <string_view>

namespace vog::client {

class JsonLine {
 public:
  JsonLine& add(std::string_view key, std::string_view value) {
    std::string v = "\"";
    for (const char c : value) {
      if (c == '"' || c == '\\') {
        v += '\\';
        v += c;
      } else if (static_cast<unsigned char>(c) < 0x20) {
        char buf[8];
        std::snprintf(buf, sizeof buf, "\\u%04x", static_cast<unsigned>(static_cast<unsigned char>(c)));
        v += buf;
      } else {
        v += c;
      }
    }
    v += '"';
    return raw(key, v);
  }
  JsonLine& add(std::string_view key, const char* value) { return add(key, std::string_view(value)); }
  JsonLine& add(std::string_view key, double value) {
    if (!std::isfinite(value)) return raw(key, "null");
    char buf[40];
    std::snprintf(buf, sizeof buf, "%.10g", value);
    return raw(key, buf);
  }
  JsonLine& add(std::string_view key, std::int64_t value) { return raw(key, std::to_string(value)); }
  JsonLine& add(std::string_view key, std::uint64_t value) { return raw(key, std::to_string(value)); }
  JsonLine& add(std::string_view key, int value) { return raw(key, std::to_string(value)); }
  JsonLine& add(std::string_view key, unsigned value) { return raw(key, std::to_string(value)); }
  JsonLine& add(std::string_view key, bool value) { return raw(key, value ? "true" : "false"); }
  std::string str() const { return "{" + body_ + "}"; }

 private:
  JsonLine& raw(std::string_view key, std::string_view value) {
    if (!body_.empty()) body_ += ',';
    body_ += '"';
    body_ += key;
    body_ += "\":";
    body_ += value;
    return *this;
  }
  std::string body_;
};

}  // namespace vog::client
