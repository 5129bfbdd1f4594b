// SPDX-License-Identifier: GPL-3.0-or-later
#ifndef HDRSTEREO_DAEMON_RPC_ADMIN_SERVICE_H_
#define HDRSTEREO_DAEMON_RPC_ADMIN_SERVICE_H_

#include "daemon/notify/webhook_signing.h"
#include "daemon/rpc/api_keys.h"
#include "daemon/rpc/audit_log.h"
#include "daemon/rpc/authenticator.h"
#include "daemon/rpc/call_guard_interceptor.h"
#include "daemon/store/webhook_repository.h"
#include "hdrstereo/v1/admin.grpc.pb.h"

namespace hdrstereo::rpc {

// Admin: API keys, the audit log and webhooks (role admin, see
// method_roles.cc).
class AdminService final : public v1::Admin::Service {
 public:
  AdminService(const CallDecisions& calls, Authenticator& authenticator,
               ApiKeyStore& keys, AuditLog& audit, store::Store& store,
               const notify::WebhookSigner& signer)
      : calls_(calls),
        authenticator_(authenticator),
        keys_(keys),
        audit_(audit),
        webhooks_(store),
        signer_(signer) {}

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
  grpc::Status CreateWebhook(grpc::ServerContext* context,
                             const v1::CreateWebhookRequest* request,
                             v1::CreateWebhookResponse* response) override;
  grpc::Status ListWebhooks(grpc::ServerContext* context,
                            const v1::ListWebhooksRequest* request,
                            v1::ListWebhooksResponse* response) override;
  grpc::Status DeleteWebhook(grpc::ServerContext* context,
                             const v1::DeleteWebhookRequest* request,
                             v1::Webhook* response) override;
  grpc::Status ListWebhookDeliveries(
      grpc::ServerContext* context,
      const v1::ListWebhookDeliveriesRequest* request,
      v1::ListWebhookDeliveriesResponse* response) override;

 private:
  const CallDecisions& calls_;
  Authenticator& authenticator_;  // for the roles of [auth.users]
  ApiKeyStore& keys_;
  AuditLog& audit_;
  store::WebhookRepository webhooks_;
  const notify::WebhookSigner& signer_;
};

}  // namespace hdrstereo::rpc

#endif  // HDRSTEREO_DAEMON_RPC_ADMIN_SERVICE_H_
