// SPDX-License-Identifier: GPL-3.0-or-later
//
// The real hdrstereod serving TLS on 0.0.0.0:<free port> (and, when asked,
// a local plaintext port on 127.0.0.1), with the certificates of
// TestCerts; the real CLI and plain gRPC channels connect to 127.0.0.1.
#ifndef HDRSTEREO_TESTS_INTEGRATION_REMOTE_FIXTURE_H_
#define HDRSTEREO_TESTS_INTEGRATION_REMOTE_FIXTURE_H_

#include <grpcpp/grpcpp.h>

#include <fstream>
#include <string>
#include <vector>

#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/time/clock.h"
#include "absl/time/time.h"
#include "tests/support/daemon_fixture.h"
#include "tests/support/empty_call.h"
#include "tests/support/test_certs.h"

namespace hdrstereo::testing {

class RemoteFixture : public DaemonFixture {
 protected:
  // TLS on 0.0.0.0:0; with `local_port`, also plaintext 127.0.0.1:0.
  void StartTlsDaemon(const std::vector<std::string>& extra = {},
                      bool local_port = false) {
    std::vector<std::string> args = {"--listen", "0.0.0.0:0"};
    if (local_port) args.insert(args.end(), {"--listen", "127.0.0.1:0"});
    args.insert(args.end(), {"--sim-scene",
                             WriteScene("lab-lamp", SmallLabLamp()).string()});
    const std::vector<std::string> tls = certs_.DaemonArgs();
    args.insert(args.end(), tls.begin(), tls.end());
    args.insert(args.end(), extra.begin(), extra.end());
    StartDaemon(args);
  }

  std::string local_address() const {
    return addresses_.size() > 1 ? addresses_[1] : "";
  }
  int tls_port() const {
    int port = 0;
    (void)absl::SimpleAtoi(address_.substr(address_.rfind(':') + 1), &port);
    return port;
  }

  // The CLI as `user` (its certificate); "" = with the lab CA only.
  CommandResult As(const std::string& user, std::vector<std::string> args) {
    std::vector<std::string> auth =
        user.empty()
            ? std::vector<std::string>{"--tls-ca", certs_.ca().string()}
            : certs_.CliArgs(user);
    args.insert(args.begin(), auth.begin(), auth.end());
    return Cli(args);
  }
  nlohmann::json AsJson(const std::string& user,
                        std::vector<std::string> args) {
    args.insert(args.begin(), "--json");
    CommandResult result = As(user, args);
    EXPECT_EQ(result.exit_code, 0) << result.err;
    nlohmann::json parsed = nlohmann::json::parse(result.out, nullptr, false);
    EXPECT_FALSE(parsed.is_discarded()) << result.out;
    return parsed;
  }

  // A TLS channel to the daemon: with `user`'s certificate ("" = none) and,
  // if given, an API key sent per call.
  std::shared_ptr<grpc::Channel> TlsChannel(const std::string& user,
                                            const std::string& api_key = "") {
    grpc::SslCredentialsOptions ssl;
    ssl.pem_root_certs = ReadFileOrDie(certs_.ca());
    if (!user.empty()) {
      ssl.pem_cert_chain = ReadFileOrDie(certs_.Cert(user));
      ssl.pem_private_key = ReadFileOrDie(certs_.Key(user));
    }
    std::shared_ptr<grpc::ChannelCredentials> credentials =
        grpc::SslCredentials(ssl);
    if (!api_key.empty()) {
      credentials = grpc::CompositeChannelCredentials(
          credentials, grpc::AccessTokenCredentials(api_key));
    }
    // A channel of its own (not shared with other tests' channels).
    grpc::ChannelArguments arguments;
    arguments.SetInt("hdrstereo.test.channel", ++channels_);
    return grpc::CreateCustomChannel(address_, credentials, arguments);
  }

  // One call of `method` with an empty request and raw bytes back; the
  // authorization metadata is set when given.
  static grpc::Status Call(const std::shared_ptr<grpc::Channel>& channel,
                           const std::string& method,
                           const std::string* authorization = nullptr,
                           absl::Duration deadline = absl::Seconds(20)) {
    return CallWithEmptyRequest(
        channel, method,
        [authorization](grpc::ClientContext& context) {
          if (authorization != nullptr) {
            context.AddMetadata("authorization", *authorization);
          }
        },
        deadline);
  }

  // Writes an API key to a file only its owner can read.
  std::string KeyFile(const std::string& name, const std::string& key,
                      int mode = 0600) {
    const std::string path = (dir_ / name).string();
    std::ofstream(path) << key << "\n";
    ::chmod(path.c_str(), static_cast<mode_t>(mode));
    return path;
  }

  const TestCerts& certs_ = TestCerts::Get();
  int channels_ = 0;
};

}  // namespace hdrstereo::testing

#endif  // HDRSTEREO_TESTS_INTEGRATION_REMOTE_FIXTURE_H_
