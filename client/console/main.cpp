// vog-console: the live mission view in a browser (client/console/README.md).

#include "vog/client/vogctl.hpp"
#include "vog/console/console.hpp"

#include <CLI/CLI.hpp>
#include <openssl/rand.h>
#include <signal.h>

#include <array>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>

namespace {

bool isLoopback(const std::string& address) {
  return address.rfind("127.", 0) == 0 || address == "::1" || address == "localhost";
}

// 128 random bits as hex: what a page outside loopback must present.
vog::Result<std::string> newToken() {
  std::array<unsigned char, 16> bytes{};
  if (RAND_bytes(bytes.data(), static_cast<int>(bytes.size())) != 1) return vog::Error{"no random bytes for a token"};
  std::string out;
  for (const unsigned char b : bytes) {
    static constexpr char kHex[] = "0123456789abcdef";
    out += kHex[b >> 4];
    out += kHex[b & 15];
  }
  return out;
}

// The page's folder: --web-root, else the installed one next to the executable
// (<prefix>/share/vog/console), else the source tree's.
std::filesystem::path webRoot(const std::string& option) {
  if (!option.empty()) return option;
  std::error_code ec;
  const std::filesystem::path exe = std::filesystem::read_symlink("/proc/self/exe", ec);
  if (!ec) {
    const std::filesystem::path installed = exe.parent_path().parent_path() / "share/vog/console";
    if (std::filesystem::exists(installed / "index.html", ec)) return installed;
  }
  return VOG_CONSOLE_SOURCE_WEB_ROOT;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"vog-console: a live view of vogd's mission in a browser"};
  vog::client::ConnectionOptions connection;
  connection.addTo(app);
  std::string listen = "127.0.0.1:8080";
  std::string web_root;
  std::string token;
  std::string port_file;
  app.add_option("--listen", listen, "Address and port the page is served on (ADDR:PORT)")->capture_default_str();
  app.add_option("--web-root", web_root, "Folder of the page's files (default: the installed page)");
  app.add_option("--token", token,
                 "Token the page must present (default: none on loopback, a random one on any other address)");
  app.add_option("--port-file", port_file, "Write the page's port here once it is served (for scripts)");
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  }

  vog::console::ConsoleConfig config;
  config.host = connection.host;
  config.port = connection.port;
  config.client = connection.clientConfig();
  config.client.client_name = "vog-console";
  if (connection.secret_file.empty()) {
    config.no_secret_why = "vog-console was started without --secret-file (observer only)";
  } else {
    auto secret = vog::client::readSecretFile(connection.secret_file);
    if (!secret) {
      std::cerr << "vog-console: " << secret.error().message << "\n";
      return 2;
    }
    config.secret = std::move(secret).value();
  }
  const std::size_t colon = listen.rfind(':');
  if (colon == std::string::npos || colon == 0) {
    std::cerr << "vog-console: --listen '" << listen << "': expected ADDR:PORT\n";
    return 2;
  }
  config.web.address = listen.substr(0, colon);
  if (config.web.address.size() > 2 && config.web.address.front() == '[' && config.web.address.back() == ']') {
    config.web.address = config.web.address.substr(1, config.web.address.size() - 2);
  }
  try {
    const int port = std::stoi(listen.substr(colon + 1));
    if (port < 0 || port > 65535) throw std::out_of_range("port");
    config.web.port = static_cast<std::uint16_t>(port);
  } catch (const std::exception&) {
    std::cerr << "vog-console: --listen '" << listen << "': the port is not a number in 0..65535\n";
    return 2;
  }
  config.web.web_root = webRoot(web_root);
  if (token.empty() && !isLoopback(config.web.address)) {
    auto t = newToken();
    if (!t) {
      std::cerr << "vog-console: " << t.error().message << "\n";
      return 1;
    }
    token = std::move(t).value();
  }
  config.web.token = token;

  // SIGINT and SIGTERM end the console; blocked here so every thread started below inherits the mask.
  sigset_t signals;
  sigemptyset(&signals);
  sigaddset(&signals, SIGINT);
  sigaddset(&signals, SIGTERM);
  pthread_sigmask(SIG_BLOCK, &signals, nullptr);

  auto console = vog::console::Console::start(std::move(config));
  if (!console) {
    std::cerr << "vog-console: " << console.error().message << "\n";
    return 1;
  }
  const std::string shown = listen.substr(0, colon) == "0.0.0.0" ? "HOST" : listen.substr(0, colon);
  std::cout << "vog-console: serving http://" << shown << ":" << (*console)->webPort() << "/"
            << (token.empty() ? "" : "?token=" + token) << " (vogd at " << connection.host << ":" << connection.port
            << ")" << std::endl;
  if (!port_file.empty()) {
    const std::filesystem::path tmp = port_file + ".tmp";
    std::ofstream(tmp) << (*console)->webPort() << "\n";
    std::error_code ec;
    std::filesystem::rename(tmp, port_file, ec);
    if (ec) std::cerr << "vog-console: --port-file " << port_file << ": " << ec.message() << "\n";
  }
  int received = 0;
  sigwait(&signals, &received);
  (*console)->stop();
  return 0;
}
