#pragma once
// The API server's TLS context (asio::ssl, TLS 1.2 and newer), built from its certificate chain and
// private key. The server builds it at startup and `vogd --check-config` builds it to check the
// files, so both refuse the same files for the same reasons.

#include "vog/core/result.hpp"

#include <memory>

namespace asio::ssl {
class context;  // <asio/ssl/context.hpp>; a caller that keeps or destroys the context includes it
}

namespace vog::api {

struct TlsServerConfig;  // vog/api/api_server.hpp

// Errors name the setting and the file: a file that is missing or not PEM ("api.tls.certificate_file:
// cannot use F: ...", "api.tls.private_key_file: cannot use F: ..."), a key that does not match the
// certificate ("api.tls.private_key_file: F does not match the certificate").
Result<std::unique_ptr<asio::ssl::context>> makeTlsContext(const TlsServerConfig& config);

}  // namespace vog::api
