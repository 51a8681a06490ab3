"""Trace files of a run: Parquet (``linsense simulate``'s default), CSV and MATLAB .mat.

One column per signal, SI units, named with the unit: ``t_s, x_m, x_est_m, v_m_s, v_est_m_s,
x_ref_m, theta_err_rad, i_a_A, i_b_A, i_c_A, i_d_A, i_q_A, duty_a, duty_b, duty_c, force_N,
err_sig_rad, fault``. Whole traces of a :class:`~linsense.sim.result.Result` are written atomically
(:func:`linsense.io.write_atomic`); a streamed run (:mod:`linsense.sim.stream`) writes its trace
chunk by chunk through a :class:`TraceWriter` (Parquet: one row group per chunk,
:data:`PARQUET_OPTIONS`; CSV: rows appended), never holding it whole. pyarrow is imported only to
write or read Parquet.
"""

from __future__ import annotations

import io
import json
from pathlib import Path

import numpy as np

from linsense._extras import available, require
from linsense.io import write_atomic, write_atomic_with

#: what needs pyarrow, in the message when it is missing (the parquet extra)
_PARQUET = "the Parquet trace"

#: (column, array name, component or None)
COLUMNS = (
    ("t_s", "t", None), ("x_m", "x", None), ("x_est_m", "x_est", None), ("v_m_s", "v", None),
    ("v_est_m_s", "v_est", None), ("x_ref_m", "x_ref", None), ("theta_err_rad", "theta_err", None),
    ("i_a_A", "i_abc", 0), ("i_b_A", "i_abc", 1), ("i_c_A", "i_abc", 2),
    ("i_d_A", "i_dq", 0), ("i_q_A", "i_dq", 1),
    ("duty_a", "duty", 0), ("duty_b", "duty", 1), ("duty_c", "duty", 2),
    ("force_N", "force", None), ("err_sig_rad", "err_sig", None), ("fault", "fault", None),
)


def trace_columns(result) -> dict[str, np.ndarray]:
    """The trace as ``{column: 1-D array}``.

    Parameters
    ----------
    result : Result or dict
        A :class:`~linsense.sim.result.Result`, or a chunk's ``{array name: array}``.

    Returns
    -------
    dict of str to ndarray
        Columns of :data:`COLUMNS`.
    """
    get = result.__getitem__ if isinstance(result, dict) else (lambda n: getattr(result, n))
    out = {}
    for col, name, k in COLUMNS:
        a = get(name)
        out[col] = a if k is None else a[:, k]
    return out


#: how a Parquet trace is written: pyarrow's defaults (Snappy, statistics) but no dictionary on the
#: float columns (measured values hardly repeat: the dictionary was tried and dropped on every page,
#: 15 ms of CPU per simulated second, 5 times the C loop; without it about 3 ms, and a smaller file);
#: the fault bits, nearly constant, keep theirs
PARQUET_OPTIONS = {"use_dictionary": ["fault"]}

_CSV_FMT = ["%.10g"] * (len(COLUMNS) - 1) + ["%d"]


def _csv_rows(cols: dict[str, np.ndarray], f, header: bool) -> None:
    data = np.column_stack([np.asarray(v, dtype=float) for v in cols.values()])
    np.savetxt(f, data, delimiter=",", header=",".join(cols) if header else "", comments="", fmt=_CSV_FMT)


def trace_csv(result) -> str:
    """CSV text: a header line, then one row per sample (``%.10g``; NaN written as ``nan``).

    Parameters
    ----------
    result : Result or dict
        As :func:`trace_columns`.

    Returns
    -------
    str
        The CSV text.
    """
    buf = io.StringIO()
    _csv_rows(trace_columns(result), buf, True)
    return buf.getvalue()


class TraceWriter:
    """Writes a trace chunk by chunk into an open binary file.

    ``write(arrays)`` per chunk (a chunk's ``{array name: array}``), then ``close()``.

    Parameters
    ----------
    f : binary file
        The open file (its owner closes it).
    fmt : {"parquet", "csv"}
        ``parquet``: one row group per chunk, :data:`PARQUET_OPTIONS`; the file is a valid Parquet
        file only once closed. ``csv``: the header, then the rows of each chunk, as
        :func:`trace_csv`.

    Raises
    ------
    ValueError
        Another ``fmt``.
    """

    def __init__(self, f, fmt: str) -> None:
        if fmt not in ("parquet", "csv"):
            raise ValueError(f"unknown trace format {fmt!r}")
        if fmt == "parquet":  # (before the run starts: refused in one line when pyarrow is missing)
            require("pyarrow.parquet", extra="parquet", feature=_PARQUET)
        self.f, self.fmt, self.rows = f, fmt, 0
        self._pq = None
        self._text = None

    def write(self, arrays: dict[str, np.ndarray]) -> None:
        """Write one chunk.

        Parameters
        ----------
        arrays : dict of str to ndarray
            The chunk's ``{array name: array}``.
        """
        cols = trace_columns(arrays)
        if self.fmt == "parquet":
            import pyarrow as pa
            import pyarrow.parquet as pq

            # (from the buffers: pa.array and pa.table would import pandas, 0.3 s)
            arrays = [pa.Array.from_buffers(pa.from_numpy_dtype(a.dtype), len(a), [None, pa.py_buffer(a)])
                      for a in (np.ascontiguousarray(v) for v in cols.values())]
            table = pa.Table.from_arrays(arrays, names=list(cols))
            if self._pq is None:
                self._pq = pq.ParquetWriter(self.f, table.schema, **PARQUET_OPTIONS)
            self._pq.write_table(table)
        else:
            if self._text is None:
                self._text = io.TextIOWrapper(self.f, encoding="utf-8", newline="\n", write_through=True)
            _csv_rows(cols, self._text, self.rows == 0)
        self.rows += len(cols["t_s"])

    def abort(self) -> None:
        """Let go of the file after a failure (its owner deletes it): nothing more is written."""
        if self._pq is not None:
            try:
                self._pq.close()
            except Exception:  # noqa: BLE001 - the file is being thrown away
                pass
            self._pq = None
        if self._text is not None:
            self._text.detach()
            self._text = None

    def close(self) -> None:
        """Finish the file (Parquet: its footer, with the columns even without a sample).

        The file itself stays open: its owner closes it.
        """
        if self.fmt == "parquet":
            if self._pq is None:  # no sample at all: an empty file with the columns
                self.write({name: np.empty((0, 3) if name in ("i_abc", "duty") else (0, 2) if name == "i_dq"
                                           else 0, dtype=np.uint32 if name == "fault" else float)
                            for _, name, _ in COLUMNS})
            self._pq.close()
        elif self._text is not None:
            self._text.flush()
            self._text.detach()  # (the file itself is its owner's to close)


