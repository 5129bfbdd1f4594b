// SPDX-License-Identifier: GPL-3.0-or-later
#include "daemon/http/http_edge.h"

#include <linux/sockios.h>
#include <openssl/ssl.h>
#include <openssl/x509.h>
#include <openssl/x509v3.h>
#include <spdlog/spdlog.h>
#include <sys/ioctl.h>

#include <atomic>
#include <boost/asio.hpp>
#include <boost/asio/ssl.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>
#include <boost/beast/ssl.hpp>
#include <deque>
#include <list>
#include <optional>
#include <thread>
#include <type_traits>

#include "absl/strings/ascii.h"
#include "absl/strings/match.h"
#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "absl/strings/str_split.h"
#include "absl/strings/strip.h"
#include "absl/synchronization/mutex.h"
#include "daemon/http/connect_protocol.h"
#include "daemon/http/request_checks.h"
#include "daemon/http/rpc_bridge.h"
#include "hdrstereo/v1/sessions.pb.h"
#include "nlohmann/json.hpp"
#include "processing/base/input_limits.h"
#include "processing/base/status_macros.h"

namespace hdrstereo::http {
namespace {

namespace net = boost::asio;
namespace beast = boost::beast;
namespace bhttp = beast::http;
namespace ssl = net::ssl;
using tcp = net::ip::tcp;

using Request = bhttp::request<bhttp::string_body>;
using StringResponse = bhttp::response<bhttp::string_body>;

constexpr char kSessionCookie[] = "hdrstereo_session";
// Under TLS the __Host- prefix makes browsers refuse the cookie unless it
// is Secure, for this host only, path /.
constexpr char kTlsSessionCookie[] = "__Host-hdrstereo_session";
// The one stream whose messages are snapshots: a viewer that falls behind
// gets the newest frame, the older ones are dropped.
constexpr char kLatestOnlyMethod[] = "hdrstereo.v1.Hardware.StreamPreview";
// A live-view frame is written only while the kernel holds less than this
// not yet sent: frames a slow viewer has not taken wait in the edge, where
// only the newest is kept, not in a socket buffer the size of many frames.
constexpr int kLiveViewUnsentBytes = 32 << 10;
// Connections beyond max_connections still get their 503 (plain HTTP)
// while fewer than this many are being refused; more are closed at once.
constexpr size_t kMaxRefusing = 64;
// Sign-in bodies are tiny; the key is 80 characters.
constexpr size_t kMaxSignInBodyBytes = 4096;

// Beast's string_view as absl's (Debian's absl has its own type).
absl::string_view Sv(beast::string_view text) {
  return absl::string_view(text.data(), text.size());
}

std::chrono::steady_clock::duration Chrono(absl::Duration d) {
  return absl::ToChronoNanoseconds(d);
}

void AddSecurityHeaders(bhttp::fields& fields) {
  fields.set("Content-Security-Policy",
             "default-src 'self'; img-src 'self' blob: data:; "
             "object-src 'none'; base-uri 'none'; form-action 'self'; "
             "frame-ancestors 'none'");
  fields.set("X-Content-Type-Options", "nosniff");
  fields.set("Referrer-Policy", "no-referrer");
  fields.set("X-Frame-Options", "DENY");
}

StringResponse JsonResponse(unsigned version, int status, std::string body) {
  StringResponse response(static_cast<bhttp::status>(status), version);
  AddSecurityHeaders(response.base());
  response.set(bhttp::field::content_type, "application/json");
  response.set(bhttp::field::cache_control, "no-store");
  response.body() = std::move(body);
  response.prepare_payload();
  return response;
}

StringResponse ErrorResponse(unsigned version, const absl::Status& status) {
  return JsonResponse(version, HttpStatusOf(status.code()), ErrorJson(status));
}

std::string PeerName(const tcp::endpoint& endpoint) {
  const net::ip::address address = endpoint.address();
  return address.is_v6()
             ? absl::StrCat("ipv6:[", address.to_string(),
                            "]:", endpoint.port())
             : absl::StrCat("ipv4:", address.to_string(), ":", endpoint.port());
}

// The principal a verified client certificate names, by the gRPC edge's
// rule (rpc::CertificatePrincipal): its SAN URI hdrstereo://user/NAME,
// else its CN.
std::string PrincipalOfCertificate(X509* cert) {
  std::vector<std::string> uris;
  auto* names = static_cast<GENERAL_NAMES*>(
      X509_get_ext_d2i(cert, NID_subject_alt_name, nullptr, nullptr));
  if (names != nullptr) {
    for (int i = 0; i < sk_GENERAL_NAME_num(names); ++i) {
      const GENERAL_NAME* name = sk_GENERAL_NAME_value(names, i);
      if (name->type != GEN_URI) continue;
      const ASN1_IA5STRING* uri = name->d.uniformResourceIdentifier;
      uris.emplace_back(
          reinterpret_cast<const char*>(ASN1_STRING_get0_data(uri)),
          static_cast<size_t>(ASN1_STRING_length(uri)));
    }
    GENERAL_NAMES_free(names);
  }
  std::string common_name;
  X509_NAME* subject = X509_get_subject_name(cert);
  const int index = X509_NAME_get_index_by_NID(subject, NID_commonName, -1);
  if (index >= 0) {
    const ASN1_STRING* data =
        X509_NAME_ENTRY_get_data(X509_NAME_get_entry(subject, index));
    common_name.assign(
        reinterpret_cast<const char*>(ASN1_STRING_get0_data(data)),
        static_cast<size_t>(ASN1_STRING_length(data)));
  }
  return rpc::CertificatePrincipal(uris, common_name);
}

absl::StatusOr<std::unique_ptr<ssl::context>> TlsContext(
    const rpc::TlsMaterial& tls) {
  auto context = std::make_unique<ssl::context>(ssl::context::tls_server);
  boost::system::error_code ec;
  context->set_options(ssl::context::default_workarounds |
                           ssl::context::no_sslv2 | ssl::context::no_sslv3 |
                           ssl::context::no_tlsv1 | ssl::context::no_tlsv1_1,
                       ec);
  context->use_certificate_chain(net::buffer(tls.cert_chain), ec);
  if (!ec) {
    context->use_private_key(net::buffer(tls.private_key), ssl::context::pem,
                             ec);
  }
  if (!ec && !tls.client_ca.empty()) {
    context->add_certificate_authority(net::buffer(tls.client_ca), ec);
    // Asked for, not required: a browser without one signs in with a key.
    if (!ec) context->set_verify_mode(ssl::verify_peer, ec);
    // With peers verified, OpenSSL resumes a session (a browser's next
    // connection) only under a session id context, and without one fails
    // that handshake (alert 80, internal error).
    static constexpr unsigned char kSessionContext[] = "hdrstereo-http";
    if (!ec && SSL_CTX_set_session_id_context(
                   context->native_handle(), kSessionContext,
                   sizeof(kSessionContext) - 1) != 1) {
      ec = boost::asio::error::invalid_argument;
    }
  }
  if (ec) {
    return absl::InvalidArgumentError(
        absl::StrCat("the HTTP edge cannot use the TLS files: ", ec.message()));
  }
  if (!tls.crl_dir.empty()) {
    X509_STORE* store = SSL_CTX_get_cert_store(context->native_handle());
    X509_LOOKUP* lookup = X509_STORE_add_lookup(store, X509_LOOKUP_hash_dir());
    if (lookup == nullptr ||
        X509_LOOKUP_add_dir(lookup, tls.crl_dir.c_str(), X509_FILETYPE_PEM) !=
            1 ||
        X509_STORE_set_flags(store, X509_V_FLAG_CRL_CHECK) != 1) {
      return absl::InvalidArgumentError(absl::StrCat(
          "the HTTP edge cannot use the revocation lists in ", tls.crl_dir));
    }
  }
  return context;
}

// A Content-Type for a downloaded file, by its extension; anything that a
// browser could run (HTML, SVG, scripts) is an attachment.
std::string FileContentType(absl::string_view path) {
  const size_t dot = path.rfind('.');
  const std::string extension =
      dot == path.npos ? "" : absl::AsciiStrToLower(path.substr(dot + 1));
  if (extension == "png") return "image/png";
  if (extension == "jpg" || extension == "jpeg") return "image/jpeg";
  if (extension == "tif" || extension == "tiff") return "image/tiff";
  if (extension == "json") return "application/json";
  if (extension == "csv") return "text/csv";
  return "application/octet-stream";
}

// A report file's Content-Type: the page itself is shown as HTML (under
// kReportPolicy), the rest as any downloaded file.
std::string ReportFileContentType(absl::string_view path) {
  if (absl::EndsWithIgnoreCase(path, ".html")) {
    return "text/html; charset=utf-8";
  }
  return FileContentType(path);
}

// A downloaded file is never a page of this origin.
constexpr char kFilePolicy[] = "sandbox; default-src 'none'";
// What a session's report page needs (processing/report/html_report.cc):
// its inline <style> and its images, files beside it. Its inline script
// (which counts the images that loaded, for tests opening the file
// directly) never runs here: no script-src, and a sandbox without
// allow-scripts. allow-same-origin keeps the page at this origin so that
// its images are fetched with the session cookie (SameSite=Strict): a
// page of an opaque origin is cross-site to every cookie.
constexpr char kReportPolicy[] =
    "sandbox allow-same-origin; default-src 'none'; img-src 'self'; "
    "style-src 'unsafe-inline'; base-uri 'none'; form-action 'none'; "
    "frame-ancestors 'none'";
// ListArtifacts' largest page (daemon/rpc/pagination.h): a report's files
// come in one page, unless it has more than this many.
constexpr int kReportListPageSize = 1000;

}  // namespace

// What the whole edge shares: options, the bridge into the services, the
// sessions, the I/O threads, and the calls in flight.
class HttpEdge::Impl {
 public:
  Impl(const HttpEdgeOptions& options, HttpEdgeServices services)
      : options_(options),
        services_(std::move(services)),
        bridge_(services_.channel, *services_.stamp),
        sessions_(options.sessions),
        throttle_(options.sign_in),
        io_(options.threads) {}

