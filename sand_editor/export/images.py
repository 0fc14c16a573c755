"""Image encoders for baked texture maps: PNG (8- or 16-bit) and OpenEXR (32-bit float).

Every encoder returns the file's bytes; the caller writes them (atomically, through
:mod:`sand_editor.files`). Arrays are ``(H, W)`` grey, ``(H, W, 3)`` RGB or ``(H, W, 4)`` RGBA,
rows top-down (row 0 is the top of the image).

- 8-bit PNG goes through Pillow, with its adaptive row filters.
- 16-bit PNG (grey, RGB and RGBA) goes through pypng: Pillow cannot write 16-bit RGB PNG, and
  pypng's packed-row writer is also the faster of the two for 16-bit grey. Its rows carry
  filter type 0 (none).
- EXR goes through the OpenEXR bindings: one scanline part, 32-bit float channels, lossless ZIP
  compression (PIZ is also lossless, but two to four times as slow on these maps).

PNG data use zlib level :data:`ZLIB_LEVEL`. On smooth 2048² maps level 1 is up to three times
as fast as zlib's default 6 for 8-bit files up to twice as large; on noise-like maps, and on the
unfiltered 16-bit rows, the sizes differ by a few per cent at most. The 16-bit rows stay
unfiltered because pypng undoes PNG row filters one byte at a time in Python, which would make
reading a 2048² map back many times slower.
"""

from __future__ import annotations

import functools
import io
import os
import tempfile
from collections.abc import Callable

import numpy as np

FORMATS = ("png8", "png16", "exr")
HALF_MAX = 65504.0  # the largest finite half float
BAND_ROWS = 256  # rows per band of encode_bands
ZLIB_LEVEL = 1

_EXTENSIONS = {"png8": ".png", "png16": ".png", "exr": ".exr"}
_PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"
_EXR_MAGIC = b"\x76\x2f\x31\x01"
_UINT_FOR_BITS = {8: np.dtype(np.uint8), 16: np.dtype(np.uint16)}


def _check_shape(values: np.ndarray) -> int:
    """The channel count (1, 3 or 4) of a grey, RGB or RGBA image array; ValueError otherwise."""
    shape = values.shape
    if values.ndim == 2:
        channels = 1
    elif values.ndim == 3 and shape[2] in (3, 4):
        channels = shape[2]
    else:
        raise ValueError(f"an image is (H, W), (H, W, 3) or (H, W, 4), not {shape}")
    if shape[0] < 1 or shape[1] < 1:
        raise ValueError(f"an image needs at least one row and one column, not {shape}")
    return channels


def quantise(values: np.ndarray, bits: int) -> np.ndarray:
    """Unsigned integers of ``bits`` (8 or 16) bits for ``values``.

    Floats (any float dtype) are clipped to [0, 1], NaN becomes 0, and they are scaled by
    ``2**bits - 1`` and rounded to nearest (ties to even), in float64 so that the rounding error
    stays within half a step. An array already of the target type (uint8 for 8 bits, uint16 for
    16 bits) is taken as integer codes and passed through without rescaling; other integer
    types, booleans and a uint8/uint16 array of the other depth are refused with ValueError.
    """
    if bits not in _UINT_FOR_BITS:
        raise ValueError(f"PNG bit depth is 8 or 16, not {bits!r}")
    values = np.asarray(values)
    target = _UINT_FOR_BITS[bits]
    if values.dtype == target:
        return values
    if not np.issubdtype(values.dtype, np.floating):
        raise ValueError(
            f"a {bits}-bit PNG takes floats in [0, 1] or {target.name} codes, not {values.dtype}"
        )
    scaled = np.array(values, dtype=np.float64)
    np.nan_to_num(scaled, copy=False, nan=0.0, posinf=1.0, neginf=0.0)
    np.clip(scaled, 0.0, 1.0, out=scaled)
    scaled *= float((1 << bits) - 1)
    np.rint(scaled, out=scaled)
    return scaled.astype(target)


def encode_png(values: np.ndarray, bits: int) -> bytes:
    """PNG bytes of ``values`` at ``bits`` (8 or 16) bits per channel.

    ``values`` are floats in [0, 1] (clipped; NaN is 0) or integer codes of the target depth
    (uint8 for 8 bits, uint16 for 16), written unchanged; see :func:`quantise`.
    """
    values = np.asarray(values)
    channels = _check_shape(values)
    codes = quantise(values, bits)
    if bits == 8:
        from PIL import Image

        buffer = io.BytesIO()
        Image.fromarray(np.ascontiguousarray(codes)).save(
            buffer, format="PNG", compress_level=ZLIB_LEVEL
        )
        return buffer.getvalue()
    return _encode_png16(codes, channels)


