// SPDX-License-Identifier: GPL-3.0-or-later
#ifndef HDRSTEREO_DAEMON_RPC_ADMIN_SERVICE_H_
#define HDRSTEREO_DAEMON_RPC_ADMIN_SERVICE_H_

#include "daemon/rpc/api_keys.h"
#include "daemon/rpc/audit_log.h"
#include "daemon/rpc/authenticator.h"
#include "hdrstereo/v1/admin.grpc.pb.h"

namespace hdrstereo::rpc {

// Admin: API keys and the audit log (role admin, see method_roles.cc).
class AdminService final : public v1::Admin::Service {
 public:
  AdminService(Authenticator& authenticator, ApiKeyStore& keys, AuditLog& audit)
      : authenticator_(authenticator), keys_(keys), audit_(audit) {}

  grpc::Status CreateApiKey(grpc::ServerContext* context,
                            const v1::CreateApiKeyRequest* request,
                            v1::CreateApiKeyResponse* response) override;
  grpc::Status ListApiKeys(grpc::ServerContext* context,
                           const v1::ListApiKeysRequest* request,
                           v1::ListApiKeysResponse* response) override;
  grpc::Status RevokeApiKey(grpc::ServerContext* context,
                            const v1::RevokeApiKeyRequest* request,
                            v1::ApiKey* response) override;
  grpc::Status ListAuditLog(grpc::ServerContext* context,
                            const v1::ListAuditLogRequest* request,
                            v1::ListAuditLogResponse* response) override;

 private:
  Authenticator& authenticator_;
  ApiKeyStore& keys_;
  AuditLog& audit_;
};

}  // namespace hdrstereo::rpc

#endif  // HDRSTEREO_DAEMON_RPC_ADMIN_SERVICE_H_
