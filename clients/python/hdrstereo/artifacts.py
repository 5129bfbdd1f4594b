# SPDX-License-Identifier: GPL-3.0-or-later
"""A session's artifacts: listed, downloaded (resumable, sha256-checked)
and loaded as NumPy arrays."""

from __future__ import annotations

import hashlib
import json
import os
from pathlib import Path
from typing import TYPE_CHECKING, Any, Iterator, Union

import numpy as np

from . import images
from .errors import DataLoss
from .v1 import sessions_pb2

if TYPE_CHECKING:
    from .client import Client


def _sha256_of(path: Path) -> str:
    digest = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


class Artifact:
    """One output file of the pipeline (`kind`, `path` relative to the
    session folder, `sha256`, `size_bytes`, `params`, `job_id`)."""

    def __init__(self, client: "Client", session: str,
                 message: sessions_pb2.Artifact):
        self._client = client
        self.session = session
        self.message = message

    id = property(lambda self: self.message.id)
    kind = property(lambda self: self.message.kind)
    path = property(lambda self: self.message.path)
    sha256 = property(lambda self: self.message.sha256)
    size_bytes = property(lambda self: self.message.size_bytes)
    job_id = property(lambda self: self.message.job_id)

    @property
    def params(self) -> dict[str, Any]:
        """The producing step's parameters."""
        return json.loads(self.message.params_json or "{}")

    def __repr__(self) -> str:
        return (f"Artifact(id={self.id}, kind={self.kind!r}, path="
                f"{self.path!r}, size_bytes={self.size_bytes})")

    def _chunks(self, offset: int) -> Iterator[sessions_pb2.ArtifactChunk]:
        request = sessions_pb2.DownloadArtifactRequest(
            session=self.session, artifact_id=self.id, offset_bytes=offset)
        for chunk in self._client._stream(
                self._client._stubs.Sessions.DownloadArtifact, request):
            if chunk.offset_bytes != offset:
                raise DataLoss(f"{self.path}: expected bytes at {offset}, got "
                               f"{chunk.offset_bytes}")
            offset += len(chunk.data)
            yield chunk

    def download(self, dest: Union[str, os.PathLike],
                 overwrite: bool = False) -> Path:
        """Writes the file to `dest` (a file name, or a folder to put it in
        under its own name) and returns the path.

        An existing file is refused (FileExistsError) unless `overwrite`. An
        interrupted download leaves `<dest>.part`, which the next call
        continues; the file gets its name only once its sha256 matches the
        server's, else the partial file is removed and DataLoss raised.
        """
        target = Path(dest)
        if target.is_dir():
            target = target / Path(self.path).name
        if target.exists() and not overwrite:
            raise FileExistsError(
                f"{target} exists; pass overwrite=True to replace it")
        target.parent.mkdir(parents=True, exist_ok=True)
        part = target.with_name(target.name + ".part")
        offset = part.stat().st_size if part.exists() else 0
        if offset > self.size_bytes:
            part.unlink()
            offset = 0
        with open(part, "ab") as out:
            for chunk in self._chunks(offset):
                out.write(chunk.data)
            out.flush()
            os.fsync(out.fileno())
        if _sha256_of(part) != self.sha256:
            part.unlink()
            raise DataLoss(f"{self.path}: sha256 does not match the server's "
                           f"(the partial file {part} was removed); download "
                           "it again")
        os.replace(part, target)
        return target

    def read_bytes(self) -> bytes:
        """The whole file in memory, sha256-checked."""
        data = b"".join(chunk.data for chunk in self._chunks(0))
        if hashlib.sha256(data).hexdigest() != self.sha256:
            raise DataLoss(f"{self.path}: sha256 does not match the server's")
        return data

    def load(self) -> np.ndarray:
        """The image as a NumPy array: float32 for PFM and EXR, the file's
        bit depth for PNG and TIFF (BGR channel order for colour)."""
        return images.decode(self.read_bytes(), self.path)
