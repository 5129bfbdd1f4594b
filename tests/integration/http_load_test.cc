// SPDX-License-Identifier: GPL-3.0-or-later
//
// The HTTP edge of the real daemon under hostile input and load (issue 35,
// "Bad input and load"):
// - 10,000 random requests over raw TCP sockets, so that malformed HTTP
//   reaches the edge's parser as it was made: binary garbage, broken request
//   lines, huge and negative lengths, bad chunks, header floods, truncated
//   requests and envelopes, invalid and wrongly typed JSON for every method,
//   valid calls with and without credentials, /auth, /files and unknown
//   routes. Every answer is well-formed HTTP with the security headers and,
//   for an error, the Connect error body; nothing hangs; the daemon stays
//   up, does not grow, its store stays intact and holds only what the valid
//   requests made.
// - Idle and stalled connections against the connection bound and the
//   header timeout (slow-loris).
// - 50 Connect watchers of one capture, as that many browsers would follow
//   it, see the same events as a gRPC watcher.
// - Two protocol rules the hostile requests found broken: an answer to HEAD
//   has no body, and Connection: close closes.
// Every loop is bounded in count and time.
#include <arpa/inet.h>
#include <gmock/gmock.h>
#include <google/protobuf/util/json_util.h>
#include <google/protobuf/util/message_differencer.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <boost/asio/buffer.hpp>
#include <boost/beast/http.hpp>
#include <cerrno>
#include <iostream>
#include <limits>
#include <map>
#include <memory>
#include <random>
#include <set>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "absl/algorithm/container.h"
#include "absl/strings/ascii.h"
#include "absl/strings/escaping.h"
#include "absl/strings/match.h"
#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/strings/str_join.h"
#include "absl/strings/str_replace.h"
#include "absl/strings/str_split.h"
#include "absl/strings/strip.h"
#include "absl/time/clock.h"
#include "hdrstereo/v1/jobs.grpc.pb.h"
#include "tests/integration/http_fixture.h"
#include "tests/support/proto_methods.h"

namespace hdrstereo::testing {
namespace {

namespace beast = boost::beast;
namespace bhttp = boost::beast::http;
namespace protobuf = google::protobuf;

// The seed of every random request here (thread t of a run adds t), logged
// so that a failure can be replayed.
constexpr uint32_t kSeed = 35'2026;
constexpr int kThreads = 4;
constexpr int kWarmUpRequests = 1000;
constexpr int kHostileRequests = 10000;
// The edge's limits at their defaults (daemon/http/http_edge.h).
constexpr size_t kMaxBodyBytes = size_t{4} << 20;
constexpr size_t kMaxHeaderBytes = size_t{16} << 10;
// How long one hostile request may take, answer and close included: the
// daemon closes every connection here long before (the client half-closes,
// or the call has a Connect timeout); one that is still open is a hang.
constexpr absl::Duration kRequestTimeout = absl::Seconds(10);
// What a connection keeps of what it receives (downloads are small here).
constexpr size_t kMaxKeptBytes = size_t{8} << 20;
// Where the real client (the operator, with a valid key) and the hostile
// one connect from.
constexpr char kOperatorAddress[] = "127.0.0.1";
constexpr char kAttackerAddress[] = "127.0.0.2";

// ----- a raw TCP client -----

// A TCP connection to 127.0.0.1:`port` from `source` (any address of
// 127/8 is this machine's), written and read with POSIX calls, so that the
// daemon's parser gets exactly the bytes a test made. A send blocks at
// most 5 s (the daemon may stop reading).
class RawConnection {
 public:
  explicit RawConnection(int port, const char* source = kOperatorAddress) {
    fd_ = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
    if (fd_ < 0) return;
    const timeval send_timeout = {5, 0};
    ::setsockopt(fd_, SOL_SOCKET, SO_SNDTIMEO, &send_timeout,
                 sizeof(send_timeout));
    sockaddr_in from = {};
    from.sin_family = AF_INET;
    ::inet_pton(AF_INET, source, &from.sin_addr);
    sockaddr_in to = {};
    to.sin_family = AF_INET;
    to.sin_port = htons(static_cast<uint16_t>(port));
    to.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    if (::bind(fd_, reinterpret_cast<const sockaddr*>(&from), sizeof(from)) !=
            0 ||
        ::connect(fd_, reinterpret_cast<const sockaddr*>(&to), sizeof(to)) !=
            0) {
      Close();
    }
  }
  RawConnection(RawConnection&& other) noexcept
      : fd_(std::exchange(other.fd_, -1)) {}
  RawConnection& operator=(RawConnection&&) = delete;
  ~RawConnection() { Close(); }

  bool connected() const { return fd_ >= 0; }

  // Sends what the daemon takes of `bytes`; false when it stopped taking
  // them (it closed the connection, or did not read for 5 s).
  bool Send(absl::string_view bytes) {
    while (!bytes.empty()) {
      const ssize_t sent =
          ::send(fd_, bytes.data(), bytes.size(), MSG_NOSIGNAL);
      if (sent < 0 && errno == EINTR) continue;
      if (sent <= 0) return false;
      bytes.remove_prefix(static_cast<size_t>(sent));
    }
    return true;
  }

  // Nothing more from this side: the daemon reads the end of the stream.
  void ShutdownWrite() { ::shutdown(fd_, SHUT_WR); }

  void Close() {
    if (fd_ >= 0) ::close(fd_);
    fd_ = -1;
  }

  struct Received {
    std::string bytes;
    bool closed = false;  // by the daemon (the end of the stream, or reset)
    bool reset = false;
  };
  // Reads until the daemon closes the connection or `timeout` passes.
  Received ReadUntilClosed(absl::Duration timeout) {
    Received received;
    const absl::Time deadline = absl::Now() + timeout;
    std::vector<char> buffer(64 << 10);
    while (true) {
      const int64_t left_ms = absl::ToInt64Milliseconds(deadline - absl::Now());
      if (left_ms <= 0) return received;
      pollfd readable = {fd_, POLLIN, 0};
      if (::poll(&readable, 1, static_cast<int>(left_ms)) <= 0) continue;
      const ssize_t n = ::recv(fd_, buffer.data(), buffer.size(), 0);
      if (n < 0 && errno == EINTR) continue;
      if (n > 0) {
        if (received.bytes.size() < kMaxKeptBytes) {
          received.bytes.append(buffer.data(), static_cast<size_t>(n));
        }
        continue;
      }
      received.closed = true;
      received.reset = n < 0;
      return received;
    }
  }

 private:
  int fd_ = -1;
};

// ----- reading the daemon's answers -----

struct Answer {
  int status = 0;
  bool complete = false;   // the whole message arrived
  bool malformed = false;  // Beast could not read it as HTTP
  std::string content_type;
  std::string connection;
  std::string body;
  // X-Content-Type-Options: nosniff, Referrer-Policy: no-referrer and a
  // Content-Security-Policy, which every answer of the edge carries.
  bool security_headers = false;
};

// The responses in `bytes` (what came before the connection closed), read
// with Beast's parser: interim 100 Continue answers too; answer i has no
// body where heads[i] says it answers a HEAD request. A response that is
// cut off is the last one, not complete.
std::vector<Answer> ParseAnswers(absl::string_view bytes,
                                 const std::vector<bool>& heads = {}) {
  std::vector<Answer> answers;
  while (!bytes.empty()) {
    bhttp::response_parser<bhttp::string_body> parser;
    parser.eager(true);
    // Not boost::none: Beast 1.74 then refuses every Content-Length above 0
    // (it compares the length with the empty optional).
    parser.body_limit(std::numeric_limits<std::uint64_t>::max());
    parser.skip(answers.size() < heads.size() && heads[answers.size()]);
    beast::error_code ec;
    while (!bytes.empty() && !parser.is_done()) {
      const size_t used =
          parser.put(boost::asio::buffer(bytes.data(), bytes.size()), ec);
      bytes.remove_prefix(used);
      if (ec == bhttp::error::need_more) {
        ec = {};
        if (used == 0) break;
      } else if (ec) {
        break;
      }
    }
    // The connection's end ends a body that runs to it.
    if (!ec && !parser.is_done()) parser.put_eof(ec);
    Answer answer;
    answer.malformed = ec && ec != bhttp::error::partial_message;
    if (!parser.is_header_done()) {
      answer.malformed = true;
      answers.push_back(answer);
      break;
    }
    const auto& message = parser.get();
    answer.status = static_cast<int>(message.result_int());
    answer.complete = parser.is_done() && !ec;
    answer.content_type = std::string(message[bhttp::field::content_type]);
    answer.connection = std::string(message[bhttp::field::connection]);
    answer.body = message.body();
    answer.security_headers = message["X-Content-Type-Options"] == "nosniff" &&
                              message["Referrer-Policy"] == "no-referrer" &&
                              !message["Content-Security-Policy"].empty();
    answers.push_back(std::move(answer));
    if (!answers.back().complete) break;
  }
  return answers;
}

// Whether an error's Connect code fits its HTTP status: the Connect
// protocol's table (connectrpc.com/docs/protocol), written out here, and
// the statuses the edge answers for what HTTP itself decides (405 method,
// 413 body, 415 content type, 416 range, 431 headers). 500 is not here: no
// request should make the daemon fail inside.
bool CodeFitsStatus(const std::string& code, int status) {
  static const auto* const kCodes = new std::map<int, std::set<std::string>>{
      {400, {"invalid_argument", "failed_precondition", "out_of_range"}},
      {401, {"unauthenticated"}},
      {403, {"permission_denied"}},
      {404, {"not_found"}},
      {405, {"invalid_argument"}},
      {409, {"already_exists", "aborted"}},
      {413, {"resource_exhausted"}},
      {415, {"invalid_argument"}},
      {416, {"out_of_range"}},
      {429, {"resource_exhausted"}},
      {431, {"resource_exhausted"}},
      {499, {"canceled"}},
      {501, {"unimplemented"}},
      {503, {"unavailable"}},
      {504, {"deadline_exceeded"}}};
  auto it = kCodes->find(status);
  return it != kCodes->end() && it->second.count(code) > 0;
}

// The end of a streamed answer as JSON ({} or {"error": {...}}): Connect's
// end-of-stream message or the SSE "event: end" block; discarded when the
// stream has none.
nlohmann::json StreamEnd(const Answer& answer) {
  const nlohmann::json none(nlohmann::json::value_t::discarded);
  if (absl::StartsWith(answer.content_type, "text/event-stream")) {
    const std::string end = "event: end\ndata: ";
    const size_t at = answer.body.rfind(end);
    if (at == std::string::npos) return none;
    return nlohmann::json::parse(answer.body.substr(at + end.size()), nullptr,
                                 false);
  }
  std::vector<StreamMessage> messages = ParseEnvelopes(answer.body);
  if (messages.empty() || !messages.back().end) return none;
  return nlohmann::json::parse(messages.back().payload, nullptr, false);
}

// ----- hostile requests -----

struct HostileRequest {
  explicit HostileRequest(std::string kind) : category(std::move(kind)) {}

