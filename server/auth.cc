// Token files, the authentication interceptor and its per-call verdicts, and the listening port's
// credentials (see auth.h).
#include "server/auth.h"

#include <arpa/inet.h>
#include <grpcpp/security/server_credentials.h>
#include <grpcpp/support/byte_buffer.h>
#include <grpcpp/support/slice.h>
#include <openssl/err.h>
#include <openssl/evp.h>
#include <openssl/pem.h>
#include <openssl/x509.h>

#include <cerrno>
#include <cstring>
#include <fstream>
#include <mutex>
#include <sstream>
#include <utility>
#include <vector>

#include "absl/strings/ascii.h"
#include "absl/strings/str_cat.h"
#include "proto/wire/bearer_token.h"
#include "server/log.h"

namespace caustica::server {
namespace {

constexpr std::string_view kAuthorization = "authorization";
constexpr std::string_view kSendBearer = "send 'authorization: Bearer <token>'";

// absl's own string_view (this absl does not alias std's), for StrCat.
absl::string_view av(std::string_view text) { return absl::string_view(text.data(), text.size()); }

std::string_view trim(std::string_view text) {
  const auto space = [](char c) { return absl::ascii_isspace(static_cast<unsigned char>(c)); };
  while (!text.empty() && space(text.front())) text.remove_prefix(1);
  while (!text.empty() && space(text.back())) text.remove_suffix(1);
  return text;
}

std::vector<std::string_view> split(std::string_view text, char separator) {
  std::vector<std::string_view> parts;
  for (size_t start = 0;;) {
    const size_t end = text.find(separator, start);
    parts.push_back(text.substr(start, end == std::string_view::npos ? end : end - start));
    if (end == std::string_view::npos) return parts;
    start = end + 1;
  }
}

bool equals_ignore_case(std::string_view a, std::string_view b) {
  if (a.size() != b.size()) return false;
  for (size_t i = 0; i < a.size(); ++i) {
    if (absl::ascii_tolower(static_cast<unsigned char>(a[i])) !=
        absl::ascii_tolower(static_cast<unsigned char>(b[i]))) {
      return false;
    }
  }
  return true;
}

std::string sha256(std::string_view data) {
  unsigned char digest[EVP_MAX_MD_SIZE];
  unsigned int size = 0;
  if (EVP_Digest(data.data(), data.size(), digest, &size, EVP_sha256(), nullptr) != 1) {
    // Only an OpenSSL without SHA-256 fails here; no token may match then.
    ERR_clear_error();
    return {};
  }
  return std::string(reinterpret_cast<const char*>(digest), size);
}

// The verdicts of the calls in progress, keyed by their server context. Each entry remembers the
// interceptor that made it, so that a late-ending call whose context address was already reused
// by a new call cannot erase the new call's verdict.
class VerdictRegistry {
 public:
  void record(const grpc::ServerContextBase* call, const void* owner,
              absl::StatusOr<std::string> verdict) {
    std::lock_guard lock(mutex_);
    entries_.insert_or_assign(call, Entry{owner, std::move(verdict)});
  }
  void erase(const grpc::ServerContextBase* call, const void* owner) {
    std::lock_guard lock(mutex_);
    const auto it = entries_.find(call);
    if (it != entries_.end() && it->second.owner == owner) entries_.erase(it);
  }
  std::optional<absl::StatusOr<std::string>> find(const grpc::ServerContextBase* call) const {
    std::lock_guard lock(mutex_);
    const auto it = entries_.find(call);
    if (it == entries_.end()) return std::nullopt;
    return it->second.verdict;
  }

 private:
  struct Entry {
    const void* owner;
    absl::StatusOr<std::string> verdict;
  };
  mutable std::mutex mutex_;
  std::unordered_map<const grpc::ServerContextBase*, Entry> entries_;
};

// Never destroyed: gRPC's threads may end calls while static destructors run at exit.
VerdictRegistry& verdicts() {
  static VerdictRegistry* const registry = new VerdictRegistry();
  return *registry;
}

// Lives exactly as long as its call's ServerRpcInfo, which the call's ServerContext releases once
// the handler returned and the call ended: the destructor is the hook that ends the verdict.
class AuthInterceptor final : public grpc::experimental::Interceptor {
 public:
  AuthInterceptor(std::shared_ptr<const Authenticator> authenticator,
                  grpc::experimental::ServerRpcInfo* info)
      : authenticator_(std::move(authenticator)),
        context_(info->server_context()),
        method_(info->method() != nullptr ? info->method() : "") {}
  ~AuthInterceptor() override { verdicts().erase(context_, this); }

