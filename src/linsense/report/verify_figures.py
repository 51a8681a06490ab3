"""The certificate's figure (``linsense tune``): the holds' error against position and load, the
off-nominal plants' errors, the steps and the trajectory (docs/tuning.md, "The certificate")."""

from __future__ import annotations

from pathlib import Path

from matplotlib.figure import Figure

from linsense.verify import criteria as C


def _legend(a) -> None:
    """A small legend, where the panel has labelled lines."""
    if a.get_legend_handles_labels()[0]:
        a.legend(fontsize=7)


def _holds_panel(a, rows: list[dict]) -> None:
    """The holds on the nominal plant: ``|x - target|`` and peak to peak against position, per load."""
    for lf in C.HOLD_LOADS:
        rs = [
            r
            for r in rows
            if r["kind"] == "hold"
            and r["plant"] == "nominal"
            and "err_deg" in r
            and (r["load_n"] > 0) == (lf > 0)
            and (r["load_n"] < 0) == (lf < 0)
        ]
        if not rs:
            continue
        pos = [r["position_deg"] for r in rs]
        (line,) = a.plot(
            pos, [r["err_deg"] for r in rs], "o-", label=f"|x - target|, {rs[0]['load_n']:+.3g} N"
        )
        a.plot(
            pos,
            [r["pp_deg"] for r in rs],
            "x--",
            color=line.get_color(),
            label=f"p-p, {rs[0]['load_n']:+.3g} N",
        )
    a.axhline(C.HOLD_ERR_DEG, color="k", lw=0.8)
    a.axhline(C.HOLD_PP_DEG, color="k", lw=0.8, ls=":")
    a.set(
        title="holds, nominal plant",
        xlabel="position (electrical deg)",
        ylabel="electrical deg",
        yscale="log",
    )
    _legend(a)


def _off_nominal_panel(a, rows: list[dict]) -> None:
    """The holds at no load on the off-nominal plants, with the file's table and the one measured on
    each."""
    for plant in C.OFF_NOMINAL:
        for table, style in (("design", ".-"), ("measured", "s-")):
            rs = [
                r
                for r in rows
                if r["kind"] == "hold" and r["plant"] == plant and "err_deg" in r and r["load_n"] == 0.0
                and r.get("table", "design") == table
            ]
            if rs:
                what = "the file's table" if table == "design" else "table measured on it"
                a.plot([r["position_deg"] for r in rs], [r["err_deg"] for r in rs], style, ms=3,
                       label=f"{plant}, {what}")
    a.axhline(C.OFF_ERR_DEG, color="k", lw=0.8)
    a.axhline(C.HOLD_ERR_DEG, color="k", lw=0.8, ls=":")
    a.set(
        title="holds at no load, off-nominal plants",
        xlabel="position (electrical deg)",
        ylabel="|x - target| (electrical deg)",
        yscale="log",
    )
    _legend(a)


def _steps_panel(a, rows: list[dict]) -> None:
    """The steps and the load step: ``x - target`` against time."""
    for r in rows:
        if r["kind"] in ("step", "load_step") and "trace" in r:
            tr = r["trace"]
            a.plot(tr["t"], tr["x_deg"], label=r["case"])
    a.axhspan(-C.SETTLE_BAND_DEG, C.SETTLE_BAND_DEG, color="0.85")
    traces = [r["trace"]["x_deg"] for r in rows if r["kind"] in ("step", "load_step") and r.get("trace")]
    peak = max((max(abs(v) for v in x) for x in traces if x), default=20.0)
    lim = min(max(20.0, 1.05 * peak), 400.0)
    a.set(title="steps and load step: x - target", xlabel="t (s)", ylabel="electrical deg", ylim=(-lim, lim))
    _legend(a)


def _moves_panel(a, rows: list[dict]) -> None:
    """The moves at v_max: the estimation error against time (the worst out-and-back, the no-load
    one, the reversal and the hold after a move)."""
    shown = [r for r in rows if r["kind"] in ("trajectory", "reversal", "move_hold")
             and r["plant"] == "nominal" and r.get("trace")]
    trajs = [r for r in shown if r["kind"] == "trajectory"]
    worst = max(trajs, key=lambda r: r.get("peak_err_deg", 0.0), default=None)
    # (the worst out-and-back, the no-load one, the reversal and the hold after a move: all nine
    # loads drawn over each other hide each other; every one is in the panel below)
    picked = [r for r in shown if r is worst or (r["kind"] == "trajectory" and r["load_n"] == 0.0)
              or r["kind"] != "trajectory"]
    for r in picked:
        tr = r["trace"]
        what = r["kind"].replace("_", " ") + (" (worst)" if r is worst else "")
        a.plot(tr["t"], tr["err_deg"], lw=0.8, label=f"{what}, {r['load_n']:+.3g} N")
    a.axhspan(-C.TRAJ_PEAK_ERR_DEG, C.TRAJ_PEAK_ERR_DEG, color="0.9")
    a.axhspan(-C.TRAJ_REST_ERR_DEG, C.TRAJ_REST_ERR_DEG, color="0.8")
    a.set(title="moves at v_max: estimation error", xlabel="t (s)", ylabel="electrical deg")
    _legend(a)


