"""The result of one simulation: recorded arrays (SI units), metrics and the scenario."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from linsense.sim.metrics import fault_reason

#: Array attributes of :class:`Result`, in trace order.
ARRAYS = ("t", "x", "x_est", "v", "v_est", "x_ref", "theta_err", "i_abc", "i_dq", "duty", "force",
          "err_sig", "fault")
#: Block statistics of :class:`Result` (None when not recorded): min, max, mean over each sample's block.
BLOCK_ARRAYS = ("x_min", "x_max", "x_mean", "err_min", "err_max", "err_mean", "i_abc_min", "i_abc_max")


@dataclass(eq=False)
class Result:
    """Arrays of one closed-loop run, one sample per recorded PWM period.

    Attributes
    ----------
    t : ndarray
        Time, s.
    x : ndarray
        True position, m.
    x_est : ndarray
        HF observer estimate of the position, m.
    v : ndarray
        True speed, m/s.
    v_est : ndarray
        Estimated speed, m/s.
    x_ref : ndarray
        Reference position, m.
    theta_err : ndarray
        Electrical ``theta_est - theta`` wrapped to [-pi, pi), rad.
    i_abc : ndarray, shape (n, 3)
        True phase currents, A.
    i_dq : ndarray, shape (n, 2)
        True currents in the true dq frame, A.
    duty : ndarray, shape (n, 3)
        Duties applied during the period (NaN in the sample that tripped a fault).
    force : ndarray
        Motor force, N.
    err_sig : ndarray
        Demodulated error, rad.
    fault : ndarray
        uint32 fault bits so far.
    metrics : dict
        See :mod:`linsense.sim.metrics`.
    scenario : Scenario
        The scenario run.
    fault_bits : int
        The fault bits at the end.
    x_min : ndarray or None
        Minimum of the position over each block, m.
    x_max : ndarray or None
        Maximum of the position, m.
    x_mean : ndarray or None
        Mean of the position, m.
    err_min : ndarray or None
        Minimum of the demodulated error over each block, rad.
    err_max : ndarray or None
        Maximum of the demodulated error, rad.
    err_mean : ndarray or None
        Mean of the demodulated error, rad.
    i_abc_min : ndarray or None
        Minimum of each phase current over each block, shape (n, 3), A.
    i_abc_max : ndarray or None
        Maximum of each phase current, shape (n, 3), A.

    Notes
    -----
    The block statistics are the min, max and mean over the ``decimate`` periods each sample opens
    (None when not recorded; recorded in metrics-only runs and whenever ``decimate > 1``). Unlike the
    point values they cannot alias (docs/simulator.md, "Block statistics").
    """

    t: np.ndarray
    x: np.ndarray
    x_est: np.ndarray
    v: np.ndarray
    v_est: np.ndarray
    x_ref: np.ndarray
    theta_err: np.ndarray
    i_abc: np.ndarray
    i_dq: np.ndarray
    duty: np.ndarray
    force: np.ndarray
    err_sig: np.ndarray
    fault: np.ndarray
    metrics: dict = field(default_factory=dict)
    scenario: object = None
    fault_bits: int = 0
    x_min: np.ndarray | None = None
    x_max: np.ndarray | None = None
    x_mean: np.ndarray | None = None
    err_min: np.ndarray | None = None
    err_max: np.ndarray | None = None
    err_mean: np.ndarray | None = None
    i_abc_min: np.ndarray | None = None
    i_abc_max: np.ndarray | None = None

    @property
    def fault_reason(self) -> str:
        """``"none"`` or the fault names, e.g. ``"observer"`` or ``"travel"``."""
        return fault_reason(self.fault_bits)

    @property
    def stable(self) -> bool:
        """Whether the run's metrics call it stable (False without metrics)."""
        return bool(self.metrics.get("stable", False))

    def arrays(self) -> dict[str, np.ndarray]:
        """The recorded arrays by name.

        Returns
        -------
        dict of str to ndarray
            :data:`ARRAYS` by name.
        """
        return {k: getattr(self, k) for k in ARRAYS}

    def blocks(self) -> dict[str, np.ndarray]:
        """The block statistics recorded, by name (empty when none were).

        Returns
        -------
        dict of str to ndarray
            Of :data:`BLOCK_ARRAYS`.
        """
        return {k: getattr(self, k) for k in BLOCK_ARRAYS if getattr(self, k) is not None}

    def to_dataframe(self, blocks: bool = False):
        """A pandas DataFrame, one row per sample, the trace's columns.

        :data:`linsense.sim.trace.COLUMNS`: ``t_s, x_m, ..., i_a_A, i_b_A, i_c_A, i_d_A, i_q_A,
        duty_a, ..., fault``; the same frame as ``pandas.read_parquet`` of the run's
        ``trace.parquet``. Imports pandas.

        Parameters
        ----------
        blocks : bool, optional
            Also the block statistics recorded (``x_min_m, x_max_m, x_mean_m, err_min_rad, err_max_rad,
            err_mean_rad, i_a_min_A, i_b_min_A, i_c_min_A, i_a_max_A, ...``; none when the run kept
            none).

        Returns
        -------
        pandas.DataFrame
            The frame.
        """
        from linsense._extras import require
        from linsense.sim.trace import trace_columns

        pd = require("pandas", extra="parquet", feature="Result.to_dataframe")

        cols = trace_columns(self)
        if blocks:
            units = {"x": "m", "err": "rad"}
            for name, a in self.blocks().items():
                if a.ndim == 2:
                    stat = name.rsplit("_", 1)[1]
                    for k, ph in enumerate("abc"):
                        cols[f"i_{ph}_{stat}_A"] = a[:, k]
                else:
                    cols[f"{name}_{units[name.split('_')[0]]}"] = a
        return pd.DataFrame(cols)

    def __repr__(self) -> str:
        name = getattr(self.scenario, "name", "?")
        return (f"Result({name!r}, {self.t.size} samples, stable={self.stable}, "
                f"fault={self.fault_reason!r})")
