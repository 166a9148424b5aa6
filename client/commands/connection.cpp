// Connection options, connecting and authenticating, the box syntax, and progress lines.

#include "command_util.hpp"

#include <cmath>
#include <fstream>
#include <sstream>

namespace vog::client {

namespace detail {

void report(const CommandIo& io, const std::string& command, const std::string& message) {
  io.err << "vogctl " << command << ": " << message << std::endl;
}

void ProgressLine::update(std::uint64_t received, std::uint64_t total) {
  if (!enabled_) return;
  const int percent = total == 0 ? 100 : static_cast<int>(100 * std::min(received, total) / total);
  if (percent == last_percent_) return;
  last_percent_ = percent;
  io_.err << '\r' << what_ << ": " << received << " / " << total << ' ' << unit_ << " (" << percent << "%)"
          << std::flush;
}

void ProgressLine::finish() {
  if (enabled_ && last_percent_ >= 0) io_.err << std::endl;
  last_percent_ = -1;
}

}  // namespace detail

ClientConfig ConnectionOptions::clientConfig() const {
  ClientConfig config;
  config.timeout = std::chrono::milliseconds(timeout_ms);
  config.tls.enabled = tls || !ca_file.empty();
  config.tls.ca_file = ca_file;
  return config;
}

void ConnectionOptions::addTo(CLI::App& cmd) {
  cmd.add_option("--host", host, "vogd host")->capture_default_str();
  cmd.add_option("--port", port, "vogd API port")->capture_default_str();
  cmd.add_option("--secret-file", secret_file, "File holding the operator secret (authenticates as operator)");
  cmd.add_option("--timeout-ms", timeout_ms, "Timeout of each call")
      ->check(CLI::Range(1, 3600000))
      ->capture_default_str();
  cmd.add_flag("--tls", tls, "Connect with TLS (vogd's api.tls)");
  cmd.add_option("--ca-file", ca_file, "CA certificate(s) that signed vogd's certificate, PEM (implies --tls)");
}

Result<std::string> readSecretFile(const std::string& file) {
  // A secret is short; a larger file is the wrong file.
  constexpr std::size_t kMaxSecretBytes = 4096;
  std::ifstream in(file, std::ios::binary);
  if (!in) return Error{"cannot read --secret-file " + file};
  std::string secret(kMaxSecretBytes + 1, '\0');
  in.read(secret.data(), static_cast<std::streamsize>(secret.size()));
  secret.resize(static_cast<std::size_t>(in.gcount()));
  if (secret.size() > kMaxSecretBytes) {
    return Error{"--secret-file " + file + " is longer than " + std::to_string(kMaxSecretBytes) +
                 " bytes: not a secret file"};
  }
  while (!secret.empty() && (secret.back() == '\n' || secret.back() == '\r')) secret.pop_back();
  if (secret.empty()) return Error{"--secret-file " + file + " is empty"};
  return secret;
}

Connection openConnection(const ConnectionOptions& options, const CommandIo& io, const std::string& command,
                          bool need_operator) {
  Connection out;
  if (need_operator && options.secret_file.empty()) {
    detail::report(io, command, "an operator command needs --secret-file FILE (the operator secret)");
    out.exit_code = kExitUsage;
    return out;
  }
  // Read the secret before connecting: a typo in the path is reported without a round trip.
  std::string secret;
  if (!options.secret_file.empty()) {
    auto s = readSecretFile(options.secret_file);
    if (!s) {
      detail::report(io, command, s.error().message);
      out.exit_code = kExitUsage;
      return out;
    }
    secret = std::move(*s);
  }
  auto c = ApiClient::connect(options.host, options.port, options.clientConfig());
  if (!c) {
    detail::report(io, command, c.error().message);
    out.exit_code = kExitUsage;
    return out;
  }
  if (!secret.empty()) {
    auto role = (*c)->authenticate(secret);
    if (!role) {
      detail::report(io, command, "authentication as operator failed: " + role.error().message);
      // A transport failure is a connection error; an answered refusal is the server's.
      out.exit_code = (*c)->broken() ? kExitUsage : kExitRefused;
      return out;
    }
  }
  out.client = std::move(*c);
  return out;
}

Result<api::ExplorationBox> parseBox(const std::string& text) {
  static constexpr const char* kNames[6] = {"xmin", "ymin", "zmin", "xmax", "ymax", "zmax"};
  double v[6];
  std::size_t start = 0;
  for (int i = 0; i < 6; ++i) {
    const std::size_t comma = text.find(',', start);
    if ((i < 5) != (comma != std::string::npos)) {
      return Error{"--box '" + text + "': expected 6 comma-separated numbers xmin,ymin,zmin,xmax,ymax,zmax (metres)"};
    }
    const std::string field = text.substr(start, comma == std::string::npos ? std::string::npos : comma - start);
    std::istringstream in(field);
    in.imbue(std::locale::classic());
    double x = 0.0;
    in >> x;
    if (!in || !(in >> std::ws).eof() || !std::isfinite(x)) {
      return Error{"--box '" + text + "': " + kNames[i] + " '" + field + "' is not a finite number"};
    }
    v[i] = x;
    start = comma + 1;
  }
  api::ExplorationBox box;
  box.min_world_m = {v[0], v[1], v[2]};
  box.max_world_m = {v[3], v[4], v[5]};
  if (Status s = box.validate(); !s.ok()) return Error{"--box '" + text + "': " + s.error().message};
  return box;
}

}  // namespace vog::client
