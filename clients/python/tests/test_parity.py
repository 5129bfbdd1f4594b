# SPDX-License-Identifier: GPL-3.0-or-later
"""The client cannot fall behind the proto: every RPC of every
hdrstereo.v1 service (read from proto/hdrstereo/v1/*.proto) has a verb or a
raw call, and the lists name no RPC that is gone."""

from __future__ import annotations

import re

import hdrstereo
from hdrstereo import client as client_module

from conftest import SOURCE_DIR

SERVICE = re.compile(r"^service\s+(\w+)\s*\{(.*?)^\}", re.M | re.S)
RPC = re.compile(r"^\s*rpc\s+(\w+)\s*\(", re.M)


def proto_rpcs() -> set[str]:
    rpcs = set()
    for proto in sorted((SOURCE_DIR / "proto/hdrstereo/v1").glob("*.proto")):
        text = re.sub(r"//[^\n]*", "", proto.read_text())
        for service, body in SERVICE.findall(text):
            rpcs |= {f"{service}.{m}" for m in RPC.findall(body)}
    return rpcs


def resolve(obj, dotted: str):
    for part in dotted.split("."):
        obj = getattr(obj, part)
    return obj


def test_every_rpc_has_a_verb_or_a_raw_call() -> None:
    rpcs = proto_rpcs()
    assert len(rpcs) > 30  # the parser found the services
    client = hdrstereo.Client("127.0.0.1:9")  # no call is made
    missing = []
    for rpc in sorted(rpcs):
        service, method = rpc.split(".")
        if rpc in client_module.VERBS:
            assert callable(resolve(client, client_module.VERBS[rpc])), rpc
        elif rpc in client_module.RAW_ONLY:
            assert callable(getattr(getattr(client.raw, service), method)), rpc
        else:
            missing.append(rpc)
        # The generated stubs have it too (they were built from this proto).
        assert method in client_module.method_names(service), rpc
    client.close()
    assert not missing, ("RPCs with no verb in hdrstereo.client.VERBS and no "
                         f"entry in RAW_ONLY: {missing}")


def test_lists_name_only_existing_rpcs() -> None:
    listed = set(client_module.VERBS) | set(client_module.RAW_ONLY)
    assert not listed - proto_rpcs(), listed - proto_rpcs()
    assert not set(client_module.VERBS) & set(client_module.RAW_ONLY)
