#pragma once
// Options shared by the vogctl subcommands that talk to vogd: --host, --port, --secret-file,
// --timeout-ms; and the connection they open.

#include "vog/client/api_client.hpp"

#include <CLI/CLI.hpp>

#include <cstdio>
#include <memory>
#include <string>

namespace vog::client {

inline constexpr std::uint16_t kDefaultApiPort = 7400;

struct ConnectionOptions {
  std::string host = "127.0.0.1";
  std::uint16_t port = kDefaultApiPort;
  std::string secret_file;  // when set: authenticate as operator
  int timeout_ms = 10000;

  void addTo(CLI::App& cmd) {
    cmd.add_option("--host", host, "vogd host")->capture_default_str();
    cmd.add_option("--port", port, "vogd API port")->capture_default_str();
    cmd.add_option("--secret-file", secret_file, "File holding the operator secret (authenticates as operator)");
    cmd.add_option("--timeout-ms", timeout_ms, "Timeout of each call")->check(CLI::Range(1, 3600000))->capture_default_str();
  }

  // Connects (and authenticates when a secret file is given); prints the reason and returns null
  // on failure.
  std::unique_ptr<ApiClient> open() const {
    ClientConfig config;
    config.timeout = std::chrono::milliseconds(timeout_ms);
    auto c = ApiClient::connect(host, port, config);
    if (!c) {
      std::fprintf(stderr, "vogctl: %s\n", c.error().message.c_str());
      return nullptr;
    }
    if (!secret_file.empty()) {
      std::FILE* f = std::fopen(secret_file.c_str(), "rb");
      if (f == nullptr) {
        std::fprintf(stderr, "vogctl: cannot read --secret-file %s\n", secret_file.c_str());
        return nullptr;
      }
      std::string secret(4096, '\0');  // a secret is short; more is not a secret file
      secret.resize(std::fread(secret.data(), 1, secret.size(), f));
      std::fclose(f);
      // A trailing newline from an editor or `echo` is not part of the secret.
      while (!secret.empty() && (secret.back() == '\n' || secret.back() == '\r')) secret.pop_back();
      auto role = (*c)->authenticate(secret);
      if (!role) {
        std::fprintf(stderr, "vogctl: authentication failed: %s\n", role.error().message.c_str());
        return nullptr;
      }
    }
    return std::move(*c);
  }
};

}  // namespace vog::client
