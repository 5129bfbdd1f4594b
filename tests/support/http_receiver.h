// SPDX-License-Identifier: GPL-3.0-or-later
//
// A webhook receiver for tests: civetweb serving on 127.0.0.1 at a port the
// kernel picks, recording every request, answering with scripted statuses,
// and able to hold requests unanswered (a receiver that hangs).
#ifndef HDRSTEREO_TESTS_SUPPORT_HTTP_RECEIVER_H_
#define HDRSTEREO_TESTS_SUPPORT_HTTP_RECEIVER_H_

#include <condition_variable>
#include <deque>
#include <map>
#include <mutex>
#include <string>
#include <vector>

#include "absl/time/time.h"

struct mg_connection;
struct mg_context;

namespace hdrstereo::testing {

struct ReceivedRequest {
  std::string method;
  std::string path;
  std::map<std::string, std::string> headers;  // names in lowercase
  std::string body;
  int status = 0;  // what it was answered with
};

// What a receiver expects in X-Hdrstereo-Signature: "sha256=" + hex
// HMAC-SHA256(secret, body), computed with OpenSSL here, independently of
// the daemon's code.
std::string ExpectedSignature(const std::string& secret,
                              const std::string& body);

class HttpReceiver {
 public:
  HttpReceiver();  // a test failure when it cannot serve
  ~HttpReceiver();
  HttpReceiver(const HttpReceiver&) = delete;
  HttpReceiver& operator=(const HttpReceiver&) = delete;

  int port() const { return port_; }
  std::string Url(const std::string& path = "/hook") const;

  // The next requests are answered with these statuses, later ones 200.
  void RespondWith(std::vector<int> statuses);
  // Requests from now on wait, unanswered, until Release() (at most 120 s).
  void Hang();
  void Release();

  std::vector<ReceivedRequest> requests();
  // Requests waiting in Hang().
  int held();
  // Waits until at least `count` requests were answered (or held, when
  // `count_held`); false after `timeout`.
  bool WaitFor(size_t count, absl::Duration timeout, bool count_held = false);

 private:
  static int Handle(mg_connection* connection, void* self);

  mg_context* context_ = nullptr;
  int port_ = 0;
  std::mutex mutex_;
  std::condition_variable changed_;
  std::deque<int> statuses_;
  bool hang_ = false;
  int held_ = 0;
  std::vector<ReceivedRequest> requests_;
};

}  // namespace hdrstereo::testing

#endif  // HDRSTEREO_TESTS_SUPPORT_HTTP_RECEIVER_H_