  // Reads the console's files (options_.web_root) and says in the log
  // where it looked and what it serves.
  absl::Status LoadConsole();
  absl::Status Listen(const rpc::TlsMaterial* tls);
  void Run();
  void Stop();

  // Who the request is from: Authorization: Bearer, else the session
  // cookie, else the client certificate. UNAUTHENTICATED saying how to sign
  // in.
  absl::StatusOr<rpc::EdgeCaller> Authenticate(
      const Request& request, const std::string& cookie_name, bool key_allowed,
      const std::string& cert_principal, const std::string& peer);
  // An audit row for what the edge itself decided (sign-in, sign-out,
  // requests refused before any call).
  void Audit(const rpc::Principal& principal, const std::string& peer,
             absl::string_view route, const absl::Status& status);

  // Calls in flight into the services: Stop() waits for them, since their
  // callbacks post to the I/O context.
  void CallStarted() { in_flight_.fetch_add(1); }
  void CallEnded() { in_flight_.fetch_sub(1); }
  // Streams to cancel when the edge stops.
  void Track(const std::shared_ptr<StreamCall>& call);

  const HttpEdgeOptions options_;
  const HttpEdgeServices services_;
  RpcBridge bridge_;
  BrowserSessions sessions_;
  SignInThrottle throttle_;
  ConsoleFiles console_;  // read-only once serving
  std::atomic<size_t> connections_{0};
  std::atomic<size_t> refusing_{0};
  std::vector<std::string> addresses_;

 private:
  struct Listener;
  void Accept(Listener& listener);

  // Before io_: the connections its pending handlers hold, destroyed with
  // it, use them.
  std::unique_ptr<ssl::context> tls_;
  net::io_context io_;
  std::list<Listener> listeners_;
  std::vector<std::thread> threads_;
  std::atomic<int> in_flight_{0};
  absl::Mutex streams_mutex_;
  std::list<std::weak_ptr<StreamCall>> streams_ ABSL_GUARDED_BY(streams_mutex_);
  bool stopped_ = false;
};

// What a connection knows of the address it came in on.
struct ListenInfo {
  bool tls = false;
  bool loopback = false;
  std::vector<std::string> served_names;
  std::string cookie_name;
};

struct HttpEdge::Impl::Listener {
  Listener(net::io_context& io, ListenInfo listen_info)
      : acceptor(net::make_strand(io)), info(std::move(listen_info)) {}
  tcp::acceptor acceptor;
  ListenInfo info;
};

namespace {

// One HTTP/1.1 connection, plain or TLS: reads requests one at a time and
// answers each, unary responses kept alive, streams and downloads closed
// after their end. Every step runs on the connection's strand.
template <class Stream>
class Connection : public std::enable_shared_from_this<Connection<Stream>> {
 public:
  static constexpr bool kTls =
      std::is_same_v<Stream, beast::ssl_stream<beast::tcp_stream>>;

  Connection(HttpEdge::Impl& edge, const ListenInfo& info, Stream stream,
             std::string peer, bool refuse)
      : edge_(edge),
        info_(info),
        stream_(std::move(stream)),
        peer_(std::move(peer)),
        refuse_(refuse) {
    (refuse_ ? edge_.refusing_ : edge_.connections_).fetch_add(1);
  }
  ~Connection() {
    (refuse_ ? edge_.refusing_ : edge_.connections_).fetch_sub(1);
    if (call_ != nullptr) call_->Cancel();
  }

  void Start() {
    net::dispatch(stream_.get_executor(),
                  [self = this->shared_from_this()] { self->Handshake(); });
  }

 private:
  beast::tcp_stream& Tcp() { return beast::get_lowest_layer(stream_); }

  void Handshake() {
    Tcp().expires_after(Chrono(edge_.options_.header_timeout));
    if constexpr (kTls) {
      stream_.async_handshake(
          ssl::stream_base::server,
          [self = this->shared_from_this()](beast::error_code ec) {
            if (ec) return self->Close();
            self->ReadCertificate();
            self->ReadHeader();
          });
    } else {
      ReadHeader();
    }
  }

  void ReadCertificate() {
    if constexpr (kTls) {
      X509* cert = SSL_get1_peer_certificate(stream_.native_handle());
      if (cert == nullptr) return;
      // The handshake verified it against the lab CA (and its CRLs).
      if (SSL_get_verify_result(stream_.native_handle()) == X509_V_OK) {
        cert_principal_ = PrincipalOfCertificate(cert);
      }
      X509_free(cert);
    }
  }

  void ReadHeader() {
    head_ = false;
    caller_.reset();
    body_unread_ = false;
    range_.reset();
    if_range_.reset();
    report_ = false;
    if (refuse_) {
      // Beyond the connection limit: say so and close.
      return Send(ErrorResponse(
                      11, absl::UnavailableError(absl::StrCat(
                              "hdrstereod serves at most ",
                              edge_.options_.max_connections,
                              " HTTP connections at once; try again shortly"))),
                  /*close=*/true);
    }
    parser_.emplace();
    parser_->header_limit(
        static_cast<uint32_t>(edge_.options_.max_header_bytes));
    parser_->body_limit(edge_.options_.max_body_bytes);
    Tcp().expires_after(Chrono(requests_ == 0 ? edge_.options_.header_timeout
                                              : edge_.options_.idle_timeout));
    bhttp::async_read_header(
        stream_, buffer_, *parser_,
        [self = this->shared_from_this()](beast::error_code ec, size_t) {
          self->OnHeader(ec);
        });
  }

