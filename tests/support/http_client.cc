// SPDX-License-Identifier: GPL-3.0-or-later
#include "tests/support/http_client.h"

#include <curl/curl.h>
#include <gtest/gtest.h>
#include <sys/socket.h>

#include <memory>

#include "absl/strings/ascii.h"
#include "absl/strings/strip.h"

namespace hdrstereo::testing {
namespace {

struct BodySink {
  std::string* body;
  const std::function<bool(const std::string&)>* on_body;
};

size_t OnBody(char* data, size_t size, size_t count, void* user) {
  auto* sink = static_cast<BodySink*>(user);
  if (*sink->on_body == nullptr) {
    sink->body->append(data, size * count);
    return size * count;
  }
  // A short count ends the transfer.
  return (*sink->on_body)(std::string(data, size * count)) ? size * count : 0;
}

int SetReceiveBuffer(void* bytes, curl_socket_t socket, curlsocktype) {
  const int size = *static_cast<int*>(bytes);
  setsockopt(socket, SOL_SOCKET, SO_RCVBUF, &size, sizeof(size));
  return CURL_SOCKOPT_OK;
}

size_t OnHeader(char* data, size_t size, size_t count, void* user) {
  auto* headers = static_cast<std::multimap<std::string, std::string>*>(user);
  const std::string line(data, size * count);
  const size_t colon = line.find(':');
  if (colon == std::string::npos) {
    // A status line: a new response (after 100 Continue) starts afresh.
    if (line.rfind("HTTP/", 0) == 0) headers->clear();
    return size * count;
  }
  headers->emplace(absl::AsciiStrToLower(line.substr(0, colon)),
                   std::string(absl::StripAsciiWhitespace(
                       absl::string_view(line).substr(colon + 1))));
  return size * count;
}

}  // namespace

std::string HttpResponse::Header(const std::string& name) const {
  auto it = headers.find(name);
  return it == headers.end() ? "" : it->second;
}

nlohmann::json HttpResponse::Json() const {
  return nlohmann::json::parse(body, nullptr, false);
}

HttpResponse Fetch(const HttpRequest& request) {
  HttpResponse response;
  std::unique_ptr<CURL, decltype(&curl_easy_cleanup)> curl(curl_easy_init(),
                                                           curl_easy_cleanup);
  if (curl == nullptr) {
    response.curl_error = "curl_easy_init failed";
    return response;
  }
  CURL* c = curl.get();
  curl_easy_setopt(c, CURLOPT_URL, request.url.c_str());
  if (request.path_as_is) curl_easy_setopt(c, CURLOPT_PATH_AS_IS, 1L);
  curl_easy_setopt(c, CURLOPT_CUSTOMREQUEST, request.method.c_str());
  if (request.method == "HEAD") curl_easy_setopt(c, CURLOPT_NOBODY, 1L);
  if (request.method == "POST" || !request.body.empty()) {
    curl_easy_setopt(c, CURLOPT_POSTFIELDS, request.body.data());
    curl_easy_setopt(c, CURLOPT_POSTFIELDSIZE_LARGE,
                     static_cast<curl_off_t>(request.body.size()));
  }
  struct curl_slist* headers = nullptr;
  for (const std::string& header : request.headers) {
    headers = curl_slist_append(headers, header.c_str());
  }
  curl_easy_setopt(c, CURLOPT_HTTPHEADER, headers);
  curl_easy_setopt(
      c, CURLOPT_TIMEOUT_MS,
      static_cast<long>(absl::ToInt64Milliseconds(request.timeout)));
  curl_easy_setopt(c, CURLOPT_NOSIGNAL, 1L);
  if (!request.ca.empty()) {
    curl_easy_setopt(c, CURLOPT_CAINFO, request.ca.c_str());
  }
  if (!request.cert.empty()) {
    curl_easy_setopt(c, CURLOPT_SSLCERT, request.cert.c_str());
    curl_easy_setopt(c, CURLOPT_SSLKEY, request.key.c_str());
  }
  BodySink sink{&response.body, &request.on_body};
  curl_easy_setopt(c, CURLOPT_WRITEFUNCTION, OnBody);
  curl_easy_setopt(c, CURLOPT_WRITEDATA, &sink);
  int receive_buffer = request.receive_buffer_bytes;
  if (receive_buffer > 0) {
    curl_easy_setopt(c, CURLOPT_SOCKOPTFUNCTION, SetReceiveBuffer);
    curl_easy_setopt(c, CURLOPT_SOCKOPTDATA, &receive_buffer);
  }
  curl_easy_setopt(c, CURLOPT_HEADERFUNCTION, OnHeader);
  curl_easy_setopt(c, CURLOPT_HEADERDATA, &response.headers);
  const CURLcode code = curl_easy_perform(c);
  curl_slist_free_all(headers);
  if (code != CURLE_OK) response.curl_error = curl_easy_strerror(code);
  curl_easy_getinfo(c, CURLINFO_RESPONSE_CODE, &response.status);
  return response;
}

std::optional<StreamMessage> TakeEnvelope(std::string& buffered) {
  if (buffered.size() < 5) return std::nullopt;
  const auto flags = static_cast<uint8_t>(buffered[0]);
  uint32_t size = 0;
  for (int i = 1; i <= 4; ++i) {
    size = (size << 8) | static_cast<uint8_t>(buffered[i]);
  }
  if (buffered.size() - 5 < size) return std::nullopt;
  StreamMessage message{(flags & 0x02) != 0, buffered.substr(5, size)};
  buffered.erase(0, 5 + size);
  return message;
}

std::vector<StreamMessage> ParseEnvelopes(const std::string& body) {
  std::vector<StreamMessage> messages;
  std::string rest = body;
  while (std::optional<StreamMessage> message = TakeEnvelope(rest)) {
    messages.push_back(std::move(*message));
  }
  if (!rest.empty()) {
    ADD_FAILURE() << "a stream ends inside an envelope at byte "
                  << body.size() - rest.size() << " (" << rest.size()
                  << " bytes left over)";
  }
  return messages;
}

std::string EnvelopeOf(const std::string& payload) {
  std::string envelope(5, '\0');
  const auto size = static_cast<uint32_t>(payload.size());
  for (int i = 0; i < 4; ++i) {
    envelope[1 + i] = static_cast<char>((size >> (24 - 8 * i)) & 0xff);
  }
  return envelope + payload;
}

}  // namespace hdrstereo::testing