  std::string category;
  std::string bytes;  // what is sent, as is
  // The client half-closes after sending, so that the daemon sees the end
  // of a request it waits for the rest of. Streams that must run to their
  // end (with a Connect timeout) keep it open.
  bool half_close = true;
  bool head = false;  // a HEAD request: its answer has no body
  // "/hdrstereo.v1.Sessions/Create": the RPC it calls, for counting what
  // valid calls created.
  std::string rpc;
  // What its (first final) answer must be, when the request decides it:
  // one of `statuses` (empty: any), the error's code and part of its
  // message. A request with statuses set must be answered unless the
  // connection was reset (the daemon closes on a request it refused before
  // reading all of it).
  std::vector<int> statuses;
  std::string code;
  std::string message_part;
  bool may_go_unanswered = false;  // statuses hold if it is answered at all
  bool no_answer = false;          // the request never ends: no answer
  bool authenticated = false;      // valid credentials: never 401
  // A stream run to its end: 200 and the end-of-stream message, carrying
  // `code` when set.
  bool stream_end = false;
  int answers = 1;  // pipelined requests: how many answers at least
};

// The random requests of one thread of a run: deterministic for a seed.
class HostileRequests {
 public:
  HostileRequests(uint32_t seed, int port, std::string key, std::string tag)
      : random_(seed),
        host_(absl::StrCat("127.0.0.1:", port)),
        key_(std::move(key)),
        tag_(std::move(tag)) {
    for (const ProtoMethod& method : AllProtoMethods()) {
      methods_.push_back(method);
      if (!method.descriptor->server_streaming()) {
        unary_.push_back(method);
      } else {
        streams_.push_back(method);
      }
    }
  }

  HostileRequest Next() {
    const size_t draw = Below(100);
    size_t bound = 0;
    for (const auto& [weight, make] : Kinds()) {
      bound += weight;
      if (draw < bound) return (this->*make)();
    }
    return ValidCall();
  }
  // How many kinds of request Next() draws from.
  static size_t KindCount() { return Kinds().size(); }

 private:
  using Maker = HostileRequest (HostileRequests::*)();
  // Each kind of request with its weight out of 100.
  static const std::vector<std::pair<size_t, Maker>>& Kinds() {
    static const auto* const kKinds = new std::vector<std::pair<size_t, Maker>>{
        {7, &HostileRequests::Garbage},
        {5, &HostileRequests::BrokenRequestLine},
        {5, &HostileRequests::BadContentLength},
        {5, &HostileRequests::Chunked},
        {5, &HostileRequests::HeaderFlood},
        {5, &HostileRequests::Truncated},
        {4, &HostileRequests::BadHostOrOrigin},
        {4, &HostileRequests::WrongContentType},
        {8, &HostileRequests::InvalidJson},
        {9, &HostileRequests::WrongTypes},
        {4, &HostileRequests::RandomProto},
        {4, &HostileRequests::BadEnvelope},
        {16, &HostileRequests::ValidCall},
        {5, &HostileRequests::Auth},
        {5, &HostileRequests::Files},
        {5, &HostileRequests::Unknown},
        {4, &HostileRequests::Pipelined}};
    return *kKinds;
  }

  // ----- random pieces -----

  size_t Below(size_t n) { return n == 0 ? 0 : random_() % n; }
  bool OneIn(size_t n) { return Below(n) == 0; }
  template <class T>
  const T& Pick(const std::vector<T>& items) {
    return items[Below(items.size())];
  }
  // Mostly short, now and then up to `max`.
  size_t Length(size_t max) {
    size_t bound = 16;
    while (bound < max && OneIn(3)) bound *= 4;
    return Below(std::min(bound, max) + 1);
  }
  std::string Bytes(size_t n) {
    std::string bytes(n, '\0');
    for (char& c : bytes) c = static_cast<char>(Below(256));
    return bytes;
  }
  std::string Text(size_t n) {
    std::string text(n, ' ');
    for (char& c : text) c = static_cast<char>(0x20 + Below(95));
    return text;
  }
  std::string Token(size_t n) {
    static constexpr char kChars[] =
        "abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789";
    std::string token(n, 'a');
    for (char& c : token) c = kChars[Below(sizeof(kChars) - 1)];
    return token;
  }
  // A text as a JSON string; bytes outside ASCII go as they are (invalid
  // UTF-8 included).
  static std::string JsonString(absl::string_view text) {
    std::string out = "\"";
    for (const char c : text) {
      if (c == '"' || c == '\\') {
        out += '\\';
        out += c;
      } else if (static_cast<unsigned char>(c) < 0x20) {
        out += absl::StrFormat("\\u%04x", c);
      } else {
        out += c;
      }
    }
    return out + "\"";
  }

  // ----- requests -----

  // "METHOD TARGET HTTP/1.1", Host, `headers`, Content-Length, `body`.
  std::string Request(absl::string_view method, absl::string_view target,
                      const std::vector<std::string>& headers,
                      absl::string_view body) const {
    std::string request =
        absl::StrCat(method, " ", target, " HTTP/1.1\r\nHost: ", host_, "\r\n");
    for (const std::string& header : headers) {
      absl::StrAppend(&request, header, "\r\n");
    }
    absl::StrAppend(&request, "Content-Length: ", body.size(), "\r\n\r\n",
                    body);
    return request;
  }
  std::string Bearer() const { return "Authorization: Bearer " + key_; }
  // An Authorization header that is not a valid key.
  std::string BadKey() {
    switch (Below(3)) {
      case 0:
        return absl::StrCat("Authorization: Bearer hs_", Token(12), "_",
                            Token(64));
      case 1:
        return "Authorization: Basic " + Token(Length(200));
      default:
        return "Authorization: Bearer " + Text(Length(300));
    }
  }
  std::string SessionCookie() {
    return "Cookie: hdrstereo_session=" + Token(1 + Length(100));
  }
  // An RPC call of `method` with JSON `json`: application/json for unary
  // calls; a stream in the Connect form (enveloped) or as SSE.
  std::string Call(const ProtoMethod& method, const std::string& json,
                   std::vector<std::string> headers) {
    if (!method.descriptor->server_streaming()) {
      headers.push_back("Content-Type: application/json");
      return Request("POST", method.full_name, headers, json);
    }
    if (OneIn(2)) {
      headers.push_back("Content-Type: application/json");
      headers.push_back("Accept: text/event-stream");
      return Request("POST", method.full_name, headers, json);
    }
    headers.push_back("Content-Type: application/connect+json");
    return Request("POST", method.full_name, headers, EnvelopeOf(json));
  }
  // A stream that ends by itself: valid credentials and a Connect timeout.
  std::vector<std::string> StreamHeaders() {
    return {Bearer(), absl::StrCat("Connect-Timeout-Ms: ", 50 + Below(450))};
  }

  // ----- JSON -----

  // A JSON value of any type, with what JSON parsers trip on: huge and
  // odd numbers, invalid UTF-8, lone surrogates, NUL escapes.
  std::string AnyJson(int depth) {
    static const std::vector<std::string> kOdd = {
        "1e999999",
        "-0",
        "18446744073709551616",
        "9223372036854775808",
        "-9223372036854775809",
        "1E+2",
        "0.0000000000000000000000001",
        "123456789012345678901234567890",
        "\"NaN\"",
        "\"-Infinity\"",
        "\"\\ud800\"",
        "\"\\u0000\"",
        "\"\xff\xfe\"",
        "\"\xc3\""};
    switch (Below(depth >= 3 ? 6 : 8)) {
      case 0:
        return "null";
      case 1:
        return OneIn(2) ? "true" : "false";
      case 2:
        return absl::StrCat(static_cast<int>(Below(21)) - 10);
      case 3:
        return Pick(kOdd);
      case 4:
        return JsonString(Text(Length(64)));
      case 5:
        return JsonString(Bytes(Length(16)));
      case 6: {
        std::string array = "[";
        for (size_t i = 0, n = Below(4); i < n; ++i) {
          absl::StrAppend(&array, i ? "," : "", AnyJson(depth + 1));
        }
        return array + "]";
      }
      default: {
        std::string object = "{";
        for (size_t i = 0, n = Below(4); i < n; ++i) {
          absl::StrAppend(&object, i ? "," : "",
                          JsonString(Token(1 + Below(8))), ":",
                          AnyJson(depth + 1));
        }
        return object + "}";
      }
    }
  }

  // A value of the type `field` takes, in protobuf's JSON mapping.
  std::string ValueOf(const protobuf::FieldDescriptor* field, int depth) {
    if (field->is_map()) {
      std::string object = "{";
      for (size_t i = 0, n = Below(3); i < n; ++i) {
        absl::StrAppend(
            &object, i ? "," : "", JsonString(Token(1 + Below(6))), ":",
            ScalarOf(field->message_type()->map_value(), depth + 1));
      }
      return object + "}";
    }
    if (field->is_repeated()) {
      std::string array = "[";
      for (size_t i = 0, n = Below(3); i < n; ++i) {
        absl::StrAppend(&array, i ? "," : "", ScalarOf(field, depth + 1));
      }
      return array + "]";
    }
    return ScalarOf(field, depth);
  }
  std::string ScalarOf(const protobuf::FieldDescriptor* field, int depth) {
    using Cpp = protobuf::FieldDescriptor::CppType;
    switch (field->cpp_type()) {
      case Cpp::CPPTYPE_INT32:
      case Cpp::CPPTYPE_INT64:
      case Cpp::CPPTYPE_UINT32:
      case Cpp::CPPTYPE_UINT64: {
        // Small ones name what exists (job 1, frame 2).
        const size_t value = OneIn(2) ? Below(6) : Below(100000);
        return OneIn(2) ? absl::StrCat(value) : absl::StrCat("\"", value, "\"");
      }
      case Cpp::CPPTYPE_DOUBLE:
      case Cpp::CPPTYPE_FLOAT:
        return Pick(std::vector<std::string>{"0", "0.01", "1.5", "250", "-3",
                                             "\"NaN\""});
      case Cpp::CPPTYPE_BOOL:
        return OneIn(2) ? "true" : "false";
      case Cpp::CPPTYPE_ENUM: {
        const protobuf::EnumDescriptor* type = field->enum_type();
        return JsonString(
            type->value(static_cast<int>(Below(type->value_count())))->name());
      }
      case Cpp::CPPTYPE_STRING:
        if (field->type() == protobuf::FieldDescriptor::TYPE_BYTES) {
          return JsonString(absl::Base64Escape(Bytes(Length(32))));
        }
        return JsonString(Token(Length(24)));
      case Cpp::CPPTYPE_MESSAGE:
        if (field->message_type()->full_name() == "google.protobuf.Timestamp") {
          return "\"2026-12-05T01:00:00Z\"";
        }
        return ObjectOf(field->message_type(), depth + 1, true);
    }
    return "null";
  }