  void OnHeader(beast::error_code ec) {
    if (ec) return RefuseUnreadable(ec);
    ++requests_;
    // Whoever may not be served is answered from the headers alone, its
    // body never read (nor buffered): a wrong Host, no credentials.
    const Request& head = parser_->get();
    const std::string target(head.target());
    const absl::string_view path =
        absl::string_view(target).substr(0, target.find('?'));
    if (edge_.console_.Serves(path) || path == "/auth/session") {
      // The console's files and the session check need no credentials (the
      // files hold no secret; the calls the page makes do) and take no
      // body: one sent is not read.
      body_unread_ = !parser_->is_done();
      request_ = parser_->release();
      parser_.reset();
      return Dispatch();
    }
    const bool sign_in = target == "/auth/sign-in";
    const bool sign_out = target == "/auth/sign-out";
    if (sign_in || sign_out) parser_->body_limit(kMaxSignInBodyBytes);
    if (!CheckHost(Sv(head[bhttp::field::host]), info_.served_names).ok() ||
        (!sign_in && !sign_out && !Caller().ok())) {
      body_unread_ = true;
      request_ = parser_->release();
      parser_.reset();
      return Dispatch();
    }
    Tcp().expires_after(Chrono(edge_.options_.body_timeout));
    if (absl::EqualsIgnoreCase(Sv(parser_->get()[bhttp::field::expect]),
                               "100-continue")) {
      // curl waits for this before it sends a larger body.
      auto proceed = std::make_shared<bhttp::response<bhttp::empty_body>>(
          bhttp::status::continue_, parser_->get().version());
      return bhttp::async_write(stream_, *proceed,
                                [self = this->shared_from_this(), proceed](
                                    beast::error_code ec, size_t) {
                                  if (ec) return self->Close();
                                  self->ReadBody();
                                });
    }
    ReadBody();
  }

  void ReadBody() {
    bhttp::async_read(
        stream_, buffer_, *parser_,
        [self = this->shared_from_this()](beast::error_code ec, size_t) {
          if (ec) return self->RefuseUnreadable(ec);
          self->request_ = self->parser_->release();
          self->parser_.reset();
          self->Dispatch();
        });
  }

  // A request that could not be read: a clear answer where HTTP allows
  // one, else the connection closes.
  void RefuseUnreadable(beast::error_code ec) {
    if (ec == bhttp::error::body_limit) {
      return Send(
          ErrorResponse(11, absl::ResourceExhaustedError(absl::StrCat(
                                "the request body is larger than the "
                                "limit of ",
                                edge_.options_.max_body_bytes, " bytes"))),
          true, 413);
    }
    if (ec == bhttp::error::header_limit) {
      return Send(
          ErrorResponse(11, absl::ResourceExhaustedError(absl::StrCat(
                                "the request headers are larger than the "
                                "limit of ",
                                edge_.options_.max_header_bytes, " bytes"))),
          true, 431);
    }
    // Beast's parse errors (a bad method, target, header or chunk) get a
    // 400; a timeout or a hang-up just closes.
    if (ec != bhttp::error::end_of_stream &&
        ec != bhttp::error::partial_message &&
        ec.category() ==
            beast::error_code(bhttp::error::bad_method).category()) {
      return Send(
          ErrorResponse(11, absl::InvalidArgumentError(absl::StrCat(
                                "malformed HTTP request: ", ec.message()))),
          true);
    }
    Close();
  }

  void Dispatch() {
    const std::string target(request_.target());
    const absl::string_view path =
        absl::string_view(target).substr(0, target.find('?'));
    const unsigned version = request_.version();
    head_ = request_.method() == bhttp::verb::head;
    if (absl::Status host =
            CheckHost(Sv(request_[bhttp::field::host]), info_.served_names);
        !host.ok()) {
      edge_.Audit(rpc::Principal(), peer_, "host", host);
      return Send(ErrorResponse(version, host), true);
    }
    if (std::optional<ConsoleAnswer> answer =
            edge_.console_.Answer(Sv(request_.method_string()), path,
                                  Sv(request_[bhttp::field::if_none_match]))) {
      return ServeConsole(*answer);
    }
    const bhttp::verb verb = request_.method();
    if (path == "/auth/sign-in" || path == "/auth/sign-out") {
      if (verb != bhttp::verb::post) return MethodNotAllowed("POST");
      return path == "/auth/sign-in" ? SignIn() : SignOut();
    }
    if (path == "/auth/session") {
      if (verb != bhttp::verb::get && verb != bhttp::verb::head) {
        return MethodNotAllowed("GET, HEAD");
      }
      // Whether the page's session cookie (or client certificate) is good: a
      // page asks before its first call, so that being signed out is an
      // answer, not a 401 the browser reports as a failed request. An
      // Authorization header is not looked at: key guesses go where they
      // are throttled and audited.
      Request browser_only = request_;
      browser_only.erase(bhttp::field::authorization);
      const bool signed_in = edge_
                                 .Authenticate(browser_only, info_.cookie_name,
                                               false, cert_principal_, peer_)
                                 .ok();
      return Send(JsonResponse(
          version, 200,
          signed_in ? R"({"signedIn":true})" : R"({"signedIn":false})"));
    }
    if (absl::StartsWith(path, "/files/")) {
      if (verb != bhttp::verb::get && verb != bhttp::verb::head) {
        return MethodNotAllowed("GET, HEAD");
      }
      return Download(path);
    }
    absl::StatusOr<RpcMethod> method = FindRpcMethod(path);
    if (!method.ok() && absl::IsNotFound(method.status())) {
      return Send(ErrorResponse(version, method.status()));
    }
    if (verb != bhttp::verb::post) return MethodNotAllowed("POST");
    if (!method.ok()) return Send(ErrorResponse(version, method.status()));
    Rpc(*method);
  }

  void ServeConsole(const ConsoleAnswer& answer) {
    if (answer.status == 405) return MethodNotAllowed("GET, HEAD");
    StringResponse response(static_cast<bhttp::status>(answer.status),
                            request_.version());
    // The edge's own CSP: the page's script and style sheet are files of
    // this origin, and it has no inline script or style.
    AddSecurityHeaders(response.base());
    if (answer.file == nullptr) {
      // Not installed: say so, and do not let a browser keep the answer.
      response.set(bhttp::field::content_type, "text/plain; charset=utf-8");
      response.set(bhttp::field::cache_control, "no-store");
      response.body() = answer.message;
      response.prepare_payload();
      return Send(std::move(response));
    }
    // Kept by browsers, but asked again each time (a daemon updated in
    // place serves a new console at once): mostly a 304.
    response.set(bhttp::field::cache_control, "no-cache");
    response.set(bhttp::field::etag, answer.file->etag);
    if (answer.status == 304) {
      response.prepare_payload();
      return Send(std::move(response));
    }
    response.set(bhttp::field::content_type, answer.file->content_type);
    if (head_) {
      // HEAD: the length GET would send, no copy of the body.
      response.content_length(answer.file->body.size());
    } else {
      response.body() = answer.file->body;
      response.prepare_payload();
    }
    Send(std::move(response));
  }

  void MethodNotAllowed(const char* allowed) {
    StringResponse response =
        ErrorResponse(request_.version(),
                      absl::InvalidArgumentError(absl::StrCat(
                          "method ", std::string(request_.method_string()),
                          " is not served here; use ", allowed)));
    response.result(bhttp::status::method_not_allowed);
    response.set(bhttp::field::allow, allowed);
    Send(std::move(response));
  }

  // A mutation's checks: a content type no form can send, and an Origin,
  // when there is one, that is the edge's own (always there for a session
  // cookie: browsers send it on every POST).
  absl::Status CheckMutation(bool session_cookie) {
    const auto origin = request_.find(bhttp::field::origin);
    if (origin == request_.end()) {
      if (session_cookie) {
        return absl::PermissionDeniedError(
            "a request signed in by a session cookie must carry the Origin "
            "header");
      }
      return absl::OkStatus();
    }
    return CheckOrigin(Sv(origin->value()), info_.tls ? "https" : "http",
                       Sv(request_[bhttp::field::host]));
  }

  bool HasSessionCookie() const {
    return CookieValue(Sv(request_[bhttp::field::cookie]), info_.cookie_name)
        .has_value();
  }

  // The caller of the request being answered, authenticated once, from
  // its headers.
  const absl::StatusOr<rpc::EdgeCaller>& Caller() {
    if (!caller_.has_value()) {
      caller_ = edge_.Authenticate(
          parser_.has_value() ? parser_->get() : request_, info_.cookie_name,
          info_.tls || info_.loopback, cert_principal_, peer_);
    }
    return *caller_;
  }

