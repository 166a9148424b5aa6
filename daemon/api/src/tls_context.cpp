#include "vog/api/tls_context.hpp"

#include "vog/api/api_server.hpp"

#include <asio/ssl.hpp>

namespace vog::api {

Result<std::unique_ptr<asio::ssl::context>> makeTlsContext(const TlsServerConfig& c) {
  auto context = std::make_unique<asio::ssl::context>(asio::ssl::context::tls_server);
  asio::error_code ec;
  context->set_options(asio::ssl::context::default_workarounds | asio::ssl::context::no_sslv2 |
                           asio::ssl::context::no_sslv3 | asio::ssl::context::no_tlsv1 |
                           asio::ssl::context::no_tlsv1_1 | asio::ssl::context::single_dh_use,
                       ec);
  if (!ec) context->use_certificate_chain_file(c.certificate_chain_file.string(), ec);
  if (ec)
    return Error{"api.tls.certificate_file: cannot use " + c.certificate_chain_file.string() + ": " + ec.message()};
  context->use_private_key_file(c.private_key_file.string(), asio::ssl::context::pem, ec);
  if (ec) return Error{"api.tls.private_key_file: cannot use " + c.private_key_file.string() + ": " + ec.message()};
  if (::SSL_CTX_check_private_key(context->native_handle()) != 1)
    return Error{"api.tls.private_key_file: " + c.private_key_file.string() + " does not match the certificate"};
  return context;
}

}  // namespace vog::api