  // An object of message `type`: some of its fields (one of a oneof) by
  // their JSON or proto names, with values of their types or, unless
  // `right_types`, of any type; never `left_out` nor another field of its
  // oneof.
  std::string ObjectOf(const protobuf::Descriptor* type, int depth,
                       bool right_types,
                       const protobuf::FieldDescriptor* left_out = nullptr) {
    std::set<const protobuf::OneofDescriptor*> oneofs;
    if (left_out != nullptr && left_out->containing_oneof() != nullptr) {
      oneofs.insert(left_out->containing_oneof());
    }
    std::string object = "{";
    if (depth < 4) {
      for (int i = 0; i < type->field_count(); ++i) {
        const protobuf::FieldDescriptor* field = type->field(i);
        if (field == left_out || !OneIn(2)) continue;
        if (field->containing_oneof() != nullptr &&
            !oneofs.insert(field->containing_oneof()).second) {
          continue;
        }
        absl::StrAppend(
            &object, object.size() > 1 ? "," : "",
            JsonString(OneIn(2) ? field->json_name() : field->name()), ":",
            right_types || OneIn(2) ? ValueOf(field, depth) : AnyJson(depth));
      }
    }
    if (!right_types && OneIn(6)) {
      absl::StrAppend(&object, object.size() > 1 ? "," : "",
                      JsonString(Text(Length(20))), ":", AnyJson(depth));
    }
    return object + "}";
  }

  // ----- the categories -----

  HostileRequest Garbage() {
    HostileRequest request("garbage");
    request.bytes = Bytes(1 + Length(64 << 10));
    // A malformed request, or one longer than the header limit; or the
    // start of one ("Q"), which never ends.
    request.statuses = {400, 431};
    request.may_go_unanswered = true;
    return request;
  }

  HostileRequest BrokenRequestLine() {
    HostileRequest request("request line");
    const std::vector<std::string> methods = {"GET",
                                              "POST",
                                              "get",
                                              "",
                                              "P0ST",
                                              "GET\x01",
                                              Token(Length(10000)),
                                              Text(Length(20)),
                                              "\xff\xfe"};
    const std::vector<std::string> targets = {"/",
                                              "*",
                                              "",
                                              "http://evil.example/x",
                                              "//",
                                              "/%00",
                                              "/a b",
                                              "/\x7f",
                                              Text(Length(100)),
                                              Bytes(Length(40)),
                                              "/" + Token(20000)};
    const std::vector<std::string> versions = {
        "HTTP/1.1", "HTTP/1.0", "HTTP/2.0",   "HTTP/1",   "HTTP/1.10",
        "http/1.1", "",         "HTTP/1.1 x", "HTTP/9.9", Bytes(Length(8))};
    const std::vector<std::string> ends = {"\r\n", "\n", "\r", ""};
    request.bytes =
        absl::StrCat(Pick(methods), OneIn(4) ? "  " : " ", Pick(targets), " ",
                     Pick(versions), Pick(ends), "Host: ", host_, "\r\n");
    if (OneIn(2)) absl::StrAppend(&request.bytes, Bearer(), "\r\n");
    absl::StrAppend(&request.bytes, "\r\n");
    return request;
  }

  HostileRequest BadContentLength() {
    HostileRequest request("content length");
    const ProtoMethod& method = Pick(methods_);
    request.rpc = method.full_name;
    std::vector<std::string> headers = {Bearer(),
                                        "Content-Type: application/json"};
    std::string length;
    switch (Below(5)) {
      case 0:
        // Within 64 bits, beyond the body limit: refused before the body.
        length = absl::StrCat(kMaxBodyBytes + 1 + Below(1u << 30));
        request.statuses = {413};
        request.code = "resource_exhausted";
        request.message_part = absl::StrCat(
            "the request body is larger than the limit of ", kMaxBodyBytes);
        break;
      case 1:
        length = "1" + std::string(19 + Below(30), '9');  // overflows
        request.statuses = {400};
        request.message_part = "malformed HTTP request";
        break;
      case 2:
        length = Pick(std::vector<std::string>{"-1", "+5", "5 5", "0x10", "1e3",
                                               "", "5,6", "\xff"});
        request.statuses = {400};
        request.message_part = "malformed HTTP request";
        break;
      case 3:
        // Two lengths that disagree.
        headers.push_back("Content-Length: 3");
        length = "7";
        request.statuses = {400};
        request.message_part = "malformed HTTP request";
        break;
      default:
        // More declared than sent: the rest never comes.
        length = absl::StrCat(3 + Below(1000));
        request.no_answer = true;
        break;
    }
    request.bytes = absl::StrCat("POST ", method.full_name,
                                 " HTTP/1.1\r\nHost: ", host_, "\r\n");
    for (const std::string& header : headers) {
      absl::StrAppend(&request.bytes, header, "\r\n");
    }
    absl::StrAppend(&request.bytes, "Content-Length: ", length, "\r\n\r\n{}");
    return request;
  }

  HostileRequest Chunked() {
    HostileRequest request("chunked");
    const ProtoMethod& method = Pick(unary_);
    request.rpc = method.full_name;
    std::string body;
    switch (Below(5)) {
      case 0: {
        // Well-formed chunks of a valid call ("{", "}", the last chunk).
        body = "1\r\n{\r\n1\r\n}\r\n0\r\n\r\n";
        request.authenticated = true;
        break;
      }
      case 1:
        body = absl::StrCat(
            Pick(std::vector<std::string>{"zz", "-5", "", " ", "0x5", "5 5"}),
            "\r\n{}\r\n0\r\n\r\n");
        request.statuses = {400};
        request.message_part = "malformed HTTP request";
        break;
      case 2:
        // A size beyond 64 bits, or beyond the body limit.
        body =
            absl::StrCat(OneIn(2) ? std::string(17 + Below(20), 'f')
                                  : absl::StrCat(absl::Hex(kMaxBodyBytes + 1)),
                         "\r\n{}\r\n");
        request.statuses = {400, 413};
        break;
      case 3:
        // Chunk extensions and trailers, many of them.
        for (size_t i = 0, n = Length(4000); i < n; ++i) {
          absl::StrAppend(&body, "1;", Token(4), "=", Token(4), "\r\nx\r\n");
        }
        absl::StrAppend(&body, "0\r\n");
        for (size_t i = 0, n = Length(2000); i < n; ++i) {
          absl::StrAppend(&body, "X-", Token(6), ": ", Token(8), "\r\n");
        }
        absl::StrAppend(&body, "\r\n");
        break;
      default:
        // No last chunk: the body never ends.
        body = "2\r\n{}\r\n";
        request.no_answer = true;
        break;
    }
    const bool both_framings = OneIn(8);
    request.bytes =
        absl::StrCat("POST ", method.full_name, " HTTP/1.1\r\nHost: ", host_,
                     "\r\n", Bearer(), "\r\nContent-Type: application/json\r\n",
                     both_framings ? "Content-Length: 4\r\n" : "",
                     "Transfer-Encoding: chunked\r\n\r\n", body);
    if (both_framings) {
      // A request smuggler's favourite: refused or read as chunked.
      request.statuses.clear();
      request.message_part.clear();
      request.no_answer = false;
    }
    return request;
  }

  HostileRequest HeaderFlood() {
    HostileRequest request("headers");
    std::vector<std::string> headers = {Bearer(),
                                        "Content-Type: application/json"};
    switch (Below(4)) {
      case 0:
        headers.push_back("X-Flood: " + Token(kMaxHeaderBytes + Below(40000)));
        request.statuses = {431};
        request.message_part =
            absl::StrCat("the request headers are larger than the limit of ",
                         kMaxHeaderBytes, " bytes");
        break;
      case 1:
        for (size_t i = 0; i < 1500 + Below(5000); ++i) {
          headers.push_back(absl::StrCat("X-", i, ": ", Token(8)));
        }
        request.statuses = {431};
        request.message_part = "the request headers are larger than the limit";
        break;
      case 2:
        // A control character in a value, a name that is not a token, a
        // line without a colon.
        headers.push_back(Pick(
            std::vector<std::string>{"X-A: a\x01"
                                     "b",
                                     "X A: b", "X-A b", "X-\x80: b", ": b"}));
        request.statuses = {400};
        request.message_part = "malformed HTTP request";
        break;
      default:
        // Odd but possibly valid: folded lines, bytes above 0x7f, empty
        // values, many cookies.
        headers.push_back("X-Folded: a\r\n b");
        headers.push_back("X-High: \xc3\xa9\xff");
        headers.push_back("X-Empty:");
        headers.push_back("Cookie: " + Text(Length(2000)));
        break;
    }
    request.bytes =
        Request("POST", "/hdrstereo.v1.Server/GetInfo", headers, "{}");
    return request;
  }

  HostileRequest Truncated() {
    HostileRequest request("truncated");
    const ProtoMethod& method = Pick(methods_);
    const std::string whole =
        Call(method, ObjectOf(method.descriptor->input_type(), 0, false),
             {Bearer()});
    // Cut anywhere before the end: the daemon waits for the rest, then
    // sees the end of the stream.
    request.bytes = whole.substr(0, Below(whole.size()));
    request.no_answer = true;
    return request;
  }

