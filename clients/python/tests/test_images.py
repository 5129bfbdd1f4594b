# SPDX-License-Identifier: GPL-3.0-or-later
"""Image decoding: known arrays written by OpenCV come back exactly, with
their dtype (float32 for PFM and EXR; bit depth kept for PNG and TIFF)."""

from __future__ import annotations

import numpy as np
import pytest

import hdrstereo
from hdrstereo import images

cv2 = images.cv2
rng = np.random.default_rng(7)


def encode(suffix: str, image: np.ndarray) -> bytes:
    ok, data = cv2.imencode(suffix, image)
    assert ok, suffix
    return data.tobytes()


@pytest.mark.parametrize("shape", [(5, 7), (5, 7, 3)])
def test_pfm_is_float32_top_row_first_bgr(shape) -> None:
    truth = rng.uniform(-3, 1e4, shape).astype(np.float32)
    loaded = hdrstereo.decode(encode(".pfm", truth), "disparity/fused.pfm")
    assert loaded.dtype == np.float32 and loaded.shape == shape
    np.testing.assert_array_equal(loaded, truth)


def test_pfm_big_endian_and_infinity() -> None:
    # Written by hand: scale > 0 means big-endian; bottom row first.
    rows = np.array([[1.0, np.inf], [-2.5, 0.0]], dtype=">f4")  # top, bottom
    data = b"Pf\n2 2\n1.0\n" + rows[::-1].tobytes()
    np.testing.assert_array_equal(hdrstereo.decode_pfm(data),
                                  rows.astype(np.float32))


def test_pfm_truncated_or_not_pfm() -> None:
    with pytest.raises(ValueError, match="needs 16 bytes of pixels; it has 4"):
        hdrstereo.decode_pfm(b"Pf\n2 2\n-1.0\n" + b"\0" * 4)
    with pytest.raises(ValueError, match="not a PFM file"):
        hdrstereo.decode_pfm(b"P6\n2 2\n255\n")


def test_png_and_tiff_keep_bit_depth() -> None:
    gray16 = rng.integers(0, 65536, (6, 4), dtype=np.uint16)
    color8 = rng.integers(0, 256, (6, 4, 3), dtype=np.uint8)
    for suffix, truth in ((".png", gray16), (".tif", gray16),
                          (".png", color8), (".tiff", color8)):
        loaded = hdrstereo.decode(encode(suffix, truth), "x" + suffix)
        assert loaded.dtype == truth.dtype, suffix
        np.testing.assert_array_equal(loaded, truth)


def test_exr_is_float32() -> None:
    truth = rng.uniform(0, 100, (4, 6, 3)).astype(np.float32)
    loaded = hdrstereo.decode(encode(".exr", truth), "hdr/im0.exr")
    assert loaded.dtype == np.float32
    np.testing.assert_allclose(loaded, truth, rtol=1e-3)  # EXR may store half


def test_unknown_suffix() -> None:
    with pytest.raises(ValueError,
                       match=r"report/index.html: cannot load .html as an "
                             r"image \(PFM, EXR, PNG or TIFF\)"):
        hdrstereo.decode(b"<html>", "report/index.html")