  void SignIn() {
    const unsigned version = request_.version();
    const std::string address = peer_.substr(0, peer_.rfind(':'));
    rpc::Principal principal;
    absl::Status status = [&]() -> absl::Status {
      RETURN_IF_ERROR(edge_.throttle_.Check(address));
      std::optional<ContentType> type =
          ParseContentType(Sv(request_[bhttp::field::content_type]));
      if (!type.has_value() || type->codec != Codec::kJson || type->streaming) {
        return absl::InvalidArgumentError(
            "sign in with Content-Type: application/json and the body "
            "{\"apiKey\": \"hs_...\"}");
      }
      RETURN_IF_ERROR(CheckMutation(false));
      if (!info_.tls && !info_.loopback) {
        return absl::UnauthenticatedError(
            "API keys are accepted over TLS only");
      }
      if (request_.body().size() > kMaxSignInBodyBytes) {
        return absl::InvalidArgumentError(absl::StrCat(
            "a sign-in body is at most ", kMaxSignInBodyBytes, " bytes"));
      }
      const nlohmann::json body =
          nlohmann::json::parse(request_.body(), nullptr, false);
      if (!body.is_object() || !body.contains("apiKey") ||
          !body["apiKey"].is_string()) {
        return absl::InvalidArgumentError(
            "apiKey: expected the body {\"apiKey\": \"hs_...\"}");
      }
      const std::string token = body["apiKey"].get<std::string>();
      if (rpc::ApiKeyIdOf(token).empty()) {
        // No guess at a key (it cannot succeed): not counted as one.
        return absl::InvalidArgumentError(
            "apiKey: that is not an API key: keys look like hs_<id>_<secret> "
            "(hdrstereo admin key create prints one)");
      }
      principal.auth_method = absl::StrCat("key:", rpc::ApiKeyIdOf(token));
      absl::StatusOr<rpc::VerifiedApiKey> key =
          edge_.services_.keys->Verify(token);
      if (!key.ok()) {
        edge_.throttle_.RecordFailure(address);
        return key.status();
      }
      principal.name = key->user;
      principal.role =
          std::min(key->role, edge_.services_.authenticator->RoleOf(key->user));
      ASSIGN_OR_RETURN(std::string session, edge_.sessions_.Start(key->id));
      const absl::Time expiry = std::min(
          key->expire_time, absl::Now() + edge_.sessions_.options().lifetime);
      StringResponse response = JsonResponse(
          version, 200,
          nlohmann::json{
              {"user", principal.name},
              {"role", rpc::RoleName(principal.role)},
              {"expireTime", absl::FormatTime(absl::RFC3339_sec, expiry,
                                              absl::UTCTimeZone())}}
              .dump());
      response.set(bhttp::field::set_cookie,
                   absl::StrCat(info_.cookie_name, "=", session,
                                "; Path=/; HttpOnly; SameSite=Strict",
                                info_.tls ? "; Secure" : ""));
      edge_.Audit(principal, peer_, "/auth/sign-in", absl::OkStatus());
      Send(std::move(response));
      return absl::OkStatus();
    }();
    if (status.ok()) return;
    edge_.Audit(principal, peer_, "/auth/sign-in", status);
    Send(ErrorResponse(version, status));
  }

  void SignOut() {
    const unsigned version = request_.version();
    std::optional<std::string> token =
        CookieValue(Sv(request_[bhttp::field::cookie]), info_.cookie_name);
    absl::Status status = CheckMutation(token.has_value());
    rpc::Principal principal;
    if (status.ok()) {
      absl::StatusOr<rpc::EdgeCaller> caller = Caller();
      if (caller.ok()) principal = caller->principal;
      if (!token.has_value() || !edge_.sessions_.End(*token)) {
        status = absl::FailedPreconditionError("no browser session to end");
      }
    }
    edge_.Audit(principal, peer_, "/auth/sign-out", status);
    StringResponse response = status.ok() ? JsonResponse(version, 200, "{}")
                                          : ErrorResponse(version, status);
    // The cookie goes in any case.
    response.set(bhttp::field::set_cookie,
                 absl::StrCat(info_.cookie_name,
                              "=; Path=/; Max-Age=0; HttpOnly; SameSite=Strict",
                              info_.tls ? "; Secure" : ""));
    Send(std::move(response));
  }

  void Rpc(const RpcMethod& method) {
    const unsigned version = request_.version();
    std::optional<ContentType> type =
        ParseContentType(Sv(request_[bhttp::field::content_type]));
    const bool streaming = method.descriptor->server_streaming();
    const bool sse = streaming && type.has_value() && !type->streaming &&
                     type->codec == Codec::kJson &&
                     absl::StrContains(Sv(request_[bhttp::field::accept]),
                                       "text/event-stream");
    if (!type.has_value() || (type->streaming != streaming && !sse)) {
      StringResponse response = ErrorResponse(
          version,
          absl::InvalidArgumentError(absl::StrCat(
              method.grpc_path, " takes Content-Type ",
              streaming ? "application/connect+json or "
                          "application/connect+proto (or application/json "
                          "with Accept: text/event-stream)"
                        : "application/json or application/proto")));
      response.result(bhttp::status::unsupported_media_type);
      return Send(std::move(response));
    }
    if (streaming && version < 11) {
      // A stream is sent in chunks, which HTTP/1.0 does not have.
      return Send(ErrorResponse(
          version, absl::InvalidArgumentError(absl::StrCat(
                       method.grpc_path, " streams: it needs HTTP/1.1"))));
    }
    const Framing framing = sse ? Framing::kSse : Framing::kConnect;
    // Refused before any call: a unary call's error response, or (Connect's
    // rule for streams) a stream that is only its end message.
    auto refuse = [&](const absl::Status& status) {
      if (!streaming) return Send(ErrorResponse(version, status));
      StartStream(framing, *type);
      EndStream(status);
    };
    absl::StatusOr<rpc::EdgeCaller> caller =
        [&]() -> absl::StatusOr<rpc::EdgeCaller> {
      RETURN_IF_ERROR(CheckMutation(HasSessionCookie()));
      return Caller();
    }();
    if (!caller.ok()) {
      edge_.Audit(rpc::Principal(), peer_, method.grpc_path, caller.status());
      return refuse(caller.status());
    }
    absl::Duration timeout =
        streaming ? absl::InfiniteDuration() : edge_.options_.unary_timeout;
    if (const auto header = request_.find("Connect-Timeout-Ms");
        header != request_.end()) {
      absl::StatusOr<absl::Duration> asked =
          ParseTimeoutMs(Sv(header->value()));
      if (!asked.ok()) return refuse(asked.status());
      timeout = *asked;
    }
    absl::StatusOr<absl::string_view> body = request_.body();
    if (type->streaming) {
      body =
          ParseRequestEnvelope(request_.body(), edge_.options_.max_body_bytes);
    }
    absl::StatusOr<std::string> bytes =
        body.ok() ? RequestBytes(method, type->codec, *body) : body.status();
    if (!bytes.ok()) return refuse(bytes.status());
    if (streaming) {
      method_ = method;
      StartStream(framing, *type);
      return CallStream(method, std::move(*bytes), *caller, timeout,
                        method.descriptor->full_name() == kLatestOnlyMethod);
    }
    edge_.CallStarted();
    edge_.bridge_.Unary(
        method, std::move(*bytes), *caller, timeout,
        [self = this->shared_from_this(), edge = &edge_, method,
         codec = type->codec,
         version](absl::StatusOr<std::string> response) mutable {
          // The connection goes with the posted handler, so that no gRPC
          // thread holds it once the call is counted as ended.
          auto executor = self->stream_.get_executor();
          net::post(executor, [self = std::move(self), method, codec, version,
                               response = std::move(response)] {
            absl::StatusOr<std::string> body =
                response.ok() ? ResponseBody(method, codec, *response)
                              : response.status();
            if (!body.ok()) {
              return self->Send(ErrorResponse(version, body.status()));
            }
            StringResponse ok(bhttp::status::ok, version);
            AddSecurityHeaders(ok.base());
            ok.set(bhttp::field::content_type, ContentTypeName({codec, false}));
            ok.set(bhttp::field::cache_control, "no-store");
            ok.body() = std::move(*body);
            ok.prepare_payload();
            self->Send(std::move(ok));
          });
          edge->CallEnded();
        });
  }