  void Intercept(grpc::experimental::InterceptorBatchMethods* methods) override {
    using Hook = grpc::experimental::InterceptionHookPoints;
    // A server sees the client's metadata in its first batch, before the handler runs.
    if (methods->QueryInterceptionHookPoint(Hook::POST_RECV_INITIAL_METADATA)) {
      judge(*methods->GetRecvInitialMetadata());
    }
    if (refusal_.has_value()) {
      if (methods->QueryInterceptionHookPoint(Hook::PRE_SEND_MESSAGE)) {
        if (grpc::ByteBuffer* message = methods->GetSerializedSendMessage()) {
          const grpc::Slice empty;
          *message = grpc::ByteBuffer(&empty, 1);
        }
      }
      if (methods->QueryInterceptionHookPoint(Hook::PRE_SEND_STATUS)) {
        methods->ModifySendStatus(*refusal_);
      }
    }
    methods->Proceed();
  }

 private:
  void judge(const std::multimap<grpc::string_ref, grpc::string_ref>& metadata) {
    absl::StatusOr<std::string> verdict = authenticator_->tenant_of(metadata);
    if (!verdict.ok()) {
      const std::string message(verdict.status().message());
      refusal_.emplace(grpc::StatusCode::UNAUTHENTICATED, message);
      // The method is the request's path, as the client sent it.
      log_line(LogLevel::kWarning, absl::StrCat("refused ", printable(method_), " from ",
                                                context_->peer(), ": ", message));
    }
    verdicts().record(context_, this, std::move(verdict));
  }

  std::shared_ptr<const Authenticator> authenticator_;
  grpc::ServerContextBase* context_;
  std::string method_;
  std::optional<grpc::Status> refusal_;  // set when the call is refused
};

absl::StatusOr<std::string> read_pem_file(std::string_view flag, const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) {
    return absl::InvalidArgumentError(
        absl::StrCat(av(flag), ": cannot read ", path, ": ", std::strerror(errno)));
  }
  std::ostringstream text;
  text << in.rdbuf();
  if (in.bad()) return absl::InvalidArgumentError(absl::StrCat(av(flag), ": cannot read ", path));
  if (text.str().empty()) {
    return absl::InvalidArgumentError(absl::StrCat(av(flag), ": ", path, " is empty"));
  }
  return text.str();
}

struct BioDeleter {
  void operator()(BIO* bio) const { BIO_free(bio); }
};
struct X509Deleter {
  void operator()(X509* cert) const { X509_free(cert); }
};
struct KeyDeleter {
  void operator()(EVP_PKEY* key) const { EVP_PKEY_free(key); }
};

std::unique_ptr<BIO, BioDeleter> memory_bio(const std::string& pem) {
  return std::unique_ptr<BIO, BioDeleter>(
      BIO_new_mem_buf(pem.data(), static_cast<int>(pem.size())));
}

// Refuses a passphrase prompt: the server runs unattended, so an encrypted key must fail here.
int no_passphrase(char*, int, int, void*) { return 0; }

// The first certificate of `pem`, or null.
std::unique_ptr<X509, X509Deleter> first_certificate(const std::string& pem) {
  auto bio = memory_bio(pem);
  std::unique_ptr<X509, X509Deleter> cert(
      bio ? PEM_read_bio_X509(bio.get(), nullptr, no_passphrase, nullptr) : nullptr);
  ERR_clear_error();
  return cert;
}

// Checked here because gRPC would only fail to start listening, without saying why.
absl::Status check_key_pair(const TlsFiles& files, const std::string& cert_pem,
                            const std::string& key_pem) {
  std::unique_ptr<X509, X509Deleter> cert = first_certificate(cert_pem);
  if (!cert) {
    return absl::InvalidArgumentError(
        absl::StrCat("--tls-cert: ", files.cert, " holds no PEM certificate"));
  }
  auto bio = memory_bio(key_pem);
  std::unique_ptr<EVP_PKEY, KeyDeleter> key(
      bio ? PEM_read_bio_PrivateKey(bio.get(), nullptr, no_passphrase, nullptr) : nullptr);
  ERR_clear_error();
  if (!key) {
    return absl::InvalidArgumentError(
        absl::StrCat("--tls-key: ", files.key,
                     " holds no PEM private key (or one encrypted with a passphrase)"));
  }
  const bool matches = X509_check_private_key(cert.get(), key.get()) == 1;
  ERR_clear_error();
  if (!matches) {
    return absl::InvalidArgumentError(absl::StrCat("--tls-key: ", files.key,
                                                   " is not the key of the certificate in ",
                                                   files.cert, " (--tls-cert)"));
  }
  return absl::OkStatus();
}

}  // namespace