  HostileRequest BadHostOrOrigin() {
    HostileRequest request("host/origin");
    const ProtoMethod& method = Pick(unary_);
    request.rpc = method.full_name;
    std::string host_line = "Host: " + host_;
    std::vector<std::string> extra;
    // Whatever is wrong, the request is refused before anything else.
    request.statuses = {403};
    request.code = "permission_denied";
    switch (Below(4)) {
      case 0:
        // Another name (DNS rebinding).
        host_line = Pick(std::vector<std::string>{
            "Host: evil.example", "Host: evil.example:80", "Host: 127.0.0.2",
            "Host: localhost.evil.example"});
        request.message_part = "is not served under the name";
        break;
      case 1:
        host_line = Pick(std::vector<std::string>{
            "Host: a b", "Host: [zz]", "Host: 127.0.0.1:99999",
            "Host: " + Token(400), "Host:"});
        request.message_part = "the Host header";
        break;
      case 2:
        host_line.clear();
        request.message_part = "the Host header";
        break;
      default:
        extra.push_back(Pick(std::vector<std::string>{
            "Origin: http://evil.example", "Origin: null",
            "Origin: https://" + host_, "Origin: " + Text(Length(80))}));
        request.message_part = "cross-site requests are refused";
        break;
    }
    request.bytes = absl::StrCat("POST ", method.full_name, " HTTP/1.1\r\n");
    if (!host_line.empty()) absl::StrAppend(&request.bytes, host_line, "\r\n");
    for (const std::string& header : extra) {
      absl::StrAppend(&request.bytes, header, "\r\n");
    }
    absl::StrAppend(&request.bytes, Bearer(),
                    "\r\nContent-Type: application/json\r\n"
                    "Content-Length: 2\r\n\r\n{}");
    return request;
  }

  HostileRequest WrongContentType() {
    HostileRequest request("content type");
    const ProtoMethod& method = Pick(methods_);
    request.rpc = method.full_name;
    const bool streaming = method.descriptor->server_streaming();
    std::vector<std::string> headers = {Bearer()};
    std::vector<std::string> types = {
        "application/x-www-form-urlencoded",
        "multipart/form-data; boundary=x",
        "text/plain",
        "application/json; charset=latin1",
        "application/xml",
        "application/json+x",
        streaming ? "application/json" : "application/connect+json"};
    if (!OneIn(5)) headers.push_back("Content-Type: " + Pick(types));
    request.bytes = Request("POST", method.full_name, headers, "{}");
    request.statuses = {415};
    request.code = "invalid_argument";
    request.message_part = method.full_name + " takes Content-Type";
    return request;
  }

  // The headers, body and expectations of a call whose body is refused:
  // a unary answer, or a stream that ends at once with the error.
  void RefusedBody(const ProtoMethod& method, const std::string& payload,
                   bool envelope_given, HostileRequest& request) {
    request.rpc = method.full_name;
    request.code = "invalid_argument";
    request.authenticated = true;
    if (!method.descriptor->server_streaming()) {
      request.bytes =
          Request("POST", method.full_name,
                  {Bearer(), "Content-Type: application/json"}, payload);
      request.statuses = {400};
      return;
    }
    request.half_close = false;
    request.stream_end = true;
    std::vector<std::string> headers = StreamHeaders();
    if (!envelope_given && OneIn(2)) {
      headers.push_back("Content-Type: application/json");
      headers.push_back("Accept: text/event-stream");
      request.bytes = Request("POST", method.full_name, headers, payload);
      return;
    }
    headers.push_back("Content-Type: application/connect+json");
    request.bytes = Request("POST", method.full_name, headers,
                            envelope_given ? payload : EnvelopeOf(payload));
  }

  HostileRequest InvalidJson() {
    HostileRequest request("invalid json");
    const ProtoMethod& method = Pick(methods_);
    std::string body;
    switch (Below(6)) {
      case 0:
        body = Bytes(1 + Length(4096));
        if (absl::StripAsciiWhitespace(body).empty()) body += "x";
        break;
      case 1: {
        const std::string whole =
            ObjectOf(method.descriptor->input_type(), 0, true);
        body = whole.substr(0, Below(whole.size()));  // "{" at least
        if (body.empty()) body = "{";
        break;
      }
      case 2: {
        // Nesting far deeper than any message.
        const size_t depth = 100 + Length(100000);
        if (OneIn(2)) {
          body = std::string(depth, '[') + std::string(depth, ']');
        } else {
          for (size_t i = 0; i < depth; ++i) body += "{\"a\":";
          body += "1" + std::string(depth, '}');
        }
        break;
      }
      case 3:
        body = Pick(std::vector<std::string>{"[]", "\"text\"", "5", "true",
                                             "{} x", "{,}", "{\"a\" 1}",
                                             "{'a': 1}", "{\"\xff\": 1}"});
        break;
      case 4:
        // A field the message does not have.
        body = "{" + JsonString(Text(Length(40))) + ": " + AnyJson(0) + "}";
        break;
      default:
        // A valid object with a leading comma, or something after it.
        body = ObjectOf(method.descriptor->input_type(), 0, true);
        if (OneIn(2)) {
          body.insert(1, ",");
        } else {
          body += Pick(std::vector<std::string>{"}", "]", ",", "x", "{}"});
        }
        break;
    }
    RefusedBody(method, body, false, request);
    request.message_part = "the body is not a JSON " +
                           method.descriptor->input_type()->full_name();
    return request;
  }

  // One field given a value of a type it cannot take, the others valid:
  // the refusal names the field.
  HostileRequest WrongTypes() {
    HostileRequest request("wrong types");
    const ProtoMethod& method = Pick(methods_);
    const protobuf::Descriptor* type = method.descriptor->input_type();
    std::vector<const protobuf::FieldDescriptor*> fields;
    for (int i = 0; i < type->field_count(); ++i) {
      const protobuf::FieldDescriptor* field = type->field(i);
      // A Timestamp takes a string: no value is wrong for it in the same
      // way for every field.
      if (field->message_type() != nullptr &&
          absl::StartsWith(field->message_type()->full_name(),
                           "google.protobuf.")) {
        continue;
      }
      fields.push_back(field);
    }
    std::string object = ObjectOf(type, 0, true);
    std::string wrong;
    std::string named;
    if (fields.empty()) {
      named = "zz" + Token(6);
      wrong = absl::StrCat(JsonString(named), ":1");
    } else {
      const protobuf::FieldDescriptor* field = Pick(fields);
      named = field->name();
      std::string value;
      if (field->is_map()) {
        value = "[1]";
      } else if (field->is_repeated()) {
        value = field->message_type() != nullptr ? "[5]" : "[{\"zz\": 1}]";
      } else {
        value = field->message_type() != nullptr ? "5" : "{\"zz\": 1}";
      }
      wrong = absl::StrCat(
          JsonString(OneIn(2) ? field->json_name() : field->name()), ":",
          value);
      object = ObjectOf(type, 0, true, field);
    }
    object = object.size() > 2 ? absl::StrCat("{", wrong, ",", object.substr(1))
                               : absl::StrCat("{", wrong, "}");
    RefusedBody(method, object, false, request);
    request.message_part = named;
    return request;
  }
  HostileRequest RandomProto() {
    HostileRequest request("binary proto");
    const ProtoMethod& method = Pick(methods_);
    request.rpc = method.full_name;
    request.authenticated = true;
    const std::string payload = Bytes(Length(2048));
    if (!method.descriptor->server_streaming()) {
      request.bytes =
          Request("POST", method.full_name,
                  {Bearer(), "Content-Type: application/proto"}, payload);
      return request;
    }
    // It may parse: a real stream, ended by its timeout.
    std::vector<std::string> headers = StreamHeaders();
    headers.push_back("Content-Type: application/connect+proto");
    request.bytes =
        Request("POST", method.full_name, headers, EnvelopeOf(payload));
    request.half_close = false;
    request.stream_end = true;
    return request;
  }

  HostileRequest BadEnvelope() {
    HostileRequest request("envelope");
    const ProtoMethod& method = Pick(streams_);
    std::string body;
    switch (Below(4)) {
      case 0:
        body = std::string(Below(5), '\0');  // shorter than the prefix
        break;
      case 1:
        body = EnvelopeOf("{}");
        body[0] = static_cast<char>(1 + Below(255));  // compressed, end, ...
        break;
      case 2: {
        // Declares other than it holds: more, less, or 4 GiB.
        body = EnvelopeOf("{}");
        const uint32_t size = Pick(std::vector<uint32_t>{
            0, 1, 3, 1000, static_cast<uint32_t>(kMaxBodyBytes + 1),
            0xffffffffu});
        for (int i = 0; i < 4; ++i) {
          body[1 + i] = static_cast<char>((size >> (24 - 8 * i)) & 0xff);
        }
        break;
      }
      default:
        body = EnvelopeOf("{}") + EnvelopeOf("{}");  // two messages
        break;
    }
    RefusedBody(method, body, true, request);
    request.message_part = "envelope";
    return request;
  }

  HostileRequest ValidCall() {
    HostileRequest request("valid json");
    const ProtoMethod& method = Pick(methods_);
    request.rpc = method.full_name;
    const bool streaming = method.descriptor->server_streaming();
    // Refused before any call: an error answer, or (Connect's rule for
    // streams) a stream that is only its end.
    auto refused = [&](const std::vector<std::string>& headers, int status,
                       const std::string& code, const std::string& part) {
      request.bytes = Call(method, "{}", headers);
      request.code = code;
      request.message_part = part;
      if (streaming) {
        request.half_close = false;
        request.stream_end = true;
      } else {
        request.statuses = {status};
      }
      return request;
    };
    switch (Below(10)) {
      case 0:
        return refused({}, 401, "unauthenticated", "no credentials");
      case 1:
        // Refused, or, after ten guesses a minute, throttled.
        refused({BadKey()}, 401, "", "");
        if (!streaming) request.statuses = {401, 429};
        return request;
      case 2:
        // A cookie of no session: without an Origin refused as a possible
        // cross-site request, with one as signed out.
        return OneIn(2) ? refused({SessionCookie()}, 403, "permission_denied",
                                  "must carry the Origin header")
                        : refused({SessionCookie(), "Origin: http://" + host_},
                                  401, "unauthenticated", "");
      default:
        break;
    }
    request.authenticated = true;
    std::string json = "{}";
    const std::string& name = method.full_name;
    if (name == "/hdrstereo.v1.Sessions/Create") {
      json = absl::StrCat(R"({"name": "load-)", tag_, "-", sessions_++,
                          R"(", "note": )", JsonString(Text(Length(200))), "}");
    } else if (name == "/hdrstereo.v1.Jobs/SubmitCapture" && captures_ < 2) {
      // A few real captures run while the flood goes on.
      ++captures_;
      json = R"({"session": "load", "plan": {"bracketedStereo": )"
             R"({"exposuresS": [0.01], "skipAmbient": true}}})";
    } else if (absl::StrContains(name, "/hdrstereo.v1.Jobs/") &&
               (name != "/hdrstereo.v1.Jobs/Pause") && OneIn(2)) {
      json = absl::StrCat(R"({"jobId": ")", Below(5), R"("})");
    } else if (OneIn(3)) {
      json = ObjectOf(method.descriptor->input_type(), 0, true);
    }
    if (!streaming) {
      request.bytes = Call(method, json, {Bearer()});
      return request;
    }
    request.bytes = Call(method, json, StreamHeaders());
    request.half_close = false;
    request.stream_end = true;
    return request;
  }