def _encode_png16(codes: np.ndarray, channels: int) -> bytes:
    """16-bit PNG bytes of uint16 ``codes`` with ``channels`` channels, through pypng."""
    import png

    height, width = codes.shape[:2]
    rows = np.ascontiguousarray(codes, dtype=">u2").reshape(height, width * channels)
    writer = png.Writer(
        width,
        height,
        greyscale=channels == 1,
        alpha=channels == 4,
        bitdepth=16,
        compression=ZLIB_LEVEL,
    )
    buffer = io.BytesIO()
    writer.write_packed(buffer, (row.tobytes() for row in rows))
    return buffer.getvalue()


def encode_exr(values: np.ndarray, half: bool = False) -> bytes:
    """OpenEXR bytes of ``values`` as linear 32-bit float channels (16-bit with ``half``, as
    engines keep normal maps: 11 significant bits, a quarter of the file), ZIP-compressed.

    ``(H, W)`` is written as channel ``Y``; ``(H, W, 3)`` as ``R``, ``G``, ``B``; ``(H, W, 4)``
    as ``R``, ``G``, ``B``, ``A``. Values are stored exactly as float32 (no clipping). Values
    that are not finite in float32 (NaN, ±inf, or beyond float32's range) are refused with
    ValueError naming how many there are.
    """
    import OpenEXR

    values = np.asarray(values)
    channels = _check_shape(values)
    if not (np.issubdtype(values.dtype, np.floating) or np.issubdtype(values.dtype, np.integer)):
        raise ValueError(f"an EXR map takes real numbers, not {values.dtype}")
    with np.errstate(over="ignore"):
        pixels = np.ascontiguousarray(values, dtype=np.float32)
    bad = pixels.size - int(np.count_nonzero(np.isfinite(pixels)))
    if bad:
        raise ValueError(
            f"{bad} of {pixels.size} values are not finite float32 numbers "
            "(NaN, infinite or beyond ±3.4e38); an EXR map holds finite values only"
        )
    if half:
        if np.any(np.abs(pixels) > HALF_MAX):
            raise ValueError(f"values beyond ±{HALF_MAX:g} do not fit a half-float EXR map")
        pixels = pixels.astype(np.float16)
    name = {1: "Y", 3: "RGB", 4: "RGBA"}[channels]
    header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
    with OpenEXR.File(header, {name: pixels}) as exr_file:
        buffer = io.BytesIO()
        try:
            exr_file.write(buffer)
        except TypeError:
            return _exr_bytes_via_path(exr_file)
        return buffer.getvalue()


def _exr_bytes_via_path(exr_file) -> bytes:
    """The bytes of ``exr_file``, written into a temporary folder and read back, for OpenEXR
    releases that write to paths only (no stream support)."""
    with tempfile.TemporaryDirectory(prefix="sand-editor-exr-") as folder:
        path = os.path.join(folder, "map.exr")
        exr_file.write(path)
        with open(path, "rb") as stream:
            return stream.read()


_SRGB8_STEPS = 65535  # the table's linear steps: its error is 1/20 of an 8-bit step at worst


@functools.cache
def _srgb8_table() -> np.ndarray:
    from sand_editor.colour import linear_to_srgb

    linear = np.arange(_SRGB8_STEPS + 1, dtype=np.float64) / _SRGB8_STEPS
    return np.rint(linear_to_srgb(linear) * 255.0).astype(np.uint8)


def linear_to_srgb8(values: np.ndarray) -> np.ndarray:
    """Linear values in [0, 1] (clipped; NaN as 0) as 8-bit sRGB codes, through a table: a
    tenth of the time of the transfer function on every texel."""
    scaled = np.nan_to_num(np.asarray(values, dtype=np.float32), nan=0.0)
    np.clip(scaled, 0.0, 1.0, out=scaled)
    scaled *= _SRGB8_STEPS
    return _srgb8_table()[np.rint(scaled).astype(np.int32)]


def encode(values: np.ndarray, fmt: str, half: bool = False) -> tuple[bytes, str]:
    """The bytes of ``values`` in format ``fmt`` (one of :data:`FORMATS`) and the file's
    extension (``".png"`` or ``".exr"``); ``half``: an EXR's channels as 16-bit floats."""
    if fmt == "png8":
        return encode_png(values, 8), _EXTENSIONS[fmt]
    if fmt == "png16":
        return encode_png(values, 16), _EXTENSIONS[fmt]
    if fmt == "exr":
        return encode_exr(values, half=half), _EXTENSIONS[fmt]
    raise ValueError(f"unknown image format {fmt!r}; the formats are {', '.join(FORMATS)}")


