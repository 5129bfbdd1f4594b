# SPDX-License-Identifier: GPL-3.0-or-later
"""Exceptions raised by the client, one per gRPC status code that matters.

Every error carries the server's message (or the client's, for input
refused before a call) and, when it came from a call, the gRPC code.
"""

from __future__ import annotations

from typing import Optional

import grpc


class Error(Exception):
    """Base class of every hdrstereo client error."""

    code: Optional[grpc.StatusCode] = None

    def __init__(self, message: str, code: Optional[grpc.StatusCode] = None):
        super().__init__(message)
        self.message = message
        if code is not None:
            self.code = code


class InvalidArgument(Error, ValueError):
    """The request was refused as malformed; nothing was changed."""

    code = grpc.StatusCode.INVALID_ARGUMENT


class NotFound(Error, LookupError):
    """A session, job, artifact or schedule does not exist."""

    code = grpc.StatusCode.NOT_FOUND


class AlreadyExists(Error):
    """A session or schedule with that name exists already."""

    code = grpc.StatusCode.ALREADY_EXISTS


class PermissionDenied(Error):
    """The caller's role does not allow the call (the message names it)."""

    code = grpc.StatusCode.PERMISSION_DENIED


class Unauthenticated(Error):
    """No, bad, expired or revoked credentials."""

    code = grpc.StatusCode.UNAUTHENTICATED


class Unavailable(Error, ConnectionError):
    """The daemon cannot be reached (the message names the address)."""

    code = grpc.StatusCode.UNAVAILABLE


class DeadlineExceeded(Error, TimeoutError):
    """The call did not finish within its timeout."""

    code = grpc.StatusCode.DEADLINE_EXCEEDED


class FailedPrecondition(Error):
    """The call does not fit the current state (e.g. nothing captured yet)."""

    code = grpc.StatusCode.FAILED_PRECONDITION


class Aborted(Error):
    """The call was aborted, e.g. by the rig lock or a concurrent change."""

    code = grpc.StatusCode.ABORTED


class ResourceExhausted(Error):
    """The daemon is out of disk, queue slots or another resource."""

    code = grpc.StatusCode.RESOURCE_EXHAUSTED


class DataLoss(Error):
    """Data arrived damaged (e.g. a download whose sha256 does not match)."""

    code = grpc.StatusCode.DATA_LOSS


class JobFailed(Error):
    """`Job.wait()` saw the job end other than SUCCEEDED."""


_BY_CODE = {
    cls.code: cls
    for cls in (InvalidArgument, NotFound, AlreadyExists, PermissionDenied,
                Unauthenticated, Unavailable, DeadlineExceeded,
                FailedPrecondition, Aborted, ResourceExhausted, DataLoss)
}


def from_rpc_error(error: grpc.RpcError, address: str = "") -> Error:
    """The exception for a failed call: its class from the status code, its
    message the server's (with the address when the daemon was not
    reached)."""
    code = error.code() if hasattr(error, "code") else grpc.StatusCode.UNKNOWN
    details = error.details() if hasattr(error, "details") else str(error)
    message = details or (code.name if code else "unknown error")
    if code == grpc.StatusCode.UNAVAILABLE and address:
        message = f"cannot reach hdrstereod at {address}: {message}"
    elif code == grpc.StatusCode.DEADLINE_EXCEEDED and address:
        message = f"hdrstereod at {address} did not answer in time: {message}"
    cls = _BY_CODE.get(code, Error)
    return cls(message, code)