  // ----- streamed responses: Connect streams, SSE, downloads -----

  enum class Framing { kConnect, kSse, kDownload };

  // Starts a chunked 200 response (Connect or SSE).
  void StartStream(Framing framing, ContentType type) {
    framing_ = framing;
    codec_ = type.codec;
    auto header = std::make_shared<bhttp::response<bhttp::empty_body>>(
        bhttp::status::ok, request_.version());
    AddSecurityHeaders(header->base());
    header->set(bhttp::field::content_type,
                framing == Framing::kSse ? std::string("text/event-stream")
                                         : ContentTypeName({type.codec, true}));
    header->set(bhttp::field::cache_control, "no-store");
    header->chunked(true);
    header->keep_alive(false);
    WriteHeader(std::move(header));
  }

  template <class Body>
  void WriteHeader(std::shared_ptr<bhttp::response<Body>> header) {
    auto serializer =
        std::make_shared<bhttp::response_serializer<Body>>(*header);
    // Beast gives a read the deadline in force when it starts and keeps it:
    // the hang-up watch starts with none, then the write gets its own.
    Tcp().expires_never();
    WatchForHangUp();
    writing_ = true;
    Tcp().expires_after(Chrono(edge_.options_.write_timeout));
    bhttp::async_write_header(
        stream_, *serializer,
        [self = this->shared_from_this(), header, serializer](
            beast::error_code ec, size_t) { self->OnWritten(ec); });
  }

  void CallStream(const RpcMethod& method, std::string request,
                  const rpc::EdgeCaller& caller, absl::Duration timeout,
                  bool latest_only) {
    latest_only_ = latest_only;
    edge_.CallStarted();
    call_ = edge_.bridge_.Stream(
        method, std::move(request), caller, timeout,
        [self = this->shared_from_this()](std::string message) {
          net::post(self->stream_.get_executor(),
                    [self, message = std::move(message)]() mutable {
                      self->OnMessage(std::move(message));
                    });
        },
        [self = this->shared_from_this(),
         edge = &edge_](absl::Status status) mutable {
          auto executor = self->stream_.get_executor();
          net::post(executor, [self = std::move(self), status] {
            self->EndStream(status);
          });
          edge->CallEnded();
        });
    edge_.Track(call_);
  }

  void OnMessage(std::string message) {
    if (closed_) return;
    std::string piece = Frame(message);
    if (piece.empty()) {
      // Nothing to send (a message JSON could not show): read on.
      call_->RequestNext();
      return;
    }
    if (latest_only_) {
      // Only the newest unsent frame is kept; the call reads on.
      if (!pending_.empty()) pending_.pop_back();
      pending_.push_back(std::move(piece));
      call_->RequestNext();
    } else {
      pending_.push_back(std::move(piece));
    }
    WriteNext();
  }

  // One message as its framing writes it.
  std::string Frame(const std::string& message) {
    if (framing_ == Framing::kDownload) return message;
    absl::StatusOr<std::string> body = ResponseBody(method_, codec_, message);
    if (!body.ok()) return "";
    if (framing_ == Framing::kSse) return absl::StrCat("data: ", *body, "\n\n");
    return Envelope(0, *body);
  }

  void EndStream(absl::Status status) {
    if (ended_) return;
    ended_ = true;
    if (closed_) return;
    if (framing_ == Framing::kConnect) {
      pending_.push_back(Envelope(kEnvelopeEndStream, EndStreamJson(status)));
    } else if (framing_ == Framing::kSse) {
      pending_.push_back(
          absl::StrCat("event: end\ndata: ", EndStreamJson(status), "\n\n"));
    } else if (!status.ok() && !absl::IsCancelled(status)) {
      // A download cut short: the client sees fewer bytes than announced.
      spdlog::warn("HTTP download for {} ended early: {}", peer_,
                   std::string(status.message()));
    }
    WriteNext();
  }

  void WriteNext() {
    if (writing_ || closed_) return;
    if (pending_.empty()) {
      if (!ended_) return;
      if (framing_ == Framing::kDownload) return Close();
      // The last chunk, then the connection closes.
      writing_ = true;
      Tcp().expires_after(Chrono(edge_.options_.write_timeout));
      net::async_write(stream_, bhttp::make_chunk_last(),
                       [self = this->shared_from_this()](
                           beast::error_code, size_t) { self->Close(); });
      return;
    }
    if (latest_only_ && !ended_ && Unsent() > kLiveViewUnsentBytes) {
      // The client is not taking frames as fast as they come: wait, and
      // meanwhile newer frames replace the one waiting here.
      if (stall_start_ == absl::InfinitePast()) stall_start_ = absl::Now();
      if (absl::Now() - stall_start_ > edge_.options_.write_timeout) {
        return Close();
      }
      writing_ = true;
      pace_timer_.expires_after(std::chrono::milliseconds(10));
      pace_timer_.async_wait(
          [self = this->shared_from_this()](beast::error_code) {
            self->writing_ = false;
            self->WriteNext();
          });
      return;
    }
    stall_start_ = absl::InfinitePast();
    auto piece = std::make_shared<std::string>(std::move(pending_.front()));
    pending_.pop_front();
    writing_ = true;
    Tcp().expires_after(Chrono(edge_.options_.write_timeout));
    auto done = [self = this->shared_from_this(), piece](
                    beast::error_code ec, size_t) { self->OnWritten(ec); };
    if (framing_ == Framing::kDownload) {
      net::async_write(stream_, net::buffer(*piece), std::move(done));
    } else {
      net::async_write(stream_, bhttp::make_chunk(net::buffer(*piece)),
                       std::move(done));
    }
  }

  void OnWritten(beast::error_code ec) {
    writing_ = false;
    if (ec) return Close();
    // Idle between messages: a quiet stream is not a stalled client.
    Tcp().expires_never();
    if (!latest_only_ && call_ != nullptr && !ended_) call_->RequestNext();
    WriteNext();
  }

  // Bytes written to the socket that the kernel has not sent yet.
  int Unsent() {
    int unsent = 0;
    if (::ioctl(Tcp().socket().native_handle(), SIOCOUTQNSD, &unsent) != 0) {
      return 0;
    }
    return unsent;
  }

  // While a response streams nothing more is read: a client that hangs up
  // ends the stream. (Through the TLS layer, not by polling the socket:
  // TLS traffic of its own makes the socket readable.)
  void WatchForHangUp() {
    stream_.async_read_some(
        net::buffer(hang_up_byte_),
        [self = this->shared_from_this()](beast::error_code ec, size_t) {
          // Bytes (a pipelined request) are left alone; the connection
          // closes after the stream.
          if (!ec || self->closed_) return;
          if (self->call_ != nullptr) self->call_->Cancel();
          self->ended_ = true;
          self->Close();
        });
  }

  // ----- downloads -----

  void Download(absl::string_view path) {
    const unsigned version = request_.version();
    // /files/sessions/<session>/{artifacts|frames}/<id>
    std::vector<absl::string_view> parts = absl::StrSplit(path, '/');
    if (parts.size() >= 5 && parts[2] == "sessions" && parts[4] == "report") {
      // /files/sessions/<session>/report/<name>: the rest of the path is
      // the name, so that a '/' in it is refused as such.
      return DownloadReportFile(
          path, std::string(parts[3]),
          absl::StrJoin(parts.begin() + 5, parts.end(), "/"));
    }
    int64_t id = 0;
    if (parts.size() != 6 || parts[2] != "sessions" ||
        (parts[4] != "artifacts" && parts[4] != "frames") ||
        !absl::SimpleAtoi(parts[5], &id) || id <= 0) {
      return Send(ErrorResponse(
          version,
          absl::NotFoundError(absl::StrCat(
              "no such file: ", QuoteInput(path),
              " (files are at /files/sessions/<session>/artifacts/<id>, "
              "/files/sessions/<session>/frames/<id> and "
              "/files/sessions/<session>/report/<name>)"))));
    }
    absl::StatusOr<rpc::EdgeCaller> caller = Caller();
    const bool artifact = parts[4] == "artifacts";
    absl::StatusOr<RpcMethod> method =
        FindRpcMethod(artifact ? "/hdrstereo.v1.Sessions/DownloadArtifact"
                               : "/hdrstereo.v1.Sessions/DownloadFrame");
    if (!caller.ok() || !method.ok()) {
      const absl::Status status =
          caller.ok() ? method.status() : caller.status();
      edge_.Audit(rpc::Principal(), peer_, path, status);
      return Send(ErrorResponse(version, status));
    }
    ReadRangeHeaders();
    StartDownload(*method, std::string(parts[3]), id, artifact, *caller);
  }

