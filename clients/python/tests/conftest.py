# SPDX-License-Identifier: GPL-3.0-or-later
"""Fixtures: the real hdrstereod (simulated hardware, small lab-lamp scene)
on a free port with a temporary data root, plaintext on loopback or TLS
with certificates from deploy/make-certs.sh; stopped at the end."""

from __future__ import annotations

import json
import os
import signal
import socket
import subprocess
import time
from pathlib import Path
from typing import Iterator, Optional

import pytest

SOURCE_DIR = Path(os.environ.get("HDRSTEREO_SOURCE_DIR",
                                 Path(__file__).resolve().parents[3]))
HDRSTEREOD = os.environ.get("HDRSTEREOD", str(SOURCE_DIR / "build/daemon/hdrstereod"))
HDRSTEREO_CLI = os.environ.get("HDRSTEREO_CLI",
                               str(SOURCE_DIR / "build/clients/cli/hdrstereo"))

# The C++ tests' SmallLabLamp (tests/support/daemon_fixture.cc): the bundled
# lab-lamp at 240 x 180 with a 128 x 96 projector, so captures are quick.
SMALL_LAB_LAMP = {
    "camera": {"width": 240, "height": 180, "fx": 320, "fy": 320,
               "cx": 119.5, "cy": 89.5},
    "projector": {"width": 128, "height": 96},
}


def _merge(base: dict, patch: dict) -> dict:
    for key, value in patch.items():
        if isinstance(value, dict) and isinstance(base.get(key), dict):
            _merge(base[key], value)
        else:
            base[key] = value
    return base


def small_scene(folder: Path, patch: Optional[dict] = None) -> Path:
    """The small lab-lamp, with `patch` (e.g. faults) merged in."""
    scene = json.loads((SOURCE_DIR / "hardware/sim/scenes/lab-lamp.json")
                       .read_text())
    path = folder / "lab-lamp-small.json"
    path.write_text(json.dumps(_merge(_merge(scene, SMALL_LAB_LAMP),
                                      patch or {})))
    return path


class Daemon:
    """A running hdrstereod; `address` is what a client connects to.
    `scene` is merged into the small lab-lamp scene."""

    def __init__(self, folder: Path, extra: list[str],
                 scene: Optional[dict] = None):
        self.folder = folder
        self.data_root = folder / "data"
        ready = folder / "ready"
        self.log = folder / "daemon.log"
        argv = [HDRSTEREOD, "--data-root", str(self.data_root),
                "--ready-file", str(ready), "--hardware", "sim",
                "--sim-scene", str(small_scene(folder, scene))]
        if "--listen" not in extra:
            argv += ["--listen", "127.0.0.1:0"]
        with open(self.log, "wb") as log:
            self.process = subprocess.Popen(argv + extra, stdout=log,
                                            stderr=subprocess.STDOUT)
        deadline = time.monotonic() + 60
        while not ready.exists():
            if self.process.poll() is not None or time.monotonic() > deadline:
                self.stop()
                raise RuntimeError("hdrstereod did not start:\n" +
                                   self.log.read_text(errors="replace"))
            time.sleep(0.05)
        self.addresses = ready.read_text().split()
        self.address = self.addresses[0].replace("0.0.0.0:", "127.0.0.1:")

    def stop(self) -> Optional[int]:
        if self.process.poll() is None:
            self.process.send_signal(signal.SIGTERM)
            try:
                self.process.wait(60)
            except subprocess.TimeoutExpired:
                self.process.kill()
                self.process.wait(30)
        return self.process.returncode

    def cli(self, *args: str, extra: tuple[str, ...] = ()) -> subprocess.CompletedProcess:
        """The real CLI against this daemon."""
        return subprocess.run([HDRSTEREO_CLI, "--server", self.address,
                               *extra, *args], capture_output=True, text=True,
                              timeout=120)


@pytest.fixture(scope="session")
def daemon(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Daemon]:
    """Plaintext on 127.0.0.1 (a local caller: role admin)."""
    d = Daemon(tmp_path_factory.mktemp("daemon"), [])
    yield d
    assert d.stop() == 0, d.log.read_text(errors="replace")


def _make_certs(*args: str) -> None:
    subprocess.run([str(SOURCE_DIR / "deploy/make-certs.sh"), *args],
                   check=True, capture_output=True, timeout=60)


@pytest.fixture(scope="session")
def certs(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A lab CA, the server's certificate and clients alice (viewer), bob
    (operator), carol (admin) and dave (no role), by deploy/make-certs.sh."""
    lab = tmp_path_factory.mktemp("certs") / "lab"
    _make_certs(str(lab), "ca")
    _make_certs(str(lab), "server", "localhost", "127.0.0.1")
    for user in ("alice", "bob", "carol", "dave"):
        _make_certs(str(lab), "client", user)
    return lab


@pytest.fixture(scope="session")
def tls_daemon(tmp_path_factory: pytest.TempPathFactory,
               certs: Path) -> Iterator[Daemon]:
    """TLS with client certificates and API keys. Like the C++ remote
    tests it listens on the wildcard address (a loopback address is always
    local, without TLS); clients connect through 127.0.0.1."""
    d = Daemon(tmp_path_factory.mktemp("tls-daemon"), [
        "--listen", "0.0.0.0:0",
        "--tls-cert", str(certs / "server.pem"),
        "--tls-key", str(certs / "server.key"),
        "--tls-client-ca", str(certs / "ca.pem"),
        "--auth-user", "alice=viewer", "--auth-user", "bob=operator",
        "--auth-user", "carol=admin"])
    yield d
    assert d.stop() == 0, d.log.read_text(errors="replace")


def free_port() -> int:
    """A port nothing listens on (bound, then released)."""
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]
