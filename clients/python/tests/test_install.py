# SPDX-License-Identifier: GPL-3.0-or-later
"""`pip install --no-build-isolation --no-deps ./clients/python` works
offline with the Debian packages, and the installed package imports
outside the source and build trees (stubs generated during the install)."""

from __future__ import annotations

import shutil
import subprocess
import sys
from pathlib import Path

from conftest import SOURCE_DIR


def test_pip_install_from_the_source_tree(tmp_path: Path) -> None:
    # A copy of the two folders the install reads, so that pip's in-tree
    # build writes nothing into the checkout.
    source = tmp_path / "src"
    shutil.copytree(SOURCE_DIR / "proto", source / "proto")
    shutil.copytree(SOURCE_DIR / "clients/python", source / "clients/python",
                    ignore=shutil.ignore_patterns("tests", "examples",
                                                  "__pycache__"))
    target = tmp_path / "site"
    subprocess.run([sys.executable, "-m", "pip", "install", "--quiet",
                    "--no-index", "--no-build-isolation", "--no-deps",
                    "--target", str(target), str(source / "clients/python")],
                   check=True, timeout=300)
    assert sorted(p.name for p in (target / "hdrstereo/v1").glob("*_pb2*.py"))
    shown = subprocess.run(
        [sys.executable, "-c", "import hdrstereo, hdrstereo.v1.jobs_pb2 as j;"
         "print(hdrstereo.__file__, j.WatchJobRequest.DESCRIPTOR.full_name)"],
        env={"PYTHONPATH": str(target), "PATH": "/usr/bin:/bin"},
        cwd=tmp_path, capture_output=True, text=True, timeout=60, check=True)
    assert shown.stdout.split() == [str(target / "hdrstereo/__init__.py"),
                                    "hdrstereo.v1.WatchJobRequest"]
