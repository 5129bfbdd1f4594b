# SPDX-License-Identifier: GPL-3.0-or-later
"""Decoding the image files the pipeline writes into NumPy arrays.

PFM and EXR become float32 (PFM rows top first, as OpenCV reads them);
PNG and TIFF keep their bit depth (uint8 or uint16). Colour images are in
OpenCV's BGR order, as the files hold them.
"""

from __future__ import annotations

import os
import re

import numpy as np

# OpenCV reads EXR only when this is set before its first EXR read.
os.environ.setdefault("OPENCV_IO_ENABLE_OPENEXR", "1")
import cv2  # noqa: E402  (after the variable above)

_PFM_HEADER = re.compile(rb"\A(PF|Pf)\s+(\d+)\s+(\d+)\s+(-?[0-9.eE+-]+)\s")


def decode_pfm(data: bytes) -> np.ndarray:
    """A PFM file as float32, shape (h, w) or (h, w, 3), top row first.

    Raises ValueError for a file that is not PFM or is truncated.
    """
    match = _PFM_HEADER.match(data)
    if match is None:
        raise ValueError("not a PFM file (the header is 'PF' or 'Pf', width, "
                         "height and scale)")
    channels = 3 if match.group(1) == b"PF" else 1
    width, height = int(match.group(2)), int(match.group(3))
    scale = float(match.group(4))
    dtype = np.dtype("<f4" if scale < 0 else ">f4")
    count = width * height * channels
    body = data[match.end():]
    if len(body) < count * 4:
        raise ValueError(f"PFM of {width} x {height} x {channels} needs "
                         f"{count * 4} bytes of pixels; it has {len(body)}")
    pixels = np.frombuffer(body, dtype=dtype, count=count).astype(np.float32)
    shape = (height, width, 3) if channels == 3 else (height, width)
    # PFM stores the bottom row first; RGB order, like OpenCV's reader we
    # return BGR so that PFM and EXR arrays are alike.
    image = pixels.reshape(shape)[::-1]
    if channels == 3:
        image = image[..., ::-1]
    return np.ascontiguousarray(image)


def decode(data: bytes, name: str) -> np.ndarray:
    """Decodes `data`, the bytes of a file called `name` (its suffix picks
    the format: .pfm, .exr, .png, .tif/.tiff)."""
    suffix = os.path.splitext(name)[1].lower()
    if suffix == ".pfm":
        return decode_pfm(data)
    if suffix not in (".exr", ".png", ".tif", ".tiff"):
        what = suffix or "a file without a suffix"
        raise ValueError(f"{name}: cannot load {what} as an image (PFM, EXR, "
                         "PNG or TIFF)")
    image = cv2.imdecode(np.frombuffer(data, np.uint8), cv2.IMREAD_UNCHANGED)
    if image is None:
        raise ValueError(f"{name}: OpenCV could not decode it")
    if suffix == ".exr":
        image = image.astype(np.float32, copy=False)
    return image