bool is_valid_tenant_name(std::string_view name) {
  if (name.empty() || name.size() > 64) return false;
  // Also a path component elsewhere, where these two would not name a directory of their own.
  if (name == "." || name == "..") return false;
  for (const char c : name) {
    if (!absl::ascii_isalnum(static_cast<unsigned char>(c)) && c != '.' && c != '_' && c != '-') {
      return false;
    }
  }
  return true;
}

absl::StatusOr<TokenTable> TokenTable::load(const std::filesystem::path& file) {
  std::ifstream in(file, std::ios::binary);
  if (!in) {
    return absl::InvalidArgumentError(
        absl::StrCat("cannot read ", file.string(), ": ", std::strerror(errno)));
  }
  std::ostringstream text;
  text << in.rdbuf();
  if (in.bad()) return absl::InvalidArgumentError(absl::StrCat("cannot read ", file.string()));
  return parse(text.str(), file.string());
}

absl::StatusOr<TokenTable> TokenTable::parse(std::string_view text, std::string_view file_name) {
  TokenTable table;
  std::unordered_map<std::string, size_t> line_of_digest;
  size_t line_number = 0;
  for (std::string_view line : split(text, '\n')) {
    ++line_number;
    const auto refuse = [&](std::string_view what) {
      return absl::InvalidArgumentError(
          absl::StrCat(av(file_name), ":", line_number, ": ", av(what)));
    };
    line = trim(line);
    if (line.empty() || line.front() == '#') continue;
    const std::vector<std::string_view> fields = split(line, ',');
    if (fields.size() < 2) return refuse("missing field: expected 'token,tenant'");
    if (fields.size() > 2) return refuse("too many fields: expected 'token,tenant'");
    const std::string_view token = trim(fields[0]);
    const std::string_view tenant = trim(fields[1]);
    if (token.empty()) return refuse("empty token");
    if (token.size() < kMinTokenLength) {
      return refuse(absl::StrCat("token too short: ", token.size(), " characters, at least ",
                                 kMinTokenLength));
    }
    // Tokens travel as header values and CSV fields: visible ASCII stays intact in both.
    if (absl::Status text = wire::check_bearer_token(token, "token"); !text.ok()) {
      return refuse(std::string(text.message()));
    }
    if (!is_valid_tenant_name(tenant)) {
      return refuse(absl::StrCat("tenant '", av(tenant),
                                 "' is not a valid name: 1 to 64 of A-Z a-z 0-9 . _ - "
                                 "(not '.' or '..')"));
    }
    std::string digest = sha256(token);
    if (const auto first = line_of_digest.find(digest); first != line_of_digest.end()) {
      return refuse(absl::StrCat("duplicate token (first on line ", first->second, ")"));
    }
    line_of_digest.emplace(digest, line_number);
    table.tenant_by_digest_.emplace(std::move(digest), std::string(tenant));
  }
  if (table.tenant_by_digest_.empty()) {
    return absl::InvalidArgumentError(absl::StrCat(av(file_name), ": no tokens"));
  }
  return table;
}

std::optional<std::string> TokenTable::tenant_of(std::string_view token) const {
  // Looked up by digest: the time a lookup takes depends on the digest, which an attacker cannot
  // steer towards a valid token, and not on how much of a token was guessed right.
  const auto it = tenant_by_digest_.find(sha256(token));
  if (it == tenant_by_digest_.end()) return std::nullopt;
  return it->second;
}

absl::StatusOr<std::string> Authenticator::tenant_of(
    std::optional<std::string_view> authorization) const {
  if (!tokens_.has_value()) return std::string(kDefaultTenant);
  if (!authorization.has_value()) {
    return absl::UnauthenticatedError(
        absl::StrCat("missing 'authorization' header: ", av(kSendBearer)));
  }
  // RFC 7235: the scheme is case-insensitive and separated from its credentials by spaces.
  const std::string_view value = trim(*authorization);
  const size_t space = value.find(' ');
  const std::string_view scheme = value.substr(0, space);
  if (!equals_ignore_case(scheme, "Bearer")) {
    return absl::UnauthenticatedError(
        absl::StrCat("the 'authorization' header is not a Bearer token: ", av(kSendBearer)));
  }
  const std::string_view token =
      space == std::string_view::npos ? std::string_view() : trim(value.substr(space));
  if (token.empty()) {
    return absl::UnauthenticatedError(
        absl::StrCat("the 'authorization' header has no token after 'Bearer': ", av(kSendBearer)));
  }
  std::optional<std::string> tenant = tokens_->tenant_of(token);
  if (!tenant.has_value()) {
    return absl::UnauthenticatedError("unknown token in the 'authorization' header");
  }
  return *std::move(tenant);
}

