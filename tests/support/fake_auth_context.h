// SPDX-License-Identifier: GPL-3.0-or-later
//
// A grpc::AuthContext holding the properties gRPC's transports set on a
// connection: transport_security_type "tls" (gRPC's TLS credentials, which
// the daemon uses; "ssl" from its SSL credentials) with the x509_* of a
// verified client certificate, or "local". For unit tests and benches of
// CallGuard that need no network.
#ifndef HDRSTEREO_TESTS_SUPPORT_FAKE_AUTH_CONTEXT_H_
#define HDRSTEREO_TESTS_SUPPORT_FAKE_AUTH_CONTEXT_H_

#include <grpcpp/security/auth_context.h>

#include <map>
#include <string>
#include <vector>

namespace hdrstereo::testing {

class FakeAuthContext : public grpc::AuthContext {
 public:
  static FakeAuthContext Local() { return FakeAuthContext("local", false); }
  // TLS without a client certificate.
  static FakeAuthContext Tls() { return FakeAuthContext("tls", false); }
  static FakeAuthContext Transport(const std::string& transport) {
    return FakeAuthContext(transport, false);
  }
  // TLS with a verified client certificate.
  static FakeAuthContext Certificate(const std::string& san_uri,
                                     const std::string& common_name,
                                     const std::string& transport = "tls") {
    FakeAuthContext c(transport, true);
    if (!san_uri.empty()) {
      c.properties_.emplace("x509_subject_alternative_name", san_uri);
    }
    c.properties_.emplace("x509_common_name", common_name);
    return c;
  }

  bool IsPeerAuthenticated() const override { return authenticated_; }
  std::vector<grpc::string_ref> GetPeerIdentity() const override { return {}; }
  std::string GetPeerIdentityPropertyName() const override { return ""; }
  std::vector<grpc::string_ref> FindPropertyValues(
      const std::string& name) const override {
    std::vector<grpc::string_ref> values;
    auto [begin, end] = properties_.equal_range(name);
    for (auto it = begin; it != end; ++it) values.emplace_back(it->second);
    return values;
  }
  // Iteration is not needed by the daemon.
  grpc::AuthPropertyIterator begin() const override { return Iterator(); }
  grpc::AuthPropertyIterator end() const override { return Iterator(); }
  void AddProperty(const std::string&, const grpc::string_ref&) override {}
  bool SetPeerIdentityPropertyName(const std::string&) override {
    return false;
  }

 private:
  struct Iterator : grpc::AuthPropertyIterator {};
  FakeAuthContext(const std::string& transport, bool authenticated)
      : authenticated_(authenticated) {
    properties_.emplace("transport_security_type", transport);
  }
  bool authenticated_;
  std::multimap<std::string, std::string> properties_;
};

}  // namespace hdrstereo::testing

#endif  // HDRSTEREO_TESTS_SUPPORT_FAKE_AUTH_CONTEXT_H_
