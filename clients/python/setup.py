# SPDX-License-Identifier: GPL-3.0-or-later
"""Generates the gRPC stubs (hdrstereo/v1/*_pb2*.py) from
../../proto/hdrstereo/v1 with protoc and grpc_python_plugin before the
package is built; they are never committed."""

import shutil
import subprocess
from pathlib import Path

from setuptools import setup
from setuptools.command.build_py import build_py

HERE = Path(__file__).resolve().parent
PROTO_ROOT = HERE.parent.parent / "proto"


class BuildWithStubs(build_py):
    def run(self):
        protos = sorted(PROTO_ROOT.glob("hdrstereo/v1/*.proto"))
        if not protos:
            raise SystemExit(f"no protos in {PROTO_ROOT}/hdrstereo/v1: build "
                             "from the hdrstereo source tree")
        plugin = shutil.which("grpc_python_plugin")
        if plugin is None:
            raise SystemExit("grpc_python_plugin not found (Debian: "
                             "protobuf-compiler-grpc)")
        (HERE / "hdrstereo/v1").mkdir(exist_ok=True)
        (HERE / "hdrstereo/v1/__init__.py").write_text(
            "# Generated gRPC stubs of proto/hdrstereo/v1.\n")
        subprocess.run(["protoc", f"-I{PROTO_ROOT}", f"--python_out={HERE}",
                        f"--grpc_out={HERE}",
                        f"--plugin=protoc-gen-grpc={plugin}",
                        *map(str, protos)], check=True)
        super().run()


setup(cmdclass={"build_py": BuildWithStubs})