  HostileRequest Auth() {
    HostileRequest request("auth");
    const std::string json_type = "Content-Type: application/json";
    switch (Below(7)) {
      case 0:
        request.bytes = Request("POST", "/auth/sign-in", {json_type},
                                absl::StrCat(R"({"apiKey": ")", key_, R"("})"));
        // Signed in: the operator's address guessed no keys.
        request.statuses = {200};
        break;
      case 1:
        request.bytes = Request(
            "POST", "/auth/sign-in", {json_type},
            Pick(std::vector<std::string>{
                absl::StrCat(R"({"apiKey": ")", Text(Length(100)), R"("})"),
                AnyJson(0), Bytes(Length(5000)),
                absl::StrCat(R"({"apiKey": ")", key_.substr(0, key_.size() - 1),
                             "x\"}")}));
        request.statuses = {400, 401, 429};
        break;
      case 2:
        request.bytes =
            Request("POST", "/auth/sign-in",
                    {Pick(std::vector<std::string>{
                        "Content-Type: application/x-www-form-urlencoded",
                        "Content-Type: text/plain", "X-None: 1"})},
                    absl::StrCat("apiKey=", key_));
        request.statuses = {400, 429};
        break;
      case 3: {
        const std::string method =
            Pick(std::vector<std::string>{"GET", "PUT", "DELETE", "HEAD"});
        request.head = method == "HEAD";
        request.bytes = Request(
            method,
            Pick(std::vector<std::string>{"/auth/sign-in", "/auth/sign-out"}),
            {}, "");
        request.statuses = {405};
        request.code = "invalid_argument";
        request.message_part = "use POST";
        break;
      }
      case 4:
        request.bytes = Request("POST", "/auth/sign-out", {}, "");
        request.statuses = {400};
        request.code = "failed_precondition";
        request.message_part = "no browser session to end";
        break;
      case 5:
        request.bytes =
            Request("POST", "/auth/sign-out", {SessionCookie()}, "");
        request.statuses = {403};
        request.code = "permission_denied";
        request.message_part = "must carry the Origin header";
        break;
      default:
        request.bytes =
            Request("POST", "/auth/sign-out",
                    {SessionCookie(), "Origin: http://" + host_}, "");
        request.statuses = {400};
        request.message_part = "no browser session to end";
        break;
    }
    return request;
  }

  HostileRequest Files() {
    HostileRequest request("files");
    const std::string kind = OneIn(2) ? "frames" : "artifacts";
    const bool well_formed = !OneIn(3);
    // The session with the captures, or one that does not exist.
    const std::string session =
        OneIn(2) ? "load"
                 : Pick(std::vector<std::string>{Token(8), "..", ".", "%2e%2e",
                                                 "load%00"});
    const std::string path =
        well_formed ? absl::StrCat("/files/sessions/", session, "/", kind, "/",
                                   1 + Below(6))
                    : Pick(std::vector<std::string>{
                          "/files/", "/files/sessions/load/frames/0",
                          "/files/sessions/load/frames/-1",
                          "/files/sessions/load/frames/99999999999999999999",
                          "/files/sessions/a/b/c/d/e",
                          "/files/sessions/load/" + kind + "/1x",
                          "/files/" + Token(Length(300))});
    std::string method = Pick(std::vector<std::string>{"GET", "GET", "HEAD"});
    const bool other_method = OneIn(8);
    if (other_method) method = Pick(std::vector<std::string>{"POST", "PUT"});
    request.head = method == "HEAD";
    std::vector<std::string> headers;
    const bool keyed = !OneIn(4);
    if (keyed) headers.push_back(Bearer());
    if (OneIn(2)) {
      headers.push_back(
          "Range: " +
          Pick(std::vector<std::string>{
              "bytes=0-10", "bytes=-5", "bytes=5-1",
              "bytes=99999999999999999999-", "bytes=0-0,2-3", "items=1-2",
              "bytes=1000000-", "bytes=" + Text(Length(30))}));
    }
    if (OneIn(4)) headers.push_back("If-Range: \"" + Token(64) + "\"");
    if (OneIn(4)) headers.push_back("If-None-Match: \"" + Token(64) + "\"");
    request.bytes = Request(method, path, headers, "");
    if (other_method) {
      request.statuses = {405};
      request.message_part = "use GET, HEAD";
    } else if (!well_formed) {
      request.statuses = {404};
      request.code = "not_found";
      request.message_part = "no such file";
    } else if (!keyed) {
      request.statuses = {401};
      request.code = "unauthenticated";
    } else {
      request.authenticated = true;
      if (session != "load") request.statuses = {400, 404};
    }
    return request;
  }

  HostileRequest Unknown() {
    HostileRequest request("unknown");
    const std::string verb = Pick(std::vector<std::string>{
        "GET", "POST", "PUT", "DELETE", "PATCH", "OPTIONS"});
    std::vector<std::string> headers;
    if (OneIn(2)) headers.push_back(Bearer());
    switch (Below(3)) {
      case 0: {
        static constexpr char kChars[] =
            "abcdefghijklmnopqrstuvwxyz0123456789-._~%/";
        std::string path = "/x";
        for (size_t i = 0, n = Length(300); i < n; ++i) {
          path += kChars[Below(sizeof(kChars) - 1)];
        }
        if (OneIn(4)) absl::StrAppend(&path, "?", Token(Length(40)));
        request.bytes = Request(verb, path, headers, "");
        request.statuses = {404};
        request.code = "not_found";
        request.message_part = "no such page";
        break;
      }
      case 1: {
        // A real service, a method it does not have (or another package).
        const std::string path = Pick(std::vector<std::string>{
            "/hdrstereo.v1.Jobs/" + Token(1 + Length(40)),
            "/hdrstereo.v1." + Token(1 + Length(20)) + "/GetInfo",
            "/hdrstereo.v1.Server/getInfo"});
        headers.push_back("Content-Type: application/json");
        request.bytes = Request(verb, path, headers, "{}");
        if (verb == "POST") {
          request.statuses = {501};
          request.code = "unimplemented";
          request.message_part = "hdrstereod serves no method";
        } else {
          request.statuses = {405};
          request.message_part = "use POST";
        }
        break;
      }
      default:
        request.bytes =
            Request(verb,
                    Pick(std::vector<std::string>{
                        "/hdrstereo.v1.Jobs", "/hdrstereo.v1.Jobs/",
                        "/hdrstereo.v1./Watch", "/hdrstereo.v2.Jobs/Watch",
                        "/hdrstereo.v1.Jobs/Watch/x"}),
                    headers, "");
        request.statuses = {404};
        request.message_part = "no such page";
        break;
    }
    return request;
  }

  HostileRequest Pipelined() {
    HostileRequest request("pipelined");
    const std::string get_info =
        Request("POST", "/hdrstereo.v1.Server/GetInfo",
                {Bearer(), "Content-Type: application/json"}, "{}");
    request.authenticated = true;
    switch (Below(4)) {
      case 0:
        request.bytes = get_info + get_info + get_info;
        request.statuses = {200};
        request.answers = 3;
        break;
      case 1:
        // An answer, then the garbage after it is refused.
        request.bytes = get_info + Bytes(1 + Length(1000));
        request.statuses = {200};
        break;
      case 2:
        request.bytes = absl::StrCat(
            "POST /hdrstereo.v1.Server/WhoAmI HTTP/1.0\r\nHost: ", host_,
            "\r\n", Bearer(),
            "\r\nContent-Type: application/json\r\nContent-Length: "
            "2\r\n\r\n{}");
        request.statuses = {200};
        break;
      default:
        request.bytes = absl::StrCat(
            "POST /hdrstereo.v1.Server/WhoAmI HTTP/1.1\r\nHost: ", host_,
            "\r\n", Bearer(),
            "\r\nContent-Type: application/json\r\nExpect: 100-continue\r\n"
            "Content-Length: 2\r\n\r\n{}");
        request.statuses = {200};
        break;
    }
    return request;
  }

  std::mt19937 random_;
  const std::string host_;
  const std::string key_;
  const std::string tag_;
  std::vector<ProtoMethod> methods_;
  std::vector<ProtoMethod> unary_;
  std::vector<ProtoMethod> streams_;
  int sessions_ = 0;
  int captures_ = 0;
};

// ----- a run of hostile requests -----

struct FloodResult {
  int requests = 0;
  int answered = 0;
  int closed_unanswered = 0;
  int reset = 0;
  int failures = 0;
  // "category: why" -> how many, and the first one: what was sent and got.
  std::map<std::string, std::pair<int, std::string>> failure_kinds;
  // category -> status (0: no answer) -> count
  std::map<std::string, std::map<int, int>> statuses;
  // What valid calls created, from their answers.
  std::set<std::string> sessions;
  std::set<int64_t> jobs;
  std::set<std::string> schedules;
  // Calls that could have created something but whose answer was lost.
  std::vector<std::string> unknown_outcomes;

  // A failure of kind `why`; `detail` goes with the first example only.
  void Fail(const HostileRequest& request, const std::string& why,
            absl::string_view received, absl::string_view detail = "") {
    ++failures;
    auto& [count, example] =
        failure_kinds[absl::StrCat(request.category, ": ", why)];
    if (count++ > 0) return;
    example = absl::StrCat(
        detail.empty() ? "" : "  ", detail, detail.empty() ? "" : "\n",
        "  sent: ", absl::CHexEscape(request.bytes.substr(0, 300)),
        request.bytes.size() > 300 ? "..." : "",
        "\n  got: ", absl::CHexEscape(received.substr(0, 600)));
  }

  std::string DescribeFailures() const {
    std::string text;
    for (const auto& [kind, failed] : failure_kinds) {
      absl::StrAppend(&text, kind, " (x", failed.first, "), the first:\n",
                      failed.second, "\n");
    }
    return text;
  }

