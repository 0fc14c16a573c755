"""The map image encoders: PNG and EXR round trips, bit depths, refusals and the formats table."""

from __future__ import annotations

import struct

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from sand_editor.export import images
from sand_editor.export.images import FORMATS, decode, encode, encode_exr, encode_png

SHAPES = [(5, 7), (5, 7, 3), (5, 7, 4)]


def _png_header(data: bytes) -> tuple[int, int, int, int]:
    """Width, height, bit depth and colour type from a PNG's IHDR chunk."""
    assert data[:8] == b"\x89PNG\r\n\x1a\n"
    assert data[12:16] == b"IHDR"
    width, height, depth, colour = struct.unpack(">IIBB", data[16:26])
    return width, height, depth, colour


def _max_error(values: np.ndarray, decoded: np.ndarray, bits: int) -> float:
    """Largest distance between ``values`` and ``decoded`` codes scaled back to [0, 1]."""
    scale = float((1 << bits) - 1)
    return float(np.max(np.abs(decoded.astype(np.float64) / scale - values.astype(np.float64))))


@pytest.mark.parametrize("bits", [8, 16])
@pytest.mark.parametrize("shape", SHAPES)
def test_png_round_trip_within_half_a_step(bits, shape):
    rng = np.random.default_rng(bits * 100 + len(shape))
    values = rng.random(shape)
    values.flat[:4] = [0.0, 1.0, 0.5, 1.0 / ((1 << bits) - 1)]
    data = encode_png(values, bits)
    decoded = decode(data)
    assert decoded.shape == shape
    assert decoded.dtype == (np.uint8 if bits == 8 else np.uint16)
    assert _max_error(values, decoded, bits) <= 0.5 / ((1 << bits) - 1) + 1e-12
    assert decoded.flat[0] == 0 and decoded.flat[1] == (1 << bits) - 1


@pytest.mark.parametrize("shape", SHAPES)
def test_png_rows_are_top_down(shape):
    values = np.zeros(shape, dtype=np.float32)
    values[0] = 1.0
    for bits in (8, 16):
        decoded = decode(encode_png(values, bits))
        assert np.all(decoded[0] == (1 << bits) - 1)
        assert np.all(decoded[1:] == 0)


@pytest.mark.parametrize(
    ("shape", "colour"), [((5, 7), 0), ((5, 7, 3), 2), ((5, 7, 4), 6)], ids=["Y", "RGB", "RGBA"]
)
@pytest.mark.parametrize("bits", [8, 16])
def test_png_header_has_the_asked_bit_depth(shape, colour, bits):
    data = encode_png(np.full(shape, 0.25), bits)
    assert _png_header(data) == (7, 5, bits, colour)
    assert data[24] == bits


def test_png_clips_and_maps_nan_to_zero():
    values = np.array([[np.nan, -1.0, 2.0, np.inf, -np.inf, 0.5]], dtype=np.float32)
    assert decode(encode_png(values, 8)).tolist() == [[0, 0, 255, 255, 0, 128]]
    assert decode(encode_png(values, 16)).tolist() == [[0, 0, 65535, 65535, 0, 32768]]


@pytest.mark.parametrize("dtype", [np.float16, np.float32, np.float64])
def test_png_takes_any_float_dtype(dtype):
    values = np.array([[0.0, 0.25, 1.0]], dtype=dtype)
    assert decode(encode_png(values, 16)).tolist() == [[0, 16384, 65535]]


def test_png_passes_integer_codes_through():
    codes8 = np.array([[0, 1, 254, 255]], dtype=np.uint8)
    codes16 = np.array([[0, 1, 65534, 65535]], dtype=np.uint16)
    assert np.array_equal(decode(encode_png(codes8, 8)), codes8)
    assert np.array_equal(decode(encode_png(codes16, 16)), codes16)


@pytest.mark.parametrize(
    ("values", "bits"),
    [
        (np.zeros((2, 2), dtype=np.uint16), 8),
        (np.zeros((2, 2), dtype=np.uint8), 16),
        (np.zeros((2, 2), dtype=np.int32), 8),
        (np.zeros((2, 2), dtype=bool), 8),
        (np.zeros((2, 2)), 12),
        (np.zeros((2, 2, 2)), 8),
        (np.zeros((2, 2, 3, 1)), 8),
        (np.zeros((0, 4)), 8),
    ],
)
def test_png_refuses_what_it_cannot_write(values, bits):
    with pytest.raises(ValueError):
        encode_png(values, bits)


@settings(max_examples=60, deadline=None, database=None)
@given(
    bits=st.sampled_from([8, 16]),
    values=hnp.arrays(
        np.float64,
        st.tuples(st.integers(1, 9), st.integers(1, 9), st.sampled_from([0, 3, 4])).map(
            lambda s: s[:2] if s[2] == 0 else s
        ),
        elements=st.floats(0.0, 1.0),
    ),
)
def test_png_round_trip_property(bits, values):
    decoded = decode(encode_png(values, bits))
    assert decoded.shape == values.shape
    assert _max_error(values, decoded, bits) <= 0.5 / ((1 << bits) - 1) + 1e-12


EXR_SPECIALS = [1e-30, 65504.0, -3.5, 0.0, -0.0, 1e-45, 3.0e38, 1.0 / 3.0]