  void ReadRangeHeaders() {
    if (const auto header = request_.find(bhttp::field::range);
        header != request_.end()) {
      range_ = ParseRange(Sv(header->value()));
    }
    // If-Range: the range holds only for the file the client has.
    if (const auto header = request_.find(bhttp::field::if_range);
        header != request_.end()) {
      if_range_ = std::string(header->value());
    }
  }

  // A file of the session's report by its name, so that the page's
  // relative links to its images resolve here: the artifact of path
  // report/<name>, found with Sessions.ListArtifacts as the caller, then
  // sent by DownloadArtifact as the id route sends it. Both calls go
  // through the bridge, so the guard authorizes and audits them as it
  // does the id route's.
  void DownloadReportFile(absl::string_view path, std::string session,
                          absl::string_view name) {
    const unsigned version = request_.version();
    absl::StatusOr<std::string> file = ReportFilePath(name);
    if (!file.ok()) return Send(ErrorResponse(version, file.status()));
    absl::StatusOr<rpc::EdgeCaller> caller = Caller();
    absl::StatusOr<RpcMethod> list =
        FindRpcMethod("/hdrstereo.v1.Sessions/ListArtifacts");
    absl::StatusOr<RpcMethod> download =
        FindRpcMethod("/hdrstereo.v1.Sessions/DownloadArtifact");
    if (!caller.ok() || !list.ok() || !download.ok()) {
      const absl::Status status = !caller.ok() ? caller.status()
                                  : !list.ok() ? list.status()
                                               : download.status();
      edge_.Audit(rpc::Principal(), peer_, path, status);
      return Send(ErrorResponse(version, status));
    }
    ReadRangeHeaders();
    report_ = true;
    FindReportFile(*list, *download, std::move(session), std::move(*file), "",
                   *caller);
  }

  // One page of the session's report artifacts; the next, until `file`
  // is found or the pages end.
  void FindReportFile(const RpcMethod& list, const RpcMethod& download,
                      std::string session, std::string file,
                      const std::string& page_token,
                      const rpc::EdgeCaller& caller) {
    v1::ListArtifactsRequest request;
    request.set_session(session);
    request.set_kind("report");
    request.mutable_page()->set_page_size(kReportListPageSize);
    request.mutable_page()->set_page_token(page_token);
    edge_.CallStarted();
    edge_.bridge_.Unary(
        list, request.SerializeAsString(), caller, edge_.options_.unary_timeout,
        [self = this->shared_from_this(), edge = &edge_, list, download,
         session = std::move(session), file = std::move(file),
         caller](absl::StatusOr<std::string> response) mutable {
          auto executor = self->stream_.get_executor();
          net::post(
              executor, [self = std::move(self), list, download,
                         session = std::move(session), file = std::move(file),
                         caller, response = std::move(response)]() mutable {
                self->OnReportFilesListed(list, download, std::move(session),
                                          std::move(file), caller,
                                          std::move(response));
              });
          edge->CallEnded();
        });
  }

  void OnReportFilesListed(const RpcMethod& list, const RpcMethod& download,
                           std::string session, std::string file,
                           const rpc::EdgeCaller& caller,
                           absl::StatusOr<std::string> response) {
    if (closed_) return;
    const unsigned version = request_.version();
    v1::ListArtifactsResponse listed;
    if (response.ok() && !listed.ParseFromString(*response)) {
      response = absl::InternalError("ListArtifacts sent a malformed answer");
    }
    if (!response.ok()) return Send(ErrorResponse(version, response.status()));
    for (const v1::Artifact& artifact : listed.artifacts()) {
      if (artifact.path() == file) {
        return StartDownload(download, std::move(session), artifact.id(), true,
                             caller);
      }
    }
    if (!listed.next_page_token().empty()) {
      return FindReportFile(list, download, std::move(session), std::move(file),
                            listed.next_page_token(), caller);
    }
    Send(ErrorResponse(
        version, absl::NotFoundError(absl::StrCat(
                     "session ", session, " has no report file ",
                     QuoteInput(file.substr(file.find('/') + 1)),
                     " (a processed session's report is at /files/sessions/",
                     session, "/report/index.html)"))));
  }

  void StartDownload(const RpcMethod& method, std::string session, int64_t id,
                     bool artifact, const rpc::EdgeCaller& caller) {
    const int64_t offset = range_.has_value() ? range_->first : 0;
    // To the end: a range past the end is cut to the file here (RFC 9110),
    // which the service, refusing it, cannot do.
    const int64_t length = 0;
    std::string request;
    if (artifact) {
      v1::DownloadArtifactRequest message;
      message.set_session(session);
      message.set_artifact_id(id);
      message.set_offset_bytes(offset);
      message.set_length_bytes(length);
      request = message.SerializeAsString();
    } else {
      v1::DownloadFrameRequest message;
      message.set_session(session);
      message.set_frame_id(id);
      message.set_offset_bytes(offset);
      message.set_length_bytes(length);
      request = message.SerializeAsString();
    }
    download_ = DownloadState{method, std::move(session), id, artifact, caller};
    framing_ = Framing::kDownload;
    edge_.CallStarted();
    call_ = edge_.bridge_.Stream(
        method, std::move(request), caller, absl::InfiniteDuration(),
        [self = this->shared_from_this()](std::string message) {
          net::post(self->stream_.get_executor(),
                    [self, message = std::move(message)]() mutable {
                      self->OnChunk(std::move(message));
                    });
        },
        [self = this->shared_from_this(),
         edge = &edge_](absl::Status status) mutable {
          auto executor = self->stream_.get_executor();
          net::post(executor, [self = std::move(self), status] {
            self->OnDownloadEnd(status);
          });
          edge->CallEnded();
        });
    edge_.Track(call_);
  }

  void OnChunk(std::string bytes) {
    if (closed_ || ended_) return;
    v1::ArtifactChunk chunk;
    if (!chunk.ParseFromString(bytes)) return call_->Cancel();
    if (!headers_sent_) {
      const std::string etag = absl::StrCat("\"", chunk.sha256(), "\"");
      const int64_t total = chunk.total_size_bytes();
      if (if_range_.has_value() && range_.has_value() && *if_range_ != etag) {
        // The client's copy is another file: the whole file, from the top.
        if_range_.reset();
        range_.reset();
        call_->Cancel();
        restart_ = true;
        return;
      }
      const auto if_none_match = request_.find(bhttp::field::if_none_match);
      const bool not_modified =
          if_none_match != request_.end() && if_none_match->value() == etag;
      auto header = std::make_shared<bhttp::response<bhttp::empty_body>>(
          not_modified         ? bhttp::status::not_modified
          : range_.has_value() ? bhttp::status::partial_content
                               : bhttp::status::ok,
          request_.version());
      AddSecurityHeaders(header->base());
      header->set("Content-Security-Policy",
                  report_ ? kReportPolicy : kFilePolicy);
      header->set(bhttp::field::etag, etag);
      header->set(bhttp::field::accept_ranges, "bytes");
      header->set(bhttp::field::cache_control, "private, no-cache");
      header->set(bhttp::field::content_type,
                  report_ ? ReportFileContentType(chunk.path())
                          : FileContentType(chunk.path()));
      header->keep_alive(false);
      remaining_ = total - chunk.offset_bytes();
      if (range_.has_value()) {
        absl::StatusOr<ResolvedRange> resolved = ResolveRange(*range_, total);
        if (!resolved.ok()) {
          call_->Cancel();
          ended_ = true;
          headers_sent_ = true;  // this answer is the response
          StringResponse response =
              ErrorResponse(request_.version(), resolved.status());
          response.result(bhttp::status::range_not_satisfiable);
          response.set(bhttp::field::content_range,
                       absl::StrCat("bytes */", total));
          return Send(std::move(response), true);
        }
        remaining_ = resolved->length;
        header->set(
            bhttp::field::content_range,
            absl::StrCat("bytes ", resolved->offset, "-",
                         resolved->offset + resolved->length - 1, "/", total));
      }
      if (!not_modified) header->content_length(remaining_);
      headers_sent_ = true;
      if (not_modified || head_) {
        call_->Cancel();
        ended_ = true;
        remaining_ = 0;
      }
      WriteHeader(std::move(header));
      if (ended_) return;
    }
    std::string data = std::move(*chunk.mutable_data());
    if (static_cast<int64_t>(data.size()) > remaining_) {
      data.resize(static_cast<size_t>(remaining_));
    }
    remaining_ -= static_cast<int64_t>(data.size());
    if (!data.empty()) pending_.push_back(std::move(data));
    if (remaining_ == 0) {
      call_->Cancel();
      ended_ = true;
    }
    WriteNext();
  }

