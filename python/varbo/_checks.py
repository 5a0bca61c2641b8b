"""Argument checks of the Python layer (red-team pass py11, docs/python.md): a wrong type or value is a TypeError
or a ValueError (InputError) that names the argument and the expected form, before anything reaches C++ — so no
pybind11 "incompatible function arguments" text, no silent float("1.5") or int(2.5), no OverflowError."""
from __future__ import annotations

import math
import numbers
import os
from typing import Any, Optional

import numpy as np

INT64_MAX = 2 ** 63 - 1
UINT64_MAX = 2 ** 64 - 1


def _input_error(msg: str) -> Exception:
    from ._varbo import InputError
    return InputError(msg)


def _type_name(v: Any) -> str:
    return type(v).__name__


def integer(v: Any, what: str, low: int = 0, high: int = INT64_MAX) -> int:
    """An int (Python or NumPy integer, not bool) in [low, high]."""
    if isinstance(v, (bool, np.bool_)) or not isinstance(v, (numbers.Integral, np.integer)):
        raise TypeError(f"{what}: expected an int, got {v!r} (type {_type_name(v)})")
    i = int(v)
    if not low <= i <= high:
        raise _input_error(f"{what}: expected an int in [{low}, {high}], got {i}")
    return i


def optional_integer(v: Any, what: str, low: int = 0, high: int = INT64_MAX) -> Optional[int]:
    return None if v is None else integer(v, what, low, high)


def real(v: Any, what: str, finite: bool = False) -> float:
    """A real number (int, float, NumPy scalar or a one-element array), not bool, str or complex."""
    if isinstance(v, np.ndarray) and v.size == 1 and v.dtype.kind in "iuf":
        v = v.reshape(()).item()
    if isinstance(v, (bool, np.bool_)) or not isinstance(v, (numbers.Real, np.integer, np.floating)):
        raise TypeError(f"{what}: expected a number, got {v!r:.80} (type {_type_name(v)})")
    try:
        x = float(v)
    except OverflowError:
        raise _input_error(f"{what}: {v!r:.40} is too large for a float") from None
    if finite and not math.isfinite(x):
        raise _input_error(f"{what}: expected a finite number, got {x}")
    return x


def float_array(v: Any, what: str) -> np.ndarray:
    """np.asarray(v, dtype=float) with a ValueError that names the argument (strings, objects, ragged lists)."""
    if isinstance(v, (str, bytes)):
        raise TypeError(f"{what}: expected an array of numbers, got a {_type_name(v)}")
    # What np.asarray(v, dtype=float) turns into numbers without a word (red team, session 30): a masked array's
    # hidden values, booleans, strings ("0.1"), complex numbers (their imaginary part dropped).
    if isinstance(v, np.ma.MaskedArray) and np.ma.is_masked(v):
        raise _input_error(f"{what}: a masked array with masked values; give the values to use (e.g. .filled())")
    try:
        raw = np.asarray(v)
    except (TypeError, ValueError) as e:
        raise _input_error(f"{what}: expected an array of numbers ({e})") from None
    kinds = {"b": "booleans", "U": "strings", "S": "bytes", "c": "complex numbers"}
    if raw.dtype.kind in kinds:
        raise _input_error(f"{what}: expected an array of numbers, got {kinds[raw.dtype.kind]}")
    try:
        with np.errstate(all="ignore"):
            a = np.asarray(v, dtype=float)
    except (TypeError, ValueError, OverflowError) as e:
        raise _input_error(f"{what}: expected an array of numbers ({e})") from None
    return a


def text(v: Any, what: str) -> str:
    """A str that can be written as UTF-8: a lone surrogate (os.fsdecode of a byte that is not UTF-8) gave
    pybind11's "incompatible function arguments" (red team, session 31)."""
    if not isinstance(v, str):
        raise TypeError(f"{what}: expected a str, got {_type_name(v)}")
    try:
        v.encode("utf-8")
    except UnicodeEncodeError:
        raise _input_error(f"{what}: {ascii(v):.80} is not valid text (it holds a lone surrogate, e.g. from "
                           "os.fsdecode of a byte that is not UTF-8)") from None
    return v


def path(v: Any, what: str) -> str:
    """A filesystem path or URL (str or os.PathLike)."""
    if not isinstance(v, (str, os.PathLike)):
        raise TypeError(f"{what}: expected a path or URL (str or os.PathLike), got {v!r:.60} (type {_type_name(v)})")
    p = os.fspath(v)
    if isinstance(p, bytes):
        p = os.fsdecode(p)
    if not p:
        raise _input_error(f"{what}: the path is empty")
    try:
        p.encode("utf-8")
    except UnicodeEncodeError:  # bytes that are not UTF-8 (os.fsdecode's surrogates): pybind11's raw TypeError
        raise _input_error(f"{what}: the path {p!r:.80} is not UTF-8 text; the study records its paths as UTF-8: "
                           f"rename the file or folder") from None
    if "\0" in p:  # C++ would read the path only up to it: a study or folder of another name (red team, session 27)
        raise _input_error(f"{what}: the path {p!r:.80} contains a NUL character")
    return p


def flag(v: Any, what: str) -> bool:
    """A yes/no argument: bool, NumPy bool or an int (0/1); not a str ("no" would be true)."""
    if isinstance(v, (bool, np.bool_, numbers.Integral, np.integer)):
        return bool(v)
    raise TypeError(f"{what}: expected True or False, got {v!r:.60} (type {_type_name(v)})")
