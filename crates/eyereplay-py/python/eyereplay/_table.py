"""Numeric CSV tables (extraction, session and truth files) as numpy
structured arrays, and as pandas DataFrames when pandas is installed."""

from __future__ import annotations

import csv
import io
import os
from typing import Union

import numpy as np

# Columns that hold counts or flags; every other column is float64, with an
# empty field (a frame without a face, say) read as NaN.
INTEGER_COLUMNS = frozenset({"frame", "valid", "blink", "face"})
_FLAGS = {"": 0, "0": 0, "1": 1, "false": 0, "true": 1}


def parse_csv(text: str, source: str = "<csv>") -> np.ndarray:
    """A numeric CSV with a header line as a structured array, one field per
    column (int64 for frame/valid/blink/face, float64 otherwise)."""
    rows = list(csv.reader(io.StringIO(text)))
    if not rows:
        raise ValueError(f"{source}: empty file (no header line)")
    names = [n.strip() for n in rows[0]]
    body = [r for r in rows[1:] if r]
    dtype = [(n, np.int64 if n in INTEGER_COLUMNS else np.float64) for n in names]
    out = np.empty(len(body), dtype=dtype)
    for j, name in enumerate(names):
        col = [r[j].strip() if j < len(r) else "" for r in body]
        try:
            if name in INTEGER_COLUMNS:
                out[name] = [_FLAGS[v.lower()] if v.lower() in _FLAGS else int(v) for v in col]
            else:
                out[name] = [float(v) if v else np.nan for v in col]
        except ValueError as e:
            raise ValueError(f"{source}: column '{name}': {e}") from None
    return out


def read_csv(path: Union[str, os.PathLike]) -> np.ndarray:
    """:func:`parse_csv` on a file."""
    # utf-8-sig: a byte-order mark (spreadsheets write one) is no column's.
    with open(path, encoding="utf-8-sig") as f:
        try:
            text = f.read()
        except UnicodeDecodeError:
            raise ValueError(
                f"{os.fspath(path)}: not text (a video or other binary file?); expected a CSV"
            ) from None
    return parse_csv(text, os.fspath(path))


def to_pandas(table: np.ndarray):
    """A structured array as a pandas DataFrame (same columns and dtypes)."""
    try:
        import pandas as pd
    except ImportError:
        raise ImportError(
            "pandas is not installed: pip install pandas (or use the numpy array as it is)"
        ) from None
    return pd.DataFrame({name: table[name] for name in table.dtype.names})
