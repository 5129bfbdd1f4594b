# SPDX-License-Identifier: GPL-3.0-or-later
"""Generates the gRPC stubs (hdrstereo/v1/*_pb2*.py) from
../../proto/hdrstereo/v1 with protoc and grpc_python_plugin whenever
setuptools runs (the package hdrstereo.v1 must exist before its metadata
is written); they are never committed."""

import shutil
import subprocess
from pathlib import Path

from setuptools import setup

HERE = Path(__file__).resolve().parent
PROTO_ROOT = HERE.parent.parent / "proto"


def generate_stubs() -> None:
    protos = sorted(PROTO_ROOT.glob("hdrstereo/v1/*.proto"))
    if not protos:
        raise SystemExit(f"no protos in {PROTO_ROOT}/hdrstereo/v1: build from "
                         "the hdrstereo source tree")
    plugin = shutil.which("grpc_python_plugin")
    if plugin is None:
        raise SystemExit("grpc_python_plugin not found (Debian: "
                         "protobuf-compiler-grpc)")
    (HERE / "hdrstereo/v1").mkdir(exist_ok=True)
    (HERE / "hdrstereo/v1/__init__.py").write_text(
        "# Generated gRPC stubs of proto/hdrstereo/v1.\n")
    subprocess.run(["protoc", f"-I{PROTO_ROOT}", f"--python_out={HERE}",
                    f"--grpc_out={HERE}", f"--plugin=protoc-gen-grpc={plugin}",
                    *map(str, protos)], check=True)


generate_stubs()
setup()