  void Merge(FloodResult&& other) {
    requests += other.requests;
    answered += other.answered;
    closed_unanswered += other.closed_unanswered;
    reset += other.reset;
    failures += other.failures;
    for (auto& [kind, failed] : other.failure_kinds) {
      auto& [count, example] = failure_kinds[kind];
      if (count == 0) example = std::move(failed.second);
      count += failed.first;
    }
    for (const auto& [category, counts] : other.statuses) {
      for (const auto& [status, count] : counts) {
        statuses[category][status] += count;
      }
    }
    sessions.merge(other.sessions);
    jobs.merge(other.jobs);
    schedules.merge(other.schedules);
    unknown_outcomes.insert(unknown_outcomes.end(),
                            other.unknown_outcomes.begin(),
                            other.unknown_outcomes.end());
  }
};

// The answer of a creating call, as JSON whatever its codec.
nlohmann::json CreatedJson(const HostileRequest& request,
                           const Answer& answer) {
  if (answer.content_type != "application/proto") {
    return nlohmann::json::parse(answer.body, nullptr, false);
  }
  const protobuf::MethodDescriptor* method =
      protobuf::DescriptorPool::generated_pool()->FindMethodByName(
          absl::StrReplaceAll(request.rpc.substr(1), {{"/", "."}}));
  if (method == nullptr) return nlohmann::json();
  std::unique_ptr<protobuf::Message> message(
      protobuf::MessageFactory::generated_factory()
          ->GetPrototype(method->output_type())
          ->New());
  std::string json;
  if (!message->ParseFromString(answer.body) ||
      !protobuf::util::MessageToJsonString(*message, &json).ok()) {
    return nlohmann::json();
  }
  return nlohmann::json::parse(json, nullptr, false);
}

// Notes what a successful call made: a session, jobs, a schedule.
void NoteCreated(const HostileRequest& request, const Answer& answer,
                 FloodResult& result) {
  const nlohmann::json made = CreatedJson(request, answer);
  if (!made.is_object()) return;
  if (request.rpc == "/hdrstereo.v1.Sessions/Create") {
    result.sessions.insert(made.value("name", ""));
  } else if (request.rpc == "/hdrstereo.v1.Schedules/Create") {
    result.schedules.insert(made.value("name", ""));
  } else if (request.rpc == "/hdrstereo.v1.Jobs/SubmitCapture" ||
             request.rpc == "/hdrstereo.v1.Jobs/SubmitProcessing") {
    result.jobs.insert(JsonInt(made.value("id", nlohmann::json())));
  } else if (request.rpc == "/hdrstereo.v1.Jobs/SubmitProcessingBatch") {
    for (const nlohmann::json& job :
         made.value("jobs", nlohmann::json::array())) {
      if (job.is_object()) {
        result.jobs.insert(JsonInt(job.value("id", nlohmann::json())));
      }
    }
  }
}

bool Creates(const std::string& rpc) {
  return rpc == "/hdrstereo.v1.Sessions/Create" ||
         rpc == "/hdrstereo.v1.Schedules/Create" ||
         absl::StartsWith(rpc, "/hdrstereo.v1.Jobs/Submit");
}

// Sends one request on a connection of its own and checks what comes back.
void Exchange(int port, const std::string& key, const HostileRequest& request,
              FloodResult& result) {
  ++result.requests;
  // The operator's requests (those with the key) and the others come from
  // two addresses: failed guesses at keys throttle the guesser's address.
  RawConnection connection(port, absl::StrContains(request.bytes, key)
                                     ? kOperatorAddress
                                     : kAttackerAddress);
  if (!connection.connected()) {
    return result.Fail(request, absl::StrCat("cannot connect: errno ", errno),
                       "");
  }
  connection.Send(request.bytes);
  if (request.half_close) connection.ShutdownWrite();
  const RawConnection::Received received =
      connection.ReadUntilClosed(kRequestTimeout);
  if (!received.closed) {
    return result.Fail(request,
                       absl::StrCat("still open after ",
                                    absl::FormatDuration(kRequestTimeout)),
                       received.bytes);
  }
  result.reset += received.reset;
  std::vector<Answer> answers = ParseAnswers(received.bytes, {request.head});
  // The first final answer (after any 100 Continue).
  const Answer* first = nullptr;
  int finals = 0;
  for (const Answer& answer : answers) {
    if (answer.malformed) {
      return result.Fail(request, "an answer that is not HTTP", received.bytes);
    }
    if (answer.status >= 200) {
      ++finals;
      if (first == nullptr) first = &answer;
    }
    if (answer.status < 200) continue;
    if (!answer.security_headers) {
      result.Fail(request, "an answer without the security headers",
                  received.bytes);
    }
    if (!answer.complete && answer.status >= 400) {
      return result.Fail(request, "an error cut off", received.bytes);
    }
    // An error's body (an answer to HEAD has none).
    if (answer.status >= 400 && !(request.head && &answer == &answers[0])) {
      const nlohmann::json error =
          nlohmann::json::parse(answer.body, nullptr, false);
      if (answer.content_type != "application/json" || !error.is_object() ||
          !error.value("code", nlohmann::json()).is_string() ||
          !error.value("message", nlohmann::json()).is_string() ||
          !CodeFitsStatus(error.value("code", ""), answer.status)) {
        result.Fail(request, "not a Connect error fitting its status",
                    received.bytes);
      }
    }
  }
  ++result.statuses[request.category][first == nullptr ? 0 : first->status];
  if (first == nullptr) {
    ++result.closed_unanswered;
    if (Creates(request.rpc)) {
      result.unknown_outcomes.push_back(request.rpc);
    }
    if (!request.statuses.empty() && !received.reset &&
        !request.may_go_unanswered) {
      result.Fail(request, "no answer", received.bytes);
    }
    if (request.stream_end) result.Fail(request, "no stream", received.bytes);
    return;
  }
  ++result.answered;
  if (request.no_answer) {
    return result.Fail(request, "an answer to an unfinished request",
                       received.bytes);
  }
  if (finals < request.answers && !received.reset) {
    result.Fail(request, absl::StrCat(finals, " answers of ", request.answers),
                received.bytes);
  }
  if (!request.statuses.empty()) {
    for (const Answer& answer : answers) {
      if (answer.status >= 200 &&
          !absl::c_linear_search(request.statuses, answer.status) &&
          (&answer == first || request.answers > 1)) {
        result.Fail(request,
                    absl::StrCat("status ", answer.status, ", expected ",
                                 absl::StrJoin(request.statuses, " or ")),
                    received.bytes);
      }
    }
  }
  if (request.authenticated && first->status == 401) {
    result.Fail(request, "valid credentials refused", received.bytes);
  }
  if (first->status == 200 && first->complete && Creates(request.rpc)) {
    NoteCreated(request, *first, result);
  } else if (!first->complete && Creates(request.rpc)) {
    result.unknown_outcomes.push_back(request.rpc);
  }
  // The refusal: its code and what it says, in the error body or at the
  // end of the stream.
  nlohmann::json error = nlohmann::json::object();
  if (request.stream_end) {
    const nlohmann::json end = StreamEnd(*first);
    if (first->status != 200 || !first->complete || !end.is_object()) {
      return result.Fail(request, "a stream without its end", received.bytes);
    }
    if (end.contains("error") && end["error"].is_object()) {
      error = end["error"];
    }
  } else if (first->status >= 400 && !request.head) {
    // An object: checked with every answer above.
    error = nlohmann::json::parse(first->body, nullptr, false);
    if (!error.is_object()) return;
  } else if (request.head) {
    return;  // its status was checked; it has no body to say more
  }
  if (!request.code.empty() && error.value("code", "") != request.code) {
    result.Fail(request, "code is not " + request.code, received.bytes);
  }
  if (!request.message_part.empty() &&
      !absl::StrContains(error.value("message", ""), request.message_part)) {
    result.Fail(request, "the message lacks what it should say", received.bytes,
                absl::StrCat("expected: \"", request.message_part, "\""));
  }
}

// `requests` hostile requests from each of kThreads threads at once, the
// thread t's from seed + t.
FloodResult Flood(int port, const std::string& key, uint32_t seed, int requests,
                  const std::string& tag) {
  std::vector<FloodResult> results(kThreads);
  std::vector<std::thread> threads;
  for (int t = 0; t < kThreads; ++t) {
    threads.emplace_back([&, t] {
      HostileRequests generator(seed + static_cast<uint32_t>(t), port, key,
                                absl::StrCat(tag, t));
      for (int i = 0; i < requests / kThreads; ++i) {
        Exchange(port, key, generator.Next(), results[t]);
      }
    });
  }
  for (std::thread& thread : threads) thread.join();
  FloodResult all;
  for (FloodResult& result : results) all.Merge(std::move(result));
  return all;
}

std::string Describe(const FloodResult& result) {
  std::string text =
      absl::StrCat(result.requests, " requests: ", result.answered,
                   " answered, ", result.closed_unanswered,
                   " closed without an answer (", result.reset, " reset)\n");
  for (const auto& [category, counts] : result.statuses) {
    absl::StrAppend(&text, "  ", category, ":");
    for (const auto& [status, count] : counts) {
      absl::StrAppend(&text, " ", status == 0 ? "none" : absl::StrCat(status),
                      " x", count);
    }
    absl::StrAppend(&text, "\n");
  }
  return text;
}

// A list of SQL values as the set of them.
std::set<std::string> SqlSet(const std::string& list) {
  if (list.empty() || list == "<no row>") return {};
  std::vector<std::string> items = absl::StrSplit(list, ',');
  return std::set<std::string>(items.begin(), items.end());
}

// ----- the fixture -----

class HttpLoadTest : public HttpFixture {
 protected:
  // The daemon with simulated devices (the small scene, instant) and the
  // HTTP edge on plain loopback; erin is an operator with an API key.
  void StartPlainHttpDaemon(std::vector<std::string> extra = {}) {
    std::vector<std::string> args = {
        "--http-listen",    "127.0.0.1:0",
        "--auth-user",      "erin=operator",
        "--sim-scene",      WriteScene("lab-lamp", SmallLabLamp()).string(),
        "--sim-time-scale", "0"};
    args.insert(args.end(), extra.begin(), extra.end());
    StartDaemon(args);
    ASSERT_FALSE(http_urls_.empty()) << daemon_log();
    ASSERT_TRUE(absl::SimpleAtoi(
        http_urls_[0].substr(http_urls_[0].rfind(':') + 1), &port_))
        << http_urls_[0];
    CommandResult created =
        Cli({"admin", "key", "create", "--user", "erin", "--role", "operator"});
    ASSERT_EQ(created.exit_code, 0) << created.err;
    key_ = std::string(absl::StripAsciiWhitespace(created.out));
  }