@pytest.mark.parametrize("shape", SHAPES)
def test_exr_round_trip_is_bit_exact(shape):
    rng = np.random.default_rng(len(shape))
    values = (rng.standard_normal(shape) * 100.0).astype(np.float32)
    values.flat[: len(EXR_SPECIALS)] = EXR_SPECIALS
    decoded = decode(encode_exr(values))
    assert decoded.dtype == np.float32
    assert decoded.shape == shape
    assert np.array_equal(decoded.view(np.uint32), values.view(np.uint32))


def test_exr_gradient_and_channel_names():
    import io

    import OpenEXR

    ramp = np.linspace(-2.0, 2.0, 64 * 48 * 3, dtype=np.float32).reshape(64, 48, 3)
    data = encode_exr(ramp)
    assert np.array_equal(decode(data).view(np.uint32), ramp.view(np.uint32))
    with OpenEXR.File(io.BytesIO(data), separate_channels=True) as exr_file:
        assert sorted(exr_file.channels()) == ["B", "G", "R"]
        assert exr_file.header()["compression"] == OpenEXR.ZIP_COMPRESSION
        assert {c.pixels.dtype for c in exr_file.channels().values()} == {np.dtype(np.float32)}
    with OpenEXR.File(io.BytesIO(encode_exr(ramp[..., 0])), separate_channels=True) as exr_file:
        assert list(exr_file.channels()) == ["Y"]
    with OpenEXR.File(io.BytesIO(encode_exr(np.ones((2, 3, 4)))), separate_channels=True) as f:
        assert sorted(f.channels()) == ["A", "B", "G", "R"]


def test_exr_through_a_temporary_file_matches_the_stream(tmp_path, monkeypatch):
    import OpenEXR

    monkeypatch.setattr(images.tempfile, "tempdir", str(tmp_path))
    values = np.linspace(0.0, 1.0, 6 * 5 * 4, dtype=np.float32).reshape(6, 5, 4)
    header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
    with OpenEXR.File(header, {"RGBA": values}) as exr_file:
        data = images._exr_bytes_via_path(exr_file)
    assert data == encode_exr(values)
    assert np.array_equal(images._decode_exr_via_path(data), values)
    assert list(tmp_path.iterdir()) == []


def test_exr_rows_are_top_down():
    values = np.zeros((4, 3), dtype=np.float32)
    values[0] = 7.0
    assert decode(encode_exr(values)).tolist() == values.tolist()


def test_exr_casts_to_float32():
    values = np.array([[0.1, 2.5]], dtype=np.float64)
    assert np.array_equal(decode(encode_exr(values)), values.astype(np.float32))


@pytest.mark.parametrize(
    ("bad", "count"), [([np.nan], 1), ([np.inf, -np.inf], 2), ([1e300, np.nan, 5e39], 3)]
)
def test_exr_refuses_non_finite_values(bad, count):
    values = np.zeros((3, 4), dtype=np.float64)
    values.flat[: len(bad)] = bad
    with pytest.raises(ValueError, match=rf"^{count} of 12 values are not finite"):
        encode_exr(values)


def test_encode_names_the_format_and_extension():
    values = np.full((3, 2, 3), 0.5, dtype=np.float32)
    for fmt in FORMATS:
        data, extension = encode(values, fmt)
        assert extension == (".exr" if fmt == "exr" else ".png")
        assert decode(data).shape == (3, 2, 3)
    assert _png_header(encode(values, "png8")[0])[2] == 8
    assert _png_header(encode(values, "png16")[0])[2] == 16
    with pytest.raises(ValueError, match="png8, png16, exr"):
        encode(values, "tiff")


def test_decode_refuses_other_and_damaged_files():
    with pytest.raises(ValueError, match="not a PNG or OpenEXR"):
        decode(b"GIF89a")
    values = np.random.default_rng(1).random((32, 32, 3))
    for fmt in FORMATS:
        data, _ = encode(values, fmt)
        for cut in (40, len(data) // 2):
            with pytest.raises(ValueError):
                decode(data[:cut])


def test_a_2048_square_rgb_map_encodes_in_every_format():
    values = np.random.default_rng(0).random((2048, 2048, 3), dtype=np.float32)
    for fmt in FORMATS:
        data, _ = encode(values, fmt)
        assert len(data) > 2048 * 2048
    decoded = decode(encode_png(values, 16))
    assert decoded.shape == (2048, 2048, 3)
    assert np.array_equal(decoded, images.quantise(values, 16))


@pytest.mark.parametrize("fmt", FORMATS)
@pytest.mark.parametrize("shape", [(300, 7), (256, 5, 3), (513, 3, 4), (1, 1)])
def test_an_image_encoded_in_bands_is_the_file_encoded_whole(fmt, shape):
    rng = np.random.default_rng(7)
    values = rng.uniform(-0.25, 1.25, shape)  # float64, past [0, 1]: clipping and rounding
    asked = []

    def band(rows: slice) -> np.ndarray:
        asked.append((rows.start, rows.stop))
        return values[rows]

    assert images.encode_bands(band, shape[0], fmt) == encode(values, fmt)
    assert asked[0][0] == 0 and asked[-1][1] == shape[0]
    assert all(stop - start <= images.BAND_ROWS for start, stop in asked)


def test_an_exr_encoded_in_bands_still_refuses_values_beyond_float32():
    values = np.zeros((300, 4))
    values[299, 3] = 1e300
    with pytest.raises(ValueError, match="1 of 1200 values are not finite"):
        images.encode_bands(lambda rows: values[rows], 300, "exr")