def _move_errors_panel(a, rows: list[dict]) -> None:
    """The moves at v_max: the peak estimation error moving and at rest, against load."""
    mv = [r for r in rows if r["kind"] in ("trajectory", "reversal", "move_hold") and r["plant"] == "nominal"
          and "peak_err_deg" in r]
    for kind, mark in (("trajectory", "o"), ("reversal", "^"), ("move_hold", "s")):
        rs = sorted((r for r in mv if r["kind"] == kind), key=lambda r: r["load_n"])
        if rs:
            line = mark + ("-" if len(rs) > 1 else "")
            a.plot([r["load_n"] for r in rs], [r["peak_err_deg"] for r in rs], line,
                   label=f"{kind.replace('_', ' ')}: peak moving")
            a.plot([r["load_n"] for r in rs], [r["est_err_deg"] for r in rs], mark, mfc="none",
                   label=f"{kind.replace('_', ' ')}: at rest")
    a.axhline(C.TRAJ_PEAK_ERR_DEG, color="k", lw=0.8)
    a.axhline(C.TRAJ_REST_ERR_DEG, color="k", lw=0.8, ls=":")
    top = max((r.get("speed_peak_m_s", 0.0) for r in mv), default=0.0)
    a.set(title=f"moves at v_max (reached {top:.3g} m/s): |estimation error| against load",
          xlabel="load opposing + motion (N)", ylabel="electrical deg")
    _legend(a)


def _tables_panel(a, calibrations: dict | None) -> None:
    """The compensation tables measured on the off-nominal plants, beside the plants' own and the
    motor file's."""
    for i, (plant, cal) in enumerate((calibrations or {}).items()):
        th = cal["theta_deg"]
        color = f"C{i}"
        what = (f"measured ({cal['max_diff_deg']:.2g} deg off the plant's)" if cal["completed"] else
                f"DID NOT COMPLETE ({cal['points_done']} of {cal['points']} points, {cal['fault']})")
        a.plot(th, [float("nan") if v is None else v for v in cal["psi_measured_deg"]], "o", ms=3,
               color=color, label=f"{plant}: {what}")
        a.plot(th, cal["psi_plant_deg"], "-", color=color, lw=0.8, label=f"{plant}: the plant's own")
        if i == 0:
            a.plot(th, cal["psi_file_deg"], "k--", lw=1.0, label="from the motor file")
    a.set(title="compensation table: measured on the off-nominal plants", xlabel="position (electrical deg)",
          ylabel="Psi_LUT (electrical deg)")
    _legend(a)


def certificate_figure(rows: list[dict], title: str, quick: bool = False,
                       calibrations: dict | None = None) -> Figure:
    """Six panels from the certificate's judged runs.

    Parameters
    ----------
    rows : list of dict
        Rows of :func:`linsense.verify.case_runs.judge`.
    title : str
        The figure's title.
    quick : bool, optional
        The off-nominal panels were not run.
    calibrations : dict or None, optional
        The tables measured on the off-nominal plants
        (:func:`linsense.verify.certificate.calibration_summary` by plant).

    Returns
    -------
    matplotlib.figure.Figure
        The figure.
    """
    fig = Figure(figsize=(11, 11.5), layout="constrained")
    ax = fig.subplots(3, 2)
    fig.suptitle(title)
    for a, panel in ((ax[0, 0], _holds_panel), (ax[0, 1], _off_nominal_panel), (ax[1, 0], _steps_panel),
                     (ax[1, 1], _moves_panel), (ax[2, 0], _move_errors_panel)):
        panel(a, rows)
    _tables_panel(ax[2, 1], calibrations)
    _blank_empty(ax, rows, quick)
    return fig


#: faulted runs a blank panel names (a drive whose every hold trips has about 150: the rest counted)
FAULTS_SHOWN = 4


def _blank_empty(ax, rows: list[dict], quick: bool) -> None:
    """A panel with no labelled line says why: not run (a quick certificate runs neither the
    off-nominal plants nor the trajectory), or no trace, with the faults."""
    bad = [f"{r['case']}: {r['why']}" for r in rows if r["fault"] != "none"]
    faulted = "\n".join(bad[:FAULTS_SHOWN] + ([f"... and {len(bad) - FAULTS_SHOWN} more faulted runs (the "
                                                f"certificate's lines and verification.json name them)"]
                                               if len(bad) > FAULTS_SHOWN else []))
    for a in ax.flat:
        if not any(not ln.get_label().startswith("_") for ln in a.lines):
            a.cla()
            a.set_axis_off()
            note = "not run (--quick)" if quick else f"no trace to show\n{faulted}"
            a.text(0.5, 0.5, note, ha="center", va="center", transform=a.transAxes, fontsize=8, wrap=True)


def write_certificate_figure(res, path: str | Path) -> Path:
    """Draw a tuned drive's certificate and save it (the ``figure`` of
    :func:`linsense.verify.tune_output.tune_to`).

    Parameters
    ----------
    res : linsense.verify.tuning.TuneResult
        The result, with its certificate.
    path : str or Path
        The PNG (``<stem>.verification.png``).

    Returns
    -------
    Path
        The file written.
    """
    from linsense.report.figures import save_png

    cert = res.certificate
    fig = certificate_figure(cert.rows, f"{res.motor.name}: {cert.verdict()}", quick=cert.quick,
                             calibrations=cert.extra.get("calibrations"))
    return save_png(fig, path, 100)
