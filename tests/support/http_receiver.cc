// SPDX-License-Identifier: GPL-3.0-or-later
#include "tests/support/http_receiver.h"

#include <civetweb.h>
#include <gtest/gtest.h>
#include <openssl/evp.h>
#include <openssl/hmac.h>

#include <chrono>

#include "absl/strings/ascii.h"
#include "absl/strings/escaping.h"
#include "absl/strings/str_cat.h"
#include "absl/time/clock.h"

namespace hdrstereo::testing {

std::string ExpectedSignature(const std::string& secret,
                              const std::string& body) {
  unsigned char mac[EVP_MAX_MD_SIZE];
  unsigned int length = 0;
  HMAC(EVP_sha256(), secret.data(), static_cast<int>(secret.size()),
       reinterpret_cast<const unsigned char*>(body.data()), body.size(), mac,
       &length);
  return "sha256=" + absl::BytesToHexString(absl::string_view(
                         reinterpret_cast<const char*>(mac), length));
}

HttpReceiver::HttpReceiver() {
  mg_init_library(0);
  const char* options[] = {"listening_ports", "127.0.0.1:0", "num_threads", "8",
                           nullptr};
  mg_callbacks callbacks{};
  context_ = mg_start(&callbacks, this, options);
  if (context_ == nullptr) {
    ADD_FAILURE() << "civetweb cannot serve on 127.0.0.1";
    return;
  }
  mg_set_request_handler(context_, "/", &HttpReceiver::Handle, this);
  mg_server_port ports[1] = {};
  if (mg_get_server_ports(context_, 1, ports) != 1) {
    ADD_FAILURE() << "civetweb has no port";
    return;
  }
  port_ = ports[0].port;
}

HttpReceiver::~HttpReceiver() {
  Release();
  if (context_ != nullptr) mg_stop(context_);
  mg_exit_library();
}

std::string HttpReceiver::Url(const std::string& path) const {
  return absl::StrCat("http://127.0.0.1:", port_, path);
}

void HttpReceiver::RespondWith(std::vector<int> statuses) {
  std::lock_guard<std::mutex> lock(mutex_);
  statuses_.assign(statuses.begin(), statuses.end());
}

void HttpReceiver::Hang() {
  std::lock_guard<std::mutex> lock(mutex_);
  hang_ = true;
}

void HttpReceiver::Release() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    hang_ = false;
  }
  changed_.notify_all();
}

std::vector<ReceivedRequest> HttpReceiver::requests() {
  std::lock_guard<std::mutex> lock(mutex_);
  return requests_;
}

int HttpReceiver::held() {
  std::lock_guard<std::mutex> lock(mutex_);
  return held_;
}

bool HttpReceiver::WaitFor(size_t count, absl::Duration timeout,
                           bool count_held) {
  std::unique_lock<std::mutex> lock(mutex_);
  return changed_.wait_for(lock, absl::ToChronoNanoseconds(timeout), [&] {
    return requests_.size() + (count_held ? held_ : 0) >= count;
  });
}

int HttpReceiver::Handle(mg_connection* connection, void* self_pointer) {
  auto* self = static_cast<HttpReceiver*>(self_pointer);
  const mg_request_info* info = mg_get_request_info(connection);
  ReceivedRequest request;
  request.method = info->request_method;
  request.path = info->local_uri;
  for (int i = 0; i < info->num_headers; ++i) {
    request.headers[absl::AsciiStrToLower(info->http_headers[i].name)] =
        info->http_headers[i].value;
  }
  char buffer[4096];
  for (int n; (n = mg_read(connection, buffer, sizeof(buffer))) > 0;) {
    request.body.append(buffer, n);
  }
  {
    std::unique_lock<std::mutex> lock(self->mutex_);
    if (self->hang_) {
      ++self->held_;
      self->changed_.notify_all();
      self->changed_.wait_for(lock, std::chrono::seconds(120),
                              [self] { return !self->hang_; });
      --self->held_;
    }
    request.status = 200;
    if (!self->statuses_.empty()) {
      request.status = self->statuses_.front();
      self->statuses_.pop_front();
    }
    self->requests_.push_back(request);
  }
  self->changed_.notify_all();
  mg_printf(connection,
            "HTTP/1.1 %d Scripted\r\nContent-Type: text/plain\r\n"
            "Content-Length: 8\r\nConnection: close\r\n\r\nscripted",
            request.status);
  return request.status;
}

}  // namespace hdrstereo::testing