def read_trace_csv(path: str | Path) -> dict[str, np.ndarray]:
    """Read a trace CSV back as ``{column: array}``.

    Parameters
    ----------
    path : str or Path
        The file.

    Returns
    -------
    dict of str to ndarray
        The columns.
    """
    with open(path, encoding="utf-8") as f:
        header = f.readline().strip().split(",")
    data = np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2)
    return {h: data[:, j] for j, h in enumerate(header)}


def have_parquet() -> bool:
    """Whether pyarrow is installed (the Parquet trace needs it).

    Returns
    -------
    bool
        True when ``import pyarrow`` works.
    """
    return available("pyarrow")


def read_trace(path: str | Path) -> dict[str, np.ndarray]:
    """Read a trace file back (``.parquet`` or ``.csv``) as ``{column: array}``.

    Parameters
    ----------
    path : str or Path
        The file.

    Returns
    -------
    dict of str to ndarray
        The columns.
    """
    if str(path).endswith(".parquet"):
        pq = require("pyarrow.parquet", extra="parquet", feature=_PARQUET)
        t = pq.read_table(path)
        return {c: t.column(c).to_numpy() for c in t.column_names}
    return read_trace_csv(path)


def write_trace(result, path: str | Path, fmt: str = "csv") -> Path:
    """Write the trace of ``result`` as ``csv`` or ``parquet``.

    Parameters
    ----------
    result : Result or dict
        As :func:`trace_columns`.
    path : str or Path
        The file (written atomically).
    fmt : {"csv", "parquet"}, optional
        The format.

    Returns
    -------
    Path
        The file written.

    Raises
    ------
    ValueError
        Another ``fmt``.
    """
    if fmt == "csv":
        return write_atomic(path, trace_csv(result))
    if fmt == "parquet":
        pa = require("pyarrow", extra="parquet", feature=_PARQUET)
        pq = require("pyarrow.parquet", extra="parquet", feature=_PARQUET)
        table = pa.table(trace_columns(result))
        return write_atomic_with(path, lambda f: pq.write_table(table, f, **PARQUET_OPTIONS))
    raise ValueError(f"unknown trace format {fmt!r}")


#: the .mat file's 116-byte text header (scipy writes the date there): fixed, for byte-reproducible files
MAT_HEADER = b"MATLAB 5.0 MAT-file, written by linsense".ljust(116, b" ")


#: trace samples ``linsense simulate --mat`` accepts: the .mat file is written from the whole trace
#: held in memory (144 B per sample, plus scipy's copy while it writes)
MAT_MAX_SAMPLES = 1_000_000


def write_mat(result, path: str | Path, metrics: dict | None = None) -> Path:
    """MATLAB .mat (v5): one variable per column plus ``metrics_json``.

    ``metrics_json`` holds the metrics as JSON text, without the wall-clock ones
    (:data:`linsense.io.TIMING_KEYS`). Byte-reproducible: the header carries no date.

    Parameters
    ----------
    result : Result or dict
        A :class:`~linsense.sim.result.Result`, or the trace's columns ``{column: array}`` with
        ``metrics``.
    path : str or Path
        The file (written atomically).
    metrics : dict or None, optional
        The metrics, with columns for ``result``.

    Returns
    -------
    Path
        The file written.
    """
    from scipy.io import savemat

    from linsense.io import split_timing

    cols = result if metrics is not None else trace_columns(result)
    data = {k: np.asarray(v, dtype=float) for k, v in cols.items()}
    data["metrics_json"] = json.dumps(split_timing(result.metrics if metrics is None else metrics)[0])

    def writer(f):
        buf = io.BytesIO()
        savemat(buf, data, do_compression=True, oned_as="column")
        f.write(MAT_HEADER + buf.getvalue()[len(MAT_HEADER):])

    return write_atomic_with(path, writer)
