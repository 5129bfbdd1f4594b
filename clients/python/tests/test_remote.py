# SPDX-License-Identifier: GPL-3.0-or-later
"""Remote operation: TLS with client certificates and API keys, roles,
and the profile file, against the real daemon."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

import hdrstereo
from hdrstereo.v1 import common_pb2

from conftest import Daemon


def role(identity) -> str:
    return common_pb2.Role.Name(identity.role).removeprefix("ROLE_").lower()


def as_user(daemon: Daemon, certs: Path, user: str) -> hdrstereo.Client:
    return hdrstereo.Client(daemon.address, tls_ca=str(certs / "ca.pem"),
                            tls_cert=str(certs / f"{user}.pem"),
                            tls_key=str(certs / f"{user}.key"), timeout=30)


def test_profile_file_and_client_certificate(tls_daemon, certs, tmp_path,
                                             monkeypatch) -> None:
    profile = tmp_path / "client.toml"
    profile.write_text(f"""default_profile = "lab"
[profile.lab]
server = "{tls_daemon.address}"
tls_ca = "{certs / 'ca.pem'}"
tls_cert = "{certs / 'bob.pem'}"
tls_key = "{certs / 'bob.key'}"
""")
    monkeypatch.setenv("HDRSTEREO_CLIENT_CONFIG", str(profile))
    for variable in ("HDRSTEREO_SERVER", "HDRSTEREO_PROFILE",
                     "HDRSTEREO_TLS_CA", "HDRSTEREO_TLS_CERT",
                     "HDRSTEREO_TLS_KEY", "HDRSTEREO_API_KEY_FILE"):
        monkeypatch.delenv(variable, raising=False)
    with hdrstereo.Client() as client:
        me = client.whoami()
        assert (me.principal, role(me), me.auth_method) == ("bob", "operator",
                                                             "cert")
        made = client.sessions.create("remote-bob")
        assert made.name == "remote-bob"
        # Deleting needs admin; the server's message names the role.
        with pytest.raises(hdrstereo.PermissionDenied,
                           match="needs role admin; bob has operator"):
            client.sessions.delete("remote-bob")


def test_viewer_may_read_not_capture(tls_daemon, certs) -> None:
    with as_user(tls_daemon, certs, "alice") as alice:
        assert role(alice.whoami()) == "viewer"
        alice.sessions.list()
        with pytest.raises(hdrstereo.PermissionDenied,
                           match="needs role operator; alice has viewer"):
            alice.sessions.create("alice-1")


def test_api_key_as_string_and_file(tls_daemon, certs, tmp_path) -> None:
    with as_user(tls_daemon, certs, "carol") as carol:
        made = carol.admin.create_api_key("bob", "viewer", ttl_s=3600,
                                          note="notebook")
        assert made.api_key.startswith(f"hs_{made.key.id}_")
        assert made.key.id in [k.id for k in carol.admin.list_api_keys("bob")]
    key_file = tmp_path / "bob-notebook.key"
    key_file.write_text(made.api_key + "\n")
    os.chmod(key_file, 0o600)
    ca = str(certs / "ca.pem")
    for kwargs in ({"api_key": made.api_key},
                   {"api_key_file": str(key_file)}):
        with hdrstereo.Client(tls_daemon.address, tls_ca=ca, **kwargs) as c:
            me = c.whoami()
            assert (me.principal, role(me), me.auth_method) == (
                "bob", "viewer", f"key:{made.key.id}")
            with pytest.raises(hdrstereo.PermissionDenied,
                               match="needs role operator"):
                c.sessions.create("by-key")
    with as_user(tls_daemon, certs, "carol") as carol:
        carol.admin.revoke_api_key(made.key.id)
        assert any(e.method.endswith("/RevokeApiKey")
                   for e in carol.admin.audit_log(principal="carol"))
    with hdrstereo.Client(tls_daemon.address, tls_ca=ca,
                          api_key=made.api_key) as c:
        with pytest.raises(hdrstereo.Unauthenticated, match="revoked"):
            c.whoami()


def test_no_or_bad_credentials(tls_daemon, certs) -> None:
    ca = str(certs / "ca.pem")
    with hdrstereo.Client(tls_daemon.address, tls_ca=ca) as c:
        with pytest.raises(hdrstereo.Unauthenticated,
                           match="no client certificate and no API key"):
            c.sessions.list()
    with hdrstereo.Client(tls_daemon.address, tls_ca=ca,
                          api_key="hs_nosuchkey_0000") as c:
        with pytest.raises(hdrstereo.Unauthenticated):
            c.whoami()
    with as_user(tls_daemon, certs, "dave") as dave:  # no role
        with pytest.raises(hdrstereo.PermissionDenied, match="dave"):
            dave.sessions.list()