absl::StatusOr<std::string> Authenticator::tenant_of(
    const std::multimap<grpc::string_ref, grpc::string_ref>& metadata) const {
  const auto [first, end] =
      metadata.equal_range(grpc::string_ref(kAuthorization.data(), kAuthorization.size()));
  if (first == end) return tenant_of(std::nullopt);
  if (std::next(first) != end && requires_tokens()) {
    return absl::UnauthenticatedError("more than one 'authorization' header");
  }
  return tenant_of(std::string_view(first->second.data(), first->second.size()));
}

bool is_exempt_from_tokens(std::string_view method) {
  return method.starts_with("/grpc.health.v1.Health/");
}

grpc::experimental::Interceptor* AuthInterceptorFactory::CreateServerInterceptor(
    grpc::experimental::ServerRpcInfo* info) {
  if (info->method() != nullptr && is_exempt_from_tokens(info->method())) return nullptr;
  return new AuthInterceptor(authenticator_, info);
}

absl::StatusOr<std::string> caller_tenant(const grpc::ServerContextBase& context) {
  std::optional<absl::StatusOr<std::string>> verdict = verdicts().find(&context);
  if (!verdict.has_value()) {
    return absl::InternalError(
        "no authentication verdict for this call (the server has no authentication interceptor)");
  }
  return *std::move(verdict);
}

bool is_loopback_listen_address(std::string_view listen) {
  if (listen.starts_with("unix:") || listen.starts_with("unix-abstract:")) return true;
  std::string host;
  if (listen.starts_with("[")) {
    const size_t close = listen.find(']');
    if (close == std::string_view::npos) return false;
    host = std::string(listen.substr(1, close - 1));
  } else {
    const size_t colon = listen.rfind(':');
    host = std::string(listen.substr(0, colon));
    // An IPv6 address needs brackets before a port; without them the split above is wrong.
    if (host.find(':') != std::string::npos) return false;
  }
  if (equals_ignore_case(host, "localhost")) return true;
  in_addr v4{};
  if (inet_pton(AF_INET, host.c_str(), &v4) == 1) {
    return (ntohl(v4.s_addr) >> 24) == 127;
  }
  in6_addr v6{};
  if (inet_pton(AF_INET6, host.c_str(), &v6) == 1) {
    if (IN6_IS_ADDR_LOOPBACK(&v6)) return true;
    return IN6_IS_ADDR_V4MAPPED(&v6) && v6.s6_addr[12] == 127;
  }
  return false;
}

absl::StatusOr<std::shared_ptr<grpc::ServerCredentials>> listen_credentials(std::string_view listen,
                                                                            const TlsFiles& tls,
                                                                            bool insecure) {
  if (tls.cert.empty() && tls.key.empty()) {
    if (!tls.client_ca.empty()) {
      return absl::InvalidArgumentError(
          "--tls-client-ca: needs --tls-cert and --tls-key (client certificates are checked only "
          "over TLS)");
    }
    if (!insecure && !is_loopback_listen_address(listen)) {
      return absl::InvalidArgumentError(absl::StrCat(
          "--listen ", av(listen),
          " is not a loopback address: serving plaintext there needs --insecure (or serve TLS "
          "with --tls-cert and --tls-key)"));
    }
    return grpc::InsecureServerCredentials();
  }
  if (tls.cert.empty()) return absl::InvalidArgumentError("--tls-key: needs --tls-cert");
  if (tls.key.empty()) return absl::InvalidArgumentError("--tls-cert: needs --tls-key");
  absl::StatusOr<std::string> cert = read_pem_file("--tls-cert", tls.cert);
  if (!cert.ok()) return cert.status();
  absl::StatusOr<std::string> key = read_pem_file("--tls-key", tls.key);
  if (!key.ok()) return key.status();
  if (absl::Status pair = check_key_pair(tls, *cert, *key); !pair.ok()) return pair;

  grpc::SslServerCredentialsOptions options(GRPC_SSL_DONT_REQUEST_CLIENT_CERTIFICATE);
  options.pem_key_cert_pairs.push_back({*key, *cert});
  if (!tls.client_ca.empty()) {
    absl::StatusOr<std::string> client_ca = read_pem_file("--tls-client-ca", tls.client_ca);
    if (!client_ca.ok()) return client_ca.status();
    if (!first_certificate(*client_ca)) {
      return absl::InvalidArgumentError(
          absl::StrCat("--tls-client-ca: ", tls.client_ca, " holds no PEM certificate"));
    }
    options.pem_root_certs = *client_ca;
    options.client_certificate_request = GRPC_SSL_REQUEST_AND_REQUIRE_CLIENT_CERTIFICATE_AND_VERIFY;
  }
  return grpc::SslServerCredentials(options);
}

}  // namespace caustica::server
