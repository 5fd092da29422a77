"""Telemetry as typed Arrow tables: Parquet files, written in row groups with flat memory.

The columns are the telemetry's :data:`~lanefinder.telemetry.FIELDS`, with the same names as
in CSV and JSON Lines, and typed: ``frame`` and ``misses`` int64, ``state`` string, the
``*_found``/``*_inferred`` flags bool, the other numbers float64 (null where missing), and the
list fields typed lists (``h_samples`` list<int32>, the fits and x lists list<float64>).
In a fleet dataset the video is the partition key (``telemetry/video=<id>/``).
"""

from __future__ import annotations

import contextlib
from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import Any

import pyarrow as pa
import pyarrow.parquet as pq

from .errors import LaneFinderError
from .telemetry import BOOL_FIELDS, FIELDS, LIST_FIELDS, TEXT_FIELDS

__all__ = ["ROW_GROUP_ROWS", "ParquetRowWriter", "read_parquet_rows", "rows_to_table", "telemetry_schema"]

#: Rows buffered before a row group is written: memory stays flat over any length of video.
ROW_GROUP_ROWS = 2048


def _field_type(name: str) -> pa.DataType:
    if name in ("frame", "misses"):
        return pa.int64()
    if name in TEXT_FIELDS:
        return pa.string()
    if name in BOOL_FIELDS:
        return pa.bool_()
    if name == "h_samples":
        return pa.list_(pa.int32())
    if name in LIST_FIELDS:
        return pa.list_(pa.float64())
    return pa.float64()


def telemetry_schema() -> pa.Schema:
    """Return the Arrow schema of telemetry rows.

    Returns
    -------
    pyarrow.Schema
        One field per column, typed as the module docstring says.

    Examples
    --------
    >>> s = telemetry_schema()
    >>> str(s.field("frame").type), str(s.field("left_x").type), str(s.field("h_samples").type)
    ('int64', 'list<item: double>', 'list<item: int32>')
    """
    return pa.schema([pa.field(name, _field_type(name)) for name in FIELDS])


def rows_to_table(rows: Iterable[Mapping[str, Any]], schema: pa.Schema | None = None) -> pa.Table:
    """Build a typed table from telemetry rows.

    Parameters
    ----------
    rows : iterable of mapping
        Telemetry rows (as :func:`lanefinder.telemetry.make_row` gives them); a missing key
        is null.
    schema : pyarrow.Schema, optional
        The schema (default :func:`telemetry_schema`).

    Returns
    -------
    pyarrow.Table
        One row per input row.

    Raises
    ------
    LaneFinderError
        When a value does not fit its column's type.

    Examples
    --------
    >>> t = rows_to_table([{"frame": 3, "state": "lost", "offset_m": None}])
    >>> t.num_rows, t.column("frame").to_pylist(), t.column("offset_m").to_pylist()
    (1, [3], [None])
    """
    schema = schema or telemetry_schema()
    rows = list(rows)
    try:
        return pa.table({f.name: pa.array([r.get(f.name) for r in rows], type=f.type) for f in schema}, schema=schema)
    except (pa.ArrowInvalid, pa.ArrowTypeError, TypeError, OverflowError) as e:
        raise LaneFinderError(f"telemetry value does not fit its column: {e}") from None


class ParquetRowWriter:
    """Append telemetry rows to a Parquet file, one row group every :data:`ROW_GROUP_ROWS` rows.

    The file is complete (readable) only after :meth:`close`; callers write it to a hidden
    path and put it in place afterwards (see :class:`lanefinder.io.OutputSet`).

    Parameters
    ----------
    path : str or Path
        The file to write (any writable file-like path).
    schema : pyarrow.Schema, optional
        The schema (default :func:`telemetry_schema`).

    Examples
    --------
    >>> import tempfile
    >>> with tempfile.TemporaryDirectory() as d:
    ...     w = ParquetRowWriter(f"{d}/t.parquet")
    ...     w.write({"frame": 0, "state": "lost"})
    ...     w.close()
    ...     read_parquet_rows(f"{d}/t.parquet")[0]["state"]
    'lost'
    """

    def __init__(self, path: str | Path, schema: pa.Schema | None = None):
        self.schema = schema or telemetry_schema()
        self._rows: list[Mapping[str, Any]] = []
        self._writer = pq.ParquetWriter(str(path), self.schema, compression="zstd")
        self.rows = 0

    def write(self, row: Mapping[str, Any]) -> None:
        """Append one row (written out with its row group).

        Parameters
        ----------
        row : mapping
            A telemetry row.
        """
        self._rows.append(row)
        self.rows += 1
        if len(self._rows) >= ROW_GROUP_ROWS:
            self.flush()

    def flush(self) -> None:
        """Write the buffered rows as a row group."""
        if self._rows:
            self._writer.write_table(rows_to_table(self._rows, self.schema))
            self._rows = []

    def close(self) -> None:
        """Write what is buffered and the file's footer."""
        self.flush()
        self._writer.close()

    def abort(self) -> None:
        """Close the file without writing what is buffered (the caller removes it)."""
        self._rows = []
        with contextlib.suppress(OSError, pa.ArrowException):
            self._writer.close()


def read_parquet_rows(path: str | Path) -> list[dict]:
    """Read telemetry rows back from a Parquet file.

    Parameters
    ----------
    path : str or Path
        A file written by ``--telemetry FILE.parquet``.

    Returns
    -------
    list of dict
        One dict per row, typed values (lists as lists, nulls as None).

    Raises
    ------
    LaneFinderError
        When the file is not Parquet.

    Examples
    --------
    >>> import tempfile
    >>> with tempfile.TemporaryDirectory() as d:
    ...     pq.write_table(rows_to_table([{"frame": 1, "left_x": [1.5, -2.0]}]), f"{d}/t.parquet")
    ...     read_parquet_rows(f"{d}/t.parquet")[0]["left_x"]
    [1.5, -2.0]
    """
    try:
        return pq.read_table(str(path)).to_pylist()
    except (OSError, pa.ArrowException) as e:
        raise LaneFinderError(f"{path}: not a Parquet telemetry file ({e})") from None
