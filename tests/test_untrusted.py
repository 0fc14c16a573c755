"""Numbers from outside: ASCII digits only, whatever Python's int() and float() would read."""

from __future__ import annotations

import math

import pytest
from hypothesis import given
from hypothesis import strategies as st

from sand_editor.untrusted import integer, number

OTHER_DIGITS = st.characters(categories=["Nd"]).filter(lambda c: not c.isascii())


@given(st.text(max_size=12) | st.text(alphabet="0123456789+-._eE ", max_size=12))
def test_what_is_read_is_ascii_and_reads_as_python_would(text):
    for parse, python in ((integer, int), (number, float)):
        try:
            value = parse(text)
        except ValueError:
            continue
        assert text.isascii() and text.strip() == text and "_" not in text
        expected = python(text)
        assert value == expected or (math.isnan(value) and math.isnan(expected))


@given(st.integers(min_value=-(10**38), max_value=10**38), st.floats())
def test_what_python_writes_is_read_back(whole, real):
    assert integer(str(whole)) == whole
    assert number(repr(real)) == real or (math.isnan(real) and math.isnan(number(repr(real))))


@given(OTHER_DIGITS, st.text(alphabet="0123456789", max_size=3))
def test_other_scripts_digits_are_refused(digit, ascii_digits):
    text = ascii_digits + digit
    assert int(text) >= 0  # what Python itself would accept
    for parse in (integer, number):
        with pytest.raises(ValueError, match="digits 0-9"):
            parse(text)


@pytest.mark.parametrize("text", ["1_000", " 12", "12\n", "0x10", "١٢", "1" * 41, "", "+"])
def test_spellings_int_accepts_or_too_long_are_refused(text):
    with pytest.raises(ValueError):
        integer(text)
