// Who may talk to caustica-server and as which tenant: TLS (optionally mutual) on the listening
// port, and bearer tokens that map each client to a tenant.
//
// Tokens are checked by a server interceptor rather than an AuthMetadataProcessor, because the
// latter aborts on insecure credentials in the gRPC this builds against, and the plaintext
// development mode must work too. A sync-server interceptor cannot end a call before its handler
// runs, so the interceptor records a verdict per call and every handler must ask for it first:
//
//   grpc::Status RenderService::ListScenes(grpc::ServerContext* context, ...) {
//     absl::StatusOr<std::string> tenant = caller_tenant(*context);
//     if (!tenant.ok()) return <tenant.status() as a grpc::Status>;  // before any work
//     ... only *tenant's scenes ...
//   }
//
// As a safety net for handlers that do not ask (server reflection, or a handler that forgot), the
// interceptor also replaces every message a refused call sends with an empty one and its final
// status with the UNAUTHENTICATED verdict; the handler's work and side effects still happen then.
#pragma once

#include <grpcpp/security/server_credentials.h>
#include <grpcpp/server_context.h>
#include <grpcpp/support/server_interceptor.h>
#include <grpcpp/support/string_ref.h>

#include <cstddef>
#include <filesystem>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <unordered_map>

#include "absl/status/statusor.h"

namespace caustica::server {

// The tenant of every caller when the server has no token file (development mode).
inline constexpr char kDefaultTenant[] = "";

// Tokens shorter than this are refused when loading a token file: they could be guessed.
inline constexpr size_t kMinTokenLength = 16;

// [A-Za-z0-9._-]{1,64}: tenant names appear in logs and, later, in file names.
bool is_valid_tenant_name(std::string_view name);

// The tenants of a token file, in the style of Kubernetes' static token file: one `token,tenant`
// line per token (no quoting; spaces around fields are ignored), `#` comments and blank lines.
// A tenant may have several tokens, so that tokens can be rotated. Only the SHA-256 digests of
// the tokens are kept, so the table in memory does not hold the secrets themselves.
class TokenTable {
 public:
  // Errors name the file and line: "tokens.csv:3: token too short (...)".
  static absl::StatusOr<TokenTable> load(const std::filesystem::path& file);
  // The same, from the file's text; `file_name` only labels the errors.
  static absl::StatusOr<TokenTable> parse(std::string_view text, std::string_view file_name);

  // The tenant `token` belongs to, or nullopt.
  std::optional<std::string> tenant_of(std::string_view token) const;
  size_t size() const { return tenant_by_digest_.size(); }

 private:
  std::unordered_map<std::string, std::string> tenant_by_digest_;  // SHA-256 of a token -> tenant
};

// Maps the `authorization` metadata of a call to its tenant.
class Authenticator {
 public:
  // Development mode: every caller is kDefaultTenant, whatever it sends.
  Authenticator() = default;
  // Every caller must send `authorization: Bearer <token>` with a token of `tokens`.
  explicit Authenticator(TokenTable tokens) : tokens_(std::move(tokens)) {}

  bool requires_tokens() const { return tokens_.has_value(); }

  // The tenant of a call whose `authorization` value is `authorization` (nullopt: none sent).
  // UNAUTHENTICATED, saying what is wrong, when the header is missing, is not a Bearer token, or
  // names an unknown token.
  absl::StatusOr<std::string> tenant_of(std::optional<std::string_view> authorization) const;
  // The same from a call's whole metadata; more than one `authorization` entry is refused.
  absl::StatusOr<std::string> tenant_of(
      const std::multimap<grpc::string_ref, grpc::string_ref>& metadata) const;

 private:
  std::optional<TokenTable> tokens_;
};

// Calls that need no token: health checks, so that load balancers and Kubernetes probes, which
// cannot send one, work. Server reflection is not exempt: it is a development tool whose users
// can send the header (grpcurl -H), and the fewer unauthenticated calls the better.
bool is_exempt_from_tokens(std::string_view method);

// Registered with ServerBuilder::experimental().SetInterceptorCreators: judges every call that is
// not exempt by `authenticator` and records the verdict for caller_tenant until the call ends.
class AuthInterceptorFactory : public grpc::experimental::ServerInterceptorFactoryInterface {
 public:
  explicit AuthInterceptorFactory(std::shared_ptr<const Authenticator> authenticator)
      : authenticator_(std::move(authenticator)) {}
  grpc::experimental::Interceptor* CreateServerInterceptor(
      grpc::experimental::ServerRpcInfo* info) override;

 private:
  std::shared_ptr<const Authenticator> authenticator_;
};

// The verdict on the call of `context`: its tenant, or UNAUTHENTICATED with what is wrong.
// INTERNAL when there is none: an exempt call, or a server built without AuthInterceptorFactory
// (refusing then is the safe side). Valid while the handler runs.
absl::StatusOr<std::string> caller_tenant(const grpc::ServerContextBase& context);

// The PEM files of --tls-cert, --tls-key and --tls-client-ca (paths; empty: not given).
struct TlsFiles {
  std::string cert;       // certificate chain, the server's own first
  std::string key;        // its private key
  std::string client_ca;  // set: clients must present a certificate signed by one of these CAs
};

// Whether a --listen address is reachable from this machine only: 127.0.0.0/8, ::1, localhost,
// or a unix socket. An empty host (":50051") means every interface, so it is not.
bool is_loopback_listen_address(std::string_view listen);

// The credentials of the listening port `listen`: TLS from `tls` (the files are read and the key
// checked against the certificate here, with errors naming the flag and the file), or plaintext,
// which is refused unless `listen` is loopback or `insecure` (--insecure) is set.
absl::StatusOr<std::shared_ptr<grpc::ServerCredentials>> listen_credentials(std::string_view listen,
                                                                            const TlsFiles& tls,
                                                                            bool insecure);

}  // namespace caustica::server