  void OnDownloadEnd(absl::Status status) {
    if (restart_) {
      restart_ = false;
      DownloadState again = download_;
      call_.reset();
      return StartDownload(again.method, again.session, again.id,
                           again.artifact, again.caller);
    }
    if (!headers_sent_ && !closed_) {
      ended_ = true;
      StringResponse response = ErrorResponse(
          request_.version(),
          status.ok() ? absl::DataLossError("the file is empty") : status);
      if (absl::IsOutOfRange(status)) {
        response.result(bhttp::status::range_not_satisfiable);
      }
      return Send(std::move(response), true);
    }
    EndStream(status);
  }

  // ----- plain responses -----

  void Send(StringResponse response, bool close = false, int status = 0) {
    if (status != 0) response.result(static_cast<bhttp::status>(status));
    // After a body left unread the connection cannot carry another request;
    // after Connection: close (or HTTP/1.0 without keep-alive) none comes,
    // and the server closes (RFC 9112, 9.6).
    if (close || body_unread_ || !request_.keep_alive()) {
      response.keep_alive(false);
    }
    // The answer to HEAD is its header alone (RFC 9110, 9.3.2), whose
    // Content-Length still says what GET would get.
    if (head_) response.body().clear();
    auto owned = std::make_shared<StringResponse>(std::move(response));
    const bool keep_alive = owned->keep_alive() && !refuse_;
    writing_ = true;
    Tcp().expires_after(Chrono(edge_.options_.write_timeout));
    bhttp::async_write(stream_, *owned,
                       [self = this->shared_from_this(), owned, keep_alive](
                           beast::error_code ec, size_t) {
                         self->writing_ = false;
                         if (ec || !keep_alive) return self->Close();
                         self->ReadHeader();
                       });
  }

  void Close() {
    if (closed_) return;
    closed_ = true;
    if (call_ != nullptr) call_->Cancel();
    beast::error_code ec;
    Tcp().socket().shutdown(tcp::socket::shutdown_both, ec);
    Tcp().close();
  }

  struct DownloadState {
    RpcMethod method;
    std::string session;
    int64_t id = 0;
    bool artifact = true;
    rpc::EdgeCaller caller;
  };

