# SPDX-License-Identifier: GPL-3.0-or-later
"""hdrstereo: drive the hdrstereod acquisition daemon from Python.

    import hdrstereo
    with hdrstereo.Client("localhost:50051") as client:
        client.sessions.create("lamp-1")
        client.capture.stereo("lamp-1", wait=True, progress=True)
        client.process("lamp-1", wait=True, progress=True)
        disparity = client.artifacts("lamp-1", kind="disparity")[0].load()

See help(hdrstereo.Client) and clients/python/README.md.
"""

from .artifacts import Artifact
from .client import Client, check_name
from .errors import (Aborted, AlreadyExists, DataLoss, DeadlineExceeded,
                     Error, FailedPrecondition, InvalidArgument, JobFailed,
                     NotFound, PermissionDenied, ResourceExhausted,
                     Unauthenticated, Unavailable)
from .images import decode, decode_pfm
from .jobs import Job

__all__ = [
    "Aborted", "AlreadyExists", "Artifact", "Client", "DataLoss",
    "DeadlineExceeded", "Error", "FailedPrecondition", "InvalidArgument",
    "Job", "JobFailed", "NotFound", "PermissionDenied", "ResourceExhausted",
    "Unauthenticated", "Unavailable", "check_name", "decode", "decode_pfm",
]
