"""Trace files of a run: CSV (default), Parquet (only if pyarrow is installed) and MATLAB .mat.

One column per signal, SI units, named with the unit: ``t_s, x_m, x_est_m, v_m_s, v_est_m_s,
x_ref_m, theta_err_rad, i_a_A, i_b_A, i_c_A, i_d_A, i_q_A, duty_a, duty_b, duty_c, force_N,
err_sig_rad, fault``. Written atomically (:func:`linsense.io.write_atomic`).
"""

from __future__ import annotations

import io
import json
from pathlib import Path

import numpy as np

from linsense.io import write_atomic, write_atomic_with

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
    """The trace as ``{column: 1-D array}``."""
    out = {}
    for col, name, k in COLUMNS:
        a = getattr(result, name)
        out[col] = a if k is None else a[:, k]
    return out


def trace_csv(result) -> str:
    """CSV text: a header line, then one row per sample (``%.10g``; NaN written as ``nan``)."""
    cols = trace_columns(result)
    data = np.column_stack([np.asarray(v, dtype=float) for v in cols.values()])
    buf = io.StringIO()
    fmt = ["%.10g"] * (data.shape[1] - 1) + ["%d"]
    np.savetxt(buf, data, delimiter=",", header=",".join(cols), comments="", fmt=fmt)
    return buf.getvalue()


def read_trace_csv(path: str | Path) -> dict[str, np.ndarray]:
    """Read a trace CSV back as ``{column: array}``."""
    with open(path, encoding="utf-8") as f:
        header = f.readline().strip().split(",")
    data = np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2)
    return {h: data[:, j] for j, h in enumerate(header)}


def have_parquet() -> bool:
    try:
        import pyarrow  # noqa: F401
    except ImportError:
        return False
    return True


def write_trace(result, path: str | Path, fmt: str = "csv") -> Path:
    """Write the trace as ``csv`` or ``parquet`` (needs pyarrow, not a linsense dependency)."""
    if fmt == "csv":
        return write_atomic(path, trace_csv(result))
    if fmt == "parquet":
        import pyarrow as pa
        import pyarrow.parquet as pq

        table = pa.table(trace_columns(result))
        return write_atomic_with(path, lambda f: pq.write_table(table, f))
    raise ValueError(f"unknown trace format {fmt!r}")


#: the .mat file's 116-byte text header (scipy writes the date there): fixed, for byte-reproducible files
MAT_HEADER = b"MATLAB 5.0 MAT-file, written by linsense".ljust(116, b" ")


def write_mat(result, path: str | Path) -> Path:
    """MATLAB .mat (v5): one variable per column plus ``metrics_json`` (the metrics as JSON text,
    without the wall-clock ones: :data:`linsense.io.TIMING_KEYS`). Byte-reproducible: the header
    carries no date."""
    from scipy.io import savemat

    from linsense.io import split_timing

    data = {k: np.asarray(v, dtype=float) for k, v in trace_columns(result).items()}
    data["metrics_json"] = json.dumps(split_timing(result.metrics)[0])

    def writer(f):
        buf = io.BytesIO()
        savemat(buf, data, do_compression=True, oned_as="column")
        f.write(MAT_HEADER + buf.getvalue()[len(MAT_HEADER):])

    return write_atomic_with(path, writer)