  // A unary call as erin, through libcurl.
  HttpResponse Call(const std::string& method, const std::string& json,
                    absl::Duration timeout = absl::Seconds(10)) {
    HttpRequest request;
    request.url = absl::StrCat(http_urls_[0], "/hdrstereo.v1.", method);
    request.headers = {"Content-Type: application/json",
                       "Authorization: Bearer " + key_};
    request.body = json;
    request.timeout = timeout;
    return Fetch(request);
  }

  // Waits (at most 2 minutes) until no job is queued or running; a job a
  // random request paused is cancelled, so that the rig is free again.
  void SettleJobs() {
    for (int i = 0; i < 600; ++i) {
      if (Sql("SELECT count(*) FROM jobs WHERE state IN "
              "('queued', 'running', 'paused')") == "0") {
        return;
      }
      const std::string paused =
          Sql("SELECT id FROM jobs WHERE state = 'paused' ORDER BY id LIMIT 1");
      if (paused != "<no row>") Cli({"jobs", "cancel", paused});
      absl::SleepFor(absl::Milliseconds(200));
    }
    ADD_FAILURE() << "jobs still busy: "
                  << Sql("SELECT group_concat(id || ' ' || state, ', ') "
                         "FROM jobs");
  }

  // The daemon's resident memory once its queues are empty: no job busy,
  // the audit written (listing the audit log flushes it).
  int64_t SettledRssKb() {
    SettleJobs();
    CommandResult audit = Cli({"audit", "--limit", "1"});
    EXPECT_EQ(audit.exit_code, 0) << audit.err;
    return ResidentKb(daemon_->pid());
  }

  int port_ = 0;
  std::string key_;
};

TEST_F(HttpLoadTest, TenThousandHostileRequestsNeitherCrashHangNorGrowIt) {
  StartPlainHttpDaemon();
  ASSERT_EQ(Cli({"session", "create", "load"}).exit_code, 0);
  std::cout << "seed " << kSeed << " (thread t of the warm-up: seed + t; of "
            << "the run: seed + 100 + t)\n";
  const FloodResult warm_up = Flood(port_, key_, kSeed, kWarmUpRequests, "w");
  std::cout << "warm-up: " << Describe(warm_up);
  const int64_t before = SettledRssKb();
  ASSERT_GT(before, 0);

  const absl::Time start = absl::Now();
  const FloodResult run =
      Flood(port_, key_, kSeed + 100, kHostileRequests, "f");
  const absl::Duration took = absl::Now() - start;
  std::cout << "run: " << Describe(run) << "in " << absl::FormatDuration(took)
            << "\n";
  const int64_t after = SettledRssKb();
  std::cout << "daemon RSS before " << before << " kB, after "
            << kHostileRequests << " hostile requests " << after << " kB\n";

  for (const FloodResult* result : {&warm_up, &run}) {
    EXPECT_EQ(result->failures, 0)
        << result->failures << " requests went wrong:\n"
        << result->DescribeFailures();
  }
  EXPECT_EQ(run.requests, kHostileRequests);
  // Every category was drawn, and the valid calls got through.
  EXPECT_EQ(run.statuses.size(), HostileRequests::KindCount()) << Describe(run);
  const auto valid = run.statuses.find("valid json");
  ASSERT_NE(valid, run.statuses.end());
  EXPECT_GT(valid->second.count(200) ? valid->second.at(200) : 0, 100)
      << Describe(run);
#if defined(__SANITIZE_ADDRESS__)
  // AddressSanitizer keeps freed memory in quarantine, so RSS grows by
  // design; its leak check at the daemon's exit (StopDaemon() == 0 below)
  // stands in for this one.
  std::cout << "built with AddressSanitizer: RSS not compared\n";
#else
  EXPECT_LE(after, before + before / 10)
      << "RSS grew from " << before << " kB to " << after << " kB";
#endif

  // Alive, and a real call is answered as it should be.
  EXPECT_FALSE(daemon_->Wait(absl::ZeroDuration()).has_value());
  HttpResponse whoami = Call("Server/WhoAmI", "{}");
  ASSERT_EQ(whoami.status, 200) << whoami.curl_error << whoami.body;
  EXPECT_EQ(whoami.Json().value("principal", ""), "erin");

  // The store is intact and holds what the valid calls made, nothing else.
  EXPECT_EQ(Sql("PRAGMA integrity_check"), "ok");
  std::set<std::string> sessions = warm_up.sessions;
  sessions.insert(run.sessions.begin(), run.sessions.end());
  sessions.insert("load");
  std::set<std::string> jobs;
  for (const FloodResult* result : {&warm_up, &run}) {
    for (int64_t id : result->jobs) jobs.insert(absl::StrCat(id));
  }
  std::set<std::string> schedules = warm_up.schedules;
  schedules.insert(run.schedules.begin(), run.schedules.end());
  std::vector<std::string> unknown = warm_up.unknown_outcomes;
  unknown.insert(unknown.end(), run.unknown_outcomes.begin(),
                 run.unknown_outcomes.end());
  EXPECT_GT(sessions.size(), 10u);
  EXPECT_GE(jobs.size(), 1u);
  EXPECT_EQ(SqlSet(Sql("SELECT group_concat(name) FROM sessions")), sessions)
      << "calls whose outcome is unknown: " << absl::StrJoin(unknown, ", ");
  EXPECT_EQ(SqlSet(Sql("SELECT group_concat(id) FROM jobs")), jobs)
      << "calls whose outcome is unknown: " << absl::StrJoin(unknown, ", ");
  EXPECT_EQ(SqlSet(Sql("SELECT group_concat(name) FROM schedules")), schedules);
  // Only the local admin made keys and webhooks: erin's key.
  EXPECT_EQ(Sql("SELECT count(*) FROM api_keys"), "1");
  EXPECT_EQ(Sql("SELECT count(*) FROM webhooks"), "0");
  HttpResponse listed =
      Call("Sessions/List", R"({"page": {"pageSize": 1000}})");
  ASSERT_EQ(listed.status, 200) << listed.body;
  EXPECT_EQ(listed.Json().value("sessions", nlohmann::json::array()).size(),
            sessions.size());
  EXPECT_EQ(StopDaemon(), 0) << daemon_log();
}

// The answer to a HEAD request is its header alone, an error's too: on a
// kept-alive connection a body would be read as the next answer's start.
TEST_F(HttpLoadTest, AnswersToHeadAreHeadersAlone) {
  StartPlainHttpDaemon();
  RawConnection connection(port_);
  ASSERT_TRUE(connection.connected());
  const std::string host = absl::StrCat("Host: 127.0.0.1:", port_, "\r\n");
  // 405 (the connection kept), a call on the same connection, then 401.
  ASSERT_TRUE(connection.Send(absl::StrCat(
      "HEAD /auth/sign-in HTTP/1.1\r\n", host, "\r\n",
      "POST /hdrstereo.v1.Server/WhoAmI HTTP/1.1\r\n", host,
      "Authorization: Bearer ", key_,
      "\r\nContent-Type: application/json\r\nContent-Length: 2\r\n\r\n{}",
      "HEAD /files/sessions/none/frames/1 HTTP/1.1\r\n", host, "\r\n")));
  connection.ShutdownWrite();
  const RawConnection::Received received =
      connection.ReadUntilClosed(absl::Seconds(10));
  EXPECT_TRUE(received.closed);
  const std::vector<Answer> answers =
      ParseAnswers(received.bytes, {true, false, true});
  ASSERT_EQ(answers.size(), 3u) << received.bytes;
  for (const Answer& answer : answers) {
    EXPECT_FALSE(answer.malformed) << received.bytes;
    EXPECT_TRUE(answer.complete) << received.bytes;
    EXPECT_TRUE(answer.security_headers) << received.bytes;
  }
  EXPECT_EQ(answers[0].status, 405) << received.bytes;
  EXPECT_EQ(answers[0].body, "");
  EXPECT_EQ(answers[1].status, 200) << received.bytes;
  EXPECT_EQ(nlohmann::json::parse(answers[1].body, nullptr, false)
                .value("principal", ""),
            "erin")
      << received.bytes;
  EXPECT_EQ(answers[2].status, 401) << received.bytes;
  EXPECT_EQ(answers[2].body, "");
  EXPECT_EQ(StopDaemon(), 0) << daemon_log();
}

// A request with Connection: close is answered with Connection: close and
// the daemon closes the connection (RFC 9112, 9.6), not the idle timeout a
// minute later.
TEST_F(HttpLoadTest, ConnectionCloseIsHonoured) {
  StartPlainHttpDaemon();
  RawConnection connection(port_);
  ASSERT_TRUE(connection.connected());
  // The client keeps its side open: only the daemon can end this.
  ASSERT_TRUE(connection.Send(absl::StrCat(
      "POST /hdrstereo.v1.Server/WhoAmI HTTP/1.1\r\nHost: 127.0.0.1:", port_,
      "\r\nAuthorization: Bearer ", key_,
      "\r\nConnection: close\r\nContent-Type: application/json\r\n"
      "Content-Length: 2\r\n\r\n{}")));
  const RawConnection::Received received =
      connection.ReadUntilClosed(absl::Seconds(5));
  EXPECT_TRUE(received.closed) << "still open after 5 s: " << received.bytes;
  const std::vector<Answer> answers = ParseAnswers(received.bytes);
  ASSERT_EQ(answers.size(), 1u) << received.bytes;
  EXPECT_EQ(answers[0].status, 200) << received.bytes;
  EXPECT_EQ(answers[0].connection, "close") << received.bytes;
  EXPECT_EQ(StopDaemon(), 0) << daemon_log();
}