def encode_bands(
    band: Callable[[slice], np.ndarray], height: int, fmt: str, half: bool = False
) -> tuple[bytes, str]:
    """:func:`encode` of an image made :data:`BAND_ROWS` rows at a time: ``band(rows)`` gives
    the values of the image's rows ``rows`` (top first). Each band is quantised (or made the
    EXR's float32) as it comes, so that only the file's samples are held whole, not the floats
    (nor :func:`quantise`'s float64) of the whole image."""
    samples = None
    for start in range(0, height, BAND_ROWS):
        values = band(slice(start, min(start + BAND_ROWS, height)))
        if fmt in ("png8", "png16"):
            values = quantise(values, 8 if fmt == "png8" else 16)
        elif fmt == "exr":
            with np.errstate(over="ignore"):  # encode_exr names values beyond float32
                values = np.asarray(values, dtype=np.float32)
        else:
            raise ValueError(f"unknown image format {fmt!r}; the formats are {', '.join(FORMATS)}")
        if samples is None:
            samples = np.empty((height, *values.shape[1:]), values.dtype)
        samples[start : start + len(values)] = values
    return encode(samples, fmt, half=half)


def decode(data: bytes) -> np.ndarray:
    """The pixels of PNG or EXR ``data``, rows top-down.

    PNG gives uint8 (bit depth 8 or less) or uint16 (bit depth 16) with the file's channel
    count: ``(H, W)`` grey, ``(H, W, 2)`` grey + alpha, ``(H, W, 3)`` RGB, ``(H, W, 4)`` RGBA
    (a palette image is expanded to RGB, or RGBA where it has transparency). EXR gives float32:
    ``(H, W)`` for a single channel, ``(H, W, 3)`` for ``R``, ``G``, ``B`` and ``(H, W, 4)``
    when there is also ``A``. Other files, other layouts and damaged files are a ValueError.
    """
    data = bytes(data)
    if data.startswith(_PNG_SIGNATURE):
        kind, reader = "PNG", _decode_png
    elif data.startswith(_EXR_MAGIC):
        kind, reader = "OpenEXR", _decode_exr
    else:
        raise ValueError("not a PNG or OpenEXR file")
    try:
        return reader(data)
    except (ValueError, MemoryError):
        raise
    except Exception as exc:
        raise ValueError(f"unreadable {kind} file: {exc}") from exc


def _decode_png(data: bytes) -> np.ndarray:
    """Pixels of PNG ``data``: pypng for 16-bit files, Pillow for the rest."""
    if len(data) < 26 or data[12:16] != b"IHDR":
        raise ValueError("PNG file without an IHDR header")
    if data[24] == 16:
        import png

        width, height, rows, info = png.Reader(bytes=data).read()
        planes = info["planes"]
        pixels = np.empty((height, width * planes), dtype=np.uint16)
        for y, row in enumerate(rows):
            pixels[y] = np.frombuffer(row, dtype=np.uint16, count=width * planes)
        return pixels.reshape(height, width) if planes == 1 else pixels.reshape(height, width, -1)
    from PIL import Image

    with Image.open(io.BytesIO(data), formats=["PNG"]) as image:
        if image.mode == "P":
            image = image.convert("RGBA" if "transparency" in image.info else "RGB")
        elif image.mode == "1":
            image = image.convert("L")
        elif image.mode not in ("L", "LA", "RGB", "RGBA"):
            raise ValueError(f"unsupported PNG pixel mode {image.mode}")
        return np.array(image, dtype=np.uint8)


def _decode_exr(data: bytes) -> np.ndarray:
    """Float32 pixels of the first part of OpenEXR ``data``, read from memory."""
    import OpenEXR

    try:
        exr_file = OpenEXR.File(io.BytesIO(data), separate_channels=True)
    except TypeError:
        return _decode_exr_via_path(data)
    with exr_file:
        return _exr_pixels(exr_file)


def _decode_exr_via_path(data: bytes) -> np.ndarray:
    """Float32 pixels of OpenEXR ``data`` written into a temporary folder and read from there,
    for OpenEXR releases that read from paths only."""
    import OpenEXR

    with tempfile.TemporaryDirectory(prefix="sand-editor-exr-") as folder:
        path = os.path.join(folder, "map.exr")
        with open(path, "wb") as stream:
            stream.write(data)
        with OpenEXR.File(path, separate_channels=True) as exr_file:
            return _exr_pixels(exr_file)


def _exr_pixels(exr_file) -> np.ndarray:
    """Float32 pixels of an open OpenEXR file's first part: Y, RGB or RGBA."""
    found = {name: channel.pixels for name, channel in exr_file.channels().items()}
    if len(found) == 1:
        return np.array(next(iter(found.values())), dtype=np.float32)
    if {"R", "G", "B"} <= found.keys() and len(found) == 3 + ("A" in found):
        names = ("R", "G", "B", "A") if "A" in found else ("R", "G", "B")
        return np.stack([np.asarray(found[name], dtype=np.float32) for name in names], axis=-1)
    raise ValueError(f"EXR channels {sorted(found)} are not Y, RGB or RGBA")