  HttpEdge::Impl& edge_;
  const ListenInfo& info_;
  Stream stream_;
  const std::string peer_;
  const bool refuse_;
  std::string cert_principal_;
  beast::flat_buffer buffer_;
  char hang_up_byte_[1];
  std::optional<bhttp::request_parser<bhttp::string_body>> parser_;
  Request request_;
  int requests_ = 0;
  std::optional<absl::StatusOr<rpc::EdgeCaller>> caller_;
  bool body_unread_ = false;
  bool head_ = false;  // the request being answered is a HEAD request
  bool closed_ = false;
  // The streamed response.
  Framing framing_ = Framing::kConnect;
  Codec codec_ = Codec::kJson;
  RpcMethod method_;
  std::shared_ptr<StreamCall> call_;
  bool latest_only_ = false;
  net::steady_timer pace_timer_{stream_.get_executor()};
  absl::Time stall_start_ = absl::InfinitePast();
  bool writing_ = false;
  bool ended_ = false;
  std::deque<std::string> pending_;
  // The download.
  DownloadState download_;
  std::optional<ByteRange> range_;
  std::optional<std::string> if_range_;
  bool headers_sent_ = false;
  bool restart_ = false;
  int64_t remaining_ = 0;
  bool report_ = false;  // a report file, by its name
};

}  // namespace

absl::StatusOr<rpc::EdgeCaller> HttpEdge::Impl::Authenticate(
    const Request& request, const std::string& cookie_name, bool key_allowed,
    const std::string& cert_principal, const std::string& peer) {
  rpc::EdgeCaller caller;
  caller.peer = peer;
  rpc::Principal& principal = caller.principal;
  const auto authorization = request.find(bhttp::field::authorization);
  if (authorization != request.end()) {
    absl::string_view token = Sv(authorization->value());
    if (!absl::ConsumePrefix(&token, "Bearer ")) {
      return absl::UnauthenticatedError(
          "the Authorization header must be \"Bearer hs_<id>_<secret>\"");
    }
    if (!key_allowed) {
      return absl::UnauthenticatedError("API keys are accepted over TLS only");
    }
    // Guesses at keys are limited as sign-ins are (a malformed key is no
    // guess: it cannot succeed).
    const std::string address = peer.substr(0, peer.rfind(':'));
    const bool well_formed = !rpc::ApiKeyIdOf(token).empty();
    if (well_formed) RETURN_IF_ERROR(throttle_.Check(address));
    absl::StatusOr<rpc::VerifiedApiKey> verified =
        services_.keys->Verify(token);
    if (!verified.ok()) {
      if (well_formed) throttle_.RecordFailure(address);
      return verified.status();
    }
    const rpc::VerifiedApiKey& key = *verified;
    principal.name = key.user;
    principal.role =
        std::min(key.role, services_.authenticator->RoleOf(key.user));
    principal.auth_method = absl::StrCat("key:", key.id);
    principal.key_expire_time = key.expire_time;
    return caller;
  }
  if (std::optional<std::string> token =
          CookieValue(Sv(request[bhttp::field::cookie]), cookie_name)) {
    ASSIGN_OR_RETURN(BrowserSession session, sessions_.Use(*token));
    absl::StatusOr<rpc::VerifiedApiKey> key =
        services_.keys->Active(session.key_id);
    if (!key.ok()) {
      sessions_.End(*token);
      return absl::UnauthenticatedError(
          absl::StrCat(key.status().message(),
                       "; the browser session it signed in has "
                       "ended"));
    }
    principal.name = key->user;
    principal.role =
        std::min(key->role, services_.authenticator->RoleOf(key->user));
    principal.auth_method = absl::StrCat("session:key:", key->id);
    principal.key_expire_time = key->expire_time;
    return caller;
  }
  if (!cert_principal.empty()) {
    RETURN_IF_ERROR(
        rpc::ValidatePrincipalName(cert_principal, "the client certificate"));
    principal.name = cert_principal;
    principal.role = services_.authenticator->RoleOf(cert_principal);
    principal.auth_method = "cert";
    return caller;
  }
  return absl::UnauthenticatedError(
      "no credentials: sign in (POST /auth/sign-in with {\"apiKey\": "
      "\"hs_...\"}), send Authorization: Bearer <API key>, or present a "
      "client certificate of the lab CA");
}

void HttpEdge::Impl::Audit(const rpc::Principal& principal,
                           const std::string& peer, absl::string_view route,
                           const absl::Status& status) {
  store::AuditRecord row;
  row.principal = principal.name;
  row.role = rpc::RoleName(principal.role);
  row.auth_method = principal.auth_method;
  row.peer = peer;
  row.transport = "http";
  row.method = QuoteInput(route);
  row.status_code = static_cast<int>(status.code());
  row.message = std::string(status.message());
  services_.audit->Record(std::move(row));
}

absl::Status HttpEdge::Impl::LoadConsole() {
  const std::filesystem::path& dir = options_.web_root;
  if (dir.empty()) {
    spdlog::warn(
        "HTTP edge: no operator's console (the folder of hdrstereod is "
        "unknown; give --web-root): GET / answers 404");
    return absl::OkStatus();
  }
  absl::StatusOr<ConsoleFiles> console =
      ConsoleFiles::Load(dir, options_.console_limits);
  if (!console.ok()) return console.status();
  if (!console->found() && options_.web_root_named) {
    return absl::NotFoundError(absl::StrCat(
        "--web-root ", dir.string(),
        ": no such directory (it should hold the built console: index.html, "
        "console.js, console.css)"));
  }
  console_ = *std::move(console);
  for (const std::string& skipped : console_.skipped()) {
    spdlog::warn("HTTP edge: not serving {}/{}", dir.string(), skipped);
  }
  if (!console_.installed()) {
    spdlog::warn(
        "HTTP edge: no operator's console in {} ({}): GET / answers 404; "
        "build it (the web_console target, which needs Node.js 20 and npm) "
        "or give --web-root",
        dir.string(),
        console_.found() ? "no index.html there" : "no such directory");
    return absl::OkStatus();
  }
  spdlog::info(
      "HTTP edge: serving the operator's console from {} ({} files, "
      "{} KiB)",
      dir.string(), console_.files().size(),
      (console_.total_bytes() + 1023) / 1024);
  return absl::OkStatus();
}

void HttpEdge::Impl::Track(const std::shared_ptr<StreamCall>& call) {
  absl::MutexLock lock(&streams_mutex_);
  // Forget the calls that have ended.
  streams_.remove_if([](const auto& weak) { return weak.expired(); });
  streams_.push_back(call);
}

absl::Status HttpEdge::Impl::Listen(const rpc::TlsMaterial* tls) {
  if (tls != nullptr) {
    ASSIGN_OR_RETURN(tls_, TlsContext(*tls));
  }
  for (const std::string& address : options_.listen) {
    const size_t colon = address.rfind(':');
    std::string host = address.substr(0, colon);
    int port = 0;
    if (colon == address.npos ||
        !absl::SimpleAtoi(address.substr(colon + 1), &port) || port < 0 ||
        port > 65535) {
      return absl::InvalidArgumentError(absl::StrCat(
          "--http-listen ", QuoteInput(address), " must be HOST:PORT"));
    }
    const bool loopback = host == "localhost" || host == "[::1]" ||
                          absl::StartsWith(host, "127.");
    if (!loopback && tls_ == nullptr) {
      return absl::InvalidArgumentError(absl::StrCat(
          "--http-listen ", address,
          " is not a loopback address: it needs TLS (--tls-cert and "
          "--tls-key)"));
    }
    const std::string bind_host =
        host == "localhost"
            ? "127.0.0.1"
            : std::string(absl::StripSuffix(absl::StripPrefix(host, "["), "]"));
    boost::system::error_code ec;
    const net::ip::address ip = net::ip::make_address(bind_host, ec);
    if (ec) {
      return absl::InvalidArgumentError(
          absl::StrCat("--http-listen ", QuoteInput(address), ": ",
                       QuoteInput(host), " is not an IP address"));
    }
    ListenInfo info;
    info.tls = tls_ != nullptr;
    info.loopback = loopback;
    info.cookie_name = info.tls ? kTlsSessionCookie : kSessionCookie;
    Listener& listener = listeners_.emplace_back(io_, std::move(info));
    const tcp::endpoint endpoint(ip, static_cast<uint16_t>(port));
    listener.acceptor.open(endpoint.protocol(), ec);
    if (!ec)
      listener.acceptor.set_option(net::socket_base::reuse_address(true), ec);
    if (!ec) listener.acceptor.bind(endpoint, ec);
    if (!ec)
      listener.acceptor.listen(net::socket_base::max_listen_connections, ec);
    if (ec) {
      return absl::UnavailableError(
          absl::StrCat("cannot serve HTTP on ", address, ": ", ec.message()));
    }
    const int bound = listener.acceptor.local_endpoint().port();
    addresses_.push_back(absl::StrCat(host, ":", bound));
    std::vector<std::string>& names = listener.info.served_names;
    names = options_.hosts;
    if (loopback || ip.is_unspecified()) {
      names.insert(names.end(), {"localhost", "127.0.0.1", "[::1]"});
    }
    if (ip.is_unspecified()) {
      // Every address of this machine: its own name.
      names.push_back(net::ip::host_name(ec));
    } else if (!loopback) {
      names.push_back(host);
    }
    for (std::string& name : names) name = absl::AsciiStrToLower(name);
  }
  for (Listener& listener : listeners_) Accept(listener);
  return absl::OkStatus();
}

void HttpEdge::Impl::Accept(Listener& listener) {
  listener.acceptor.async_accept(
      net::make_strand(io_),
      [this, &listener](beast::error_code ec, tcp::socket socket) {
        if (ec == net::error::operation_aborted ||
            !listener.acceptor.is_open()) {
          return;
        }
        if (ec) {
          // Out of file descriptors, say: try again shortly, not at once.
          spdlog::warn("HTTP edge: cannot accept a connection: {}",
                       ec.message());
          auto timer = std::make_shared<net::steady_timer>(
              listener.acceptor.get_executor(), std::chrono::milliseconds(100));
          timer->async_wait([this, &listener, timer](beast::error_code) {
            if (listener.acceptor.is_open()) Accept(listener);
          });
          return;
        }
        boost::system::error_code peer_ec;
        const tcp::endpoint remote = socket.remote_endpoint(peer_ec);
        const std::string peer = peer_ec ? "unknown" : PeerName(remote);
        const bool refuse = connections_.load() >= options_.max_connections;
        if (refuse && refusing_.load() >= kMaxRefusing) {
          socket.close(peer_ec);
        } else if (listener.info.tls) {
          std::make_shared<Connection<beast::ssl_stream<beast::tcp_stream>>>(
              *this, listener.info,
              beast::ssl_stream<beast::tcp_stream>(std::move(socket), *tls_),
              peer, refuse)
              ->Start();
        } else {
          std::make_shared<Connection<beast::tcp_stream>>(
              *this, listener.info, beast::tcp_stream(std::move(socket)), peer,
              refuse)
              ->Start();
        }
        Accept(listener);
      });
}

void HttpEdge::Impl::Run() {
  for (int i = 0; i < std::max(1, options_.threads); ++i) {
    threads_.emplace_back([this] { io_.run(); });
  }
}

void HttpEdge::Impl::Stop() {
  if (stopped_) return;
  stopped_ = true;
  for (Listener& listener : listeners_) {
    net::post(listener.acceptor.get_executor(), [&listener] {
      boost::system::error_code ec;
      listener.acceptor.close(ec);
    });
  }
  {
    absl::MutexLock lock(&streams_mutex_);
    for (const auto& weak : streams_) {
      if (std::shared_ptr<StreamCall> call = weak.lock()) call->Cancel();
    }
  }
  // The calls' callbacks post to io_: wait for them (the server's own
  // shutdown ends any that are left) before the context goes.
  for (int i = 0; i < 3000 && in_flight_.load() > 0; ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  if (in_flight_.load() > 0) {
    spdlog::warn("HTTP edge: {} calls still in flight at shutdown",
                 in_flight_.load());
  }
  io_.stop();
  for (std::thread& thread : threads_) thread.join();
  threads_.clear();
}

HttpEdge::HttpEdge(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}

HttpEdge::~HttpEdge() { Stop(); }

absl::StatusOr<std::unique_ptr<HttpEdge>> HttpEdge::Start(
    const HttpEdgeOptions& options, const rpc::TlsMaterial* tls,
    HttpEdgeServices services) {
  auto impl = std::make_unique<Impl>(options, std::move(services));
  RETURN_IF_ERROR(impl->LoadConsole());
  RETURN_IF_ERROR(impl->Listen(tls));
  impl->Run();
  return std::unique_ptr<HttpEdge>(new HttpEdge(std::move(impl)));
}

const std::vector<std::string>& HttpEdge::addresses() const {
  return impl_->addresses_;
}

void HttpEdge::Stop() { impl_->Stop(); }

}  // namespace hdrstereo::http