// 200 connections that send nothing or half a request line hold no one
// up: a real client is served while they wait. The daemon closes them, and
// one stalled inside its headers, at the header timeout (10 s from the
// connect), having sent nothing.
TEST_F(HttpLoadTest, IdleAndStalledConnectionsDoNotStopARealClient) {
  StartPlainHttpDaemon();
  const absl::Time opened = absl::Now();
  std::vector<RawConnection> idle;
  for (int i = 0; i < 200; ++i) {
    idle.emplace_back(port_);
    ASSERT_TRUE(idle.back().connected()) << i << ": errno " << errno;
    if (i % 2 == 1) {
      ASSERT_TRUE(idle.back().Send("POST /hdrstereo.v1.Server/GetIn"));
    }
  }
  RawConnection stalled(port_);
  ASSERT_TRUE(stalled.Send(absl::StrCat(
      "POST /hdrstereo.v1.Server/WhoAmI HTTP/1.1\r\nHost: 127.0.0.1:", port_,
      "\r\nAuthorization: Bearer ", key_, "\r\nContent-Ty")));

  // Each call is bounded by its own timeout: 5 s is not prompt, but it
  // would be a failure, not a hang.
  absl::Duration slowest;
  for (int i = 0; i < 20; ++i) {
    const absl::Time start = absl::Now();
    HttpResponse whoami = Call("Server/WhoAmI", "{}", absl::Seconds(5));
    slowest = std::max(slowest, absl::Now() - start);
    ASSERT_EQ(whoami.status, 200)
        << i << ": " << whoami.curl_error << whoami.body;
    EXPECT_EQ(whoami.Json().value("principal", ""), "erin");
  }
  std::cout << "20 calls beside 200 idle connections, the slowest in "
            << absl::FormatDuration(slowest) << "\n";

  const absl::Time limit = opened + absl::Seconds(14);
  const RawConnection::Received stall =
      stalled.ReadUntilClosed(limit - absl::Now());
  const absl::Duration held = absl::Now() - opened;
  EXPECT_TRUE(stall.closed)
      << "still open after " << absl::FormatDuration(held);
  EXPECT_EQ(stall.bytes, "");
  EXPECT_GE(held, absl::Seconds(9)) << "closed before the header timeout";
  std::cout << "the stalled connection was closed after "
            << absl::FormatDuration(held) << "\n";
  int closed = 0;
  for (RawConnection& connection : idle) {
    const RawConnection::Received received =
        connection.ReadUntilClosed(limit - absl::Now());
    closed += received.closed && received.bytes.empty();
  }
  EXPECT_EQ(closed, 200);
  HttpResponse after = Call("Server/WhoAmI", "{}");
  EXPECT_EQ(after.status, 200) << after.curl_error << after.body;
  EXPECT_EQ(StopDaemon(), 0) << daemon_log();
}

// With --http-max-connections 20 and 20 connections open, the 21st to 25th
// get a 503 saying so and are closed; the 20 are still served, and once
// their clients close them, new clients are served again.
TEST_F(HttpLoadTest, BeyondItsConnectionBoundTheEdgeRefusesClearly) {
  StartPlainHttpDaemon({"--http-max-connections", "20"});
  std::vector<RawConnection> held;
  for (int i = 0; i < 20; ++i) {
    held.emplace_back(port_);
    ASSERT_TRUE(held.back().connected()) << i;
  }
  // The daemon accepts connections in order: these are beyond the bound.
  for (int i = 21; i <= 25; ++i) {
    RawConnection extra(port_);
    ASSERT_TRUE(extra.connected()) << i;
    const RawConnection::Received received =
        extra.ReadUntilClosed(absl::Seconds(10));
    EXPECT_TRUE(received.closed) << i;
    const std::vector<Answer> answers = ParseAnswers(received.bytes);
    ASSERT_EQ(answers.size(), 1u) << i << ": " << received.bytes;
    EXPECT_EQ(answers[0].status, 503) << received.bytes;
    EXPECT_TRUE(answers[0].complete);
    EXPECT_TRUE(answers[0].security_headers);
    EXPECT_EQ(answers[0].content_type, "application/json");
    EXPECT_EQ(answers[0].connection, "close");
    const nlohmann::json error =
        nlohmann::json::parse(answers[0].body, nullptr, false);
    EXPECT_EQ(error.value("code", ""), "unavailable") << answers[0].body;
    EXPECT_EQ(error.value("message", ""),
              "hdrstereod serves at most 20 HTTP connections at once; try "
              "again shortly");
  }

  // A held connection is served when it speaks.
  ASSERT_TRUE(held[0].Send(absl::StrCat(
      "POST /hdrstereo.v1.Server/WhoAmI HTTP/1.1\r\nHost: 127.0.0.1:", port_,
      "\r\nAuthorization: Bearer ", key_,
      "\r\nContent-Type: application/json\r\nContent-Length: 2\r\n\r\n{}")));
  held[0].ShutdownWrite();
  const RawConnection::Received whoami =
      held[0].ReadUntilClosed(absl::Seconds(10));
  const std::vector<Answer> answers = ParseAnswers(whoami.bytes);
  ASSERT_EQ(answers.size(), 1u) << whoami.bytes;
  EXPECT_EQ(answers[0].status, 200) << whoami.bytes;
  EXPECT_EQ(nlohmann::json::parse(answers[0].body, nullptr, false)
                .value("principal", ""),
            "erin");

  // The clients close theirs; the daemon notices within moments.
  for (RawConnection& connection : held) connection.Close();
  HttpResponse served;
  for (int attempt = 0; attempt < 50 && served.status != 200; ++attempt) {
    if (attempt > 0) absl::SleepFor(absl::Milliseconds(100));
    served = Call("Server/WhoAmI", "{}");
  }
  EXPECT_EQ(served.status, 200) << served.curl_error << served.body;
  // Ten clients at once, within the bound, are all served.
  std::vector<HttpResponse> responses(10);
  std::vector<std::thread> threads;
  for (int i = 0; i < 10; ++i) {
    threads.emplace_back(
        [this, &responses, i] { responses[i] = Call("Server/GetInfo", "{}"); });
  }
  for (std::thread& thread : threads) thread.join();
  for (const HttpResponse& response : responses) {
    EXPECT_EQ(response.status, 200) << response.curl_error << response.body;
  }
  EXPECT_EQ(StopDaemon(), 0) << daemon_log();
}

// 50 browsers' worth of watchers on one capture, each its own TLS
// connection and Connect stream of Jobs/Watch (bob's client certificate,
// alice's key, a browser session of alice's): every one sees every event
// of the capture in order, the very events a gRPC watcher gets, and the
// capture succeeds. The HTTP twin of AHundredTlsClientsWatchOneCapture
// (tests/integration/remote_robustness_test.cc); the overhead is measured by
// tests/bench/capture_overhead.sh --http-watchers (docs/benchmarks.md).
TEST_F(HttpLoadTest, FiftyHttpWatchersFollowOneCapture) {
  StartHttpDaemon({"--sim-time-scale", "0.2"});
  const std::string id =
      SubmitStereoCapture("many", "[0.033333, 0.016667, 0.008]");
  ASSERT_FALSE(id.empty());

  const std::string key = CreateKey("alice", "viewer");
  HttpRequest sign_in = To("/auth/sign-in");
  sign_in.headers = {"Content-Type: application/json", "Origin: " + base_};
  sign_in.body = absl::StrCat(R"({"apiKey": ")", key, R"("})");
  HttpResponse signed_in = Fetch(sign_in);
  ASSERT_EQ(signed_in.status, 200) << signed_in.body;
  const std::string set_cookie = signed_in.Header("set-cookie");
  const std::string cookie =
      "Cookie: " + set_cookie.substr(0, set_cookie.find(';'));

  constexpr int kWatchers = 50;
  std::vector<HttpResponse> responses(kWatchers);
  std::vector<std::thread> threads;
  for (int i = 0; i < kWatchers; ++i) {
    HttpRequest watch = To("/hdrstereo.v1.Jobs/Watch", i % 3 == 0 ? "bob" : "");
    watch.headers = {"Content-Type: application/connect+json"};
    if (i % 3 == 1) watch.headers.push_back("Authorization: Bearer " + key);
    if (i % 3 == 2) {
      watch.headers.push_back(cookie);
      watch.headers.push_back("Origin: " + base_);
    }
    watch.body = EnvelopeOf(absl::StrCat(R"({"jobId": ")", id, R"("})"));
    watch.timeout = absl::Seconds(180);
    threads.emplace_back(
        [&responses, i, watch] { responses[i] = Fetch(watch); });
  }
  // And one over gRPC.
  std::vector<v1::JobEvent> over_grpc;
  grpc::Status grpc_status;
  threads.emplace_back([&, channel = TlsChannel("alice")] {
    grpc::ClientContext context;
    context.set_deadline(std::chrono::system_clock::now() +
                         std::chrono::seconds(180));
    context.set_wait_for_ready(true);
    v1::WatchJobRequest request;
    request.set_job_id(std::stoll(id));
    auto reader = v1::Jobs::NewStub(channel)->Watch(&context, request);
    v1::JobEvent event;
    while (reader->Read(&event)) over_grpc.push_back(event);
    grpc_status = reader->Finish();
  });
  for (std::thread& thread : threads) thread.join();

  ASSERT_TRUE(grpc_status.ok()) << grpc_status.error_message();
  ASSERT_FALSE(over_grpc.empty());
  EXPECT_EQ(over_grpc.back().state(), v1::JOB_STATE_SUCCEEDED);
  EXPECT_EQ(
      Sql(absl::StrCat("SELECT count(*) FROM job_events WHERE job_id = ", id)),
      absl::StrCat(over_grpc.size()));
  for (size_t k = 0; k < over_grpc.size(); ++k) {
    ASSERT_EQ(over_grpc[k].sequence(), static_cast<int64_t>(k + 1));
  }
  for (int i = 0; i < kWatchers; ++i) {
    ASSERT_EQ(responses[i].status, 200)
        << i << ": " << responses[i].curl_error << responses[i].body;
    const std::vector<StreamMessage> messages =
        ParseEnvelopes(responses[i].body);
    ASSERT_FALSE(messages.empty()) << i;
    ASSERT_TRUE(messages.back().end) << i;
    EXPECT_EQ(messages.back().payload, "{}") << i;
    ASSERT_EQ(messages.size(), over_grpc.size() + 1) << i;
    for (size_t k = 0; k < over_grpc.size(); ++k) {
      v1::JobEvent event;
      ASSERT_TRUE(
          protobuf::util::JsonStringToMessage(messages[k].payload, &event).ok())
          << messages[k].payload;
      EXPECT_TRUE(
          protobuf::util::MessageDifferencer::Equals(event, over_grpc[k]))
          << "watcher " << i << ", event " << k << ": " << messages[k].payload
          << " vs " << over_grpc[k].ShortDebugString();
    }
  }
  // The capture's own account of its overhead.
  std::cout << Sql(absl::StrCat(
                   "SELECT message FROM job_events WHERE job_id = ", id,
                   " AND message LIKE '%in the daemon%'"))
            << "\n";
  EXPECT_EQ(StopDaemon(), 0) << daemon_log();
}

}  // namespace
}  // namespace hdrstereo::testing
