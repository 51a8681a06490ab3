"""``linsense reproduce``: the paper's Section V regenerated, claim by claim, into one output set with
``metrics.json`` and a self-contained ``report.html`` (docs/reproduce.md).

Stages: the model (tables, LUT files, Figs. 5, 6, 8a, 8b), Fig. 9 (the calibration at 0, 20 and
40 N), Figs. 11 and 12 (3 mm and 6 mm steps with and without the LUT, and the 6 mm step without
the LUT and without dead time), Fig. 13 (the trajectory), and beyond the paper the hold study
(bias of eq. 12 against the table with R_s, and the dead time's effect) and the stability map on
the sweep engine, the rotating-vector variant of Figs. 11-13 (its own table psi_rot) and the
magnet-polarity start-up from random positions on the saturated plant. Closed-loop runs are on the
switching inverter with 0.8 us dead time.
"""

from __future__ import annotations

import json
import time
from contextlib import contextmanager
from pathlib import Path

import numpy as np

from linsense._extras import available, require_extras
from linsense.reproduce import paper_runs
from linsense.reproduce.claims import STARTUP_MOTION_MM, claims, claims_beyond, finite_or_none

#: positions of the calibration and of the hold study, full and --quick
CAL_POSITIONS = {False: 56, True: 14}
HOLD_POSITIONS = {False: 16, True: 8}
#: random start positions of the start-up study, full and --quick
STARTUP_STARTS = {False: 24, True: 12}


@contextmanager
def _stages(enabled: bool):
    """A rich progress display with one bar per stage (or nothing)."""
    if not enabled or not available("rich"):  # (rich comes with the report and sweep extras)
        yield None
        return
    from rich.console import Console
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

    with Progress(TextColumn("{task.description:<34}"), BarColumn(), MofNCompleteColumn(),
                  TimeElapsedColumn(), console=Console(stderr=True)) as p:
        yield p


class _Stage:
    def __init__(self, progress, name: str, total: int) -> None:
        self.p = progress
        self.task = progress.add_task(name, total=total) if progress is not None else None

    def tick(self) -> None:
        if self.p is not None:
            self.p.advance(self.task)


def _reach_deg(motor, res) -> float | None:
    """The farthest true electrical angle a run reaches (deg; the block maxima, so nothing between
    samples is missed)."""
    x = res.x_max if res.x_max is not None else res.x
    x = x[np.isfinite(x)]
    return float(np.max(x) * 360.0 / motor.pole_pitch) if x.size else None


def _onset(motor, res6, res3) -> dict:
    """Where the uncompensated drive loses stability: how far the 6 mm run (``res6``) and the 3 mm
    run (``res3``) reach, and the peak of the loop-gain factor ``1 + de*/dtheta`` nearest the 6 mm
    run's reach (the factor repeats every 180 deg, so its two equal peaks are told apart by
    where the run is, not by rounding)."""
    from linsense.analysis.hf import loop_gain_factor

    th = np.linspace(0.0, np.pi, 1801)  # (one period of the factor)
    g = loop_gain_factor(motor, th)
    k = int(np.argmax(g))
    peak = float(np.degrees(th[k]))
    reach6, reach3 = _reach_deg(motor, res6), _reach_deg(motor, res3)
    if reach6 is not None:
        peak += 180.0 * round((reach6 - peak) / 180.0)
    return {"gain_max": float(g[k]), "gain_peak_deg": peak, "gain_min": float(g.min()),
            "reach6_deg": reach6, "reach3_deg": reach3}


def reproduce(out: str, motor_spec: str = "ecce2010", quick: bool = False, progress: bool = False,
              model_only: bool = False):
    """Run every stage of the reproduction and write the output set (docs/reproduce.md).

    Parameters
    ----------
    out : str
        Output folder.
    motor_spec : str, optional
        Preset or motor file.
    quick : bool, optional
        Fewer calibration and hold positions, start-ups and loop angles, and a coarser stability
        map (``--quick``).
    progress : bool, optional
        Show progress bars.
    model_only : bool, optional
        The model's tables, LUT files and figures alone (no run, no report).

    Returns
    -------
    files : list
        The files written.
    lines : list of str
        The summary: the model, then each claim and whether it holds.

    Raises
    ------
    linsense.errors.InputError
        A bad motor or output folder.
    """
    from linsense.analysis.model_table import model_table, table_to_csv
    from linsense.analysis.summary import summarize
    from linsense.compensation.lut import build_lut, export
    from linsense.io import output_set, safe_name
    from linsense.model.motor import load_motor, names_a_file
    from linsense.report.figures import write_model_figures

    if not model_only:  # (the closed-loop stages run the sweep engine and write report.html)
        require_extras("report", "sweep", feature="the reproduction (linsense reproduce)")
    t_start = time.perf_counter()
    motor = load_motor(motor_spec)
    # the scenarios name the motor: a preset by name, a file by its absolute path
    preset = None if motor_spec == "ecce2010" else motor_spec
    scen_motor = str(Path(motor_spec).resolve()) if names_a_file(motor_spec) else preset
    summ = summarize(motor)
    figs: dict[str, bytes] = {}
    with output_set(out, "reproduce") as st, _stages(progress) as bars:
        # --- the model
        stage = _Stage(bars, "model: tables, LUT, Figs. 5, 6, 8", 2)
        lut_ = build_lut(motor, 360)
        st.write("model.csv", table_to_csv(model_table(motor, 360)))
        st.write("lut.csv", export(lut_, "csv"))
        st.write("lut.json", export(lut_, "json"))
        st.write(f"ls_lut_{safe_name(motor.name)}.h", export(lut_, "c"))
        st.write("summary.json", json.dumps(summ, indent=1) + "\n")
        stage.tick()
        for p in write_model_figures(motor, build_lut(motor, 56), st.path("figures")):
            figs[f"figures/{p.name}"] = p.read_bytes()
        stage.tick()
        if not model_only:
            metrics = _closed_loop(st, bars, motor, scen_motor, summ, quick, figs, t_start)
    model_line = (f"{motor.name}: Psi_LUT peak {summ['psi_lut_peak_deg']:.2f} deg; saliency minima at "
                  f"{', '.join(f'{d:.0f}' for d in summ['saliency_min_at_deg'])} deg; HF current "
                  f"{summ['hf_current_mean_A']:.2f} A; no-LUT error up to "
                  f"{summ['err_nolut_max_deg']:.1f} deg, gain factor "
                  f"{summ['gain_nolut_min']:.2f}..{summ['gain_nolut_max']:.2f}")
    if model_only:
        return st.files, [model_line]
    return st.files, [model_line, *_claim_lines(motor.name, summ, metrics)]


def _claim_lines(name: str, summ: dict, metrics: dict) -> list[str]:
    """The summary's lines of the claims: how many of the paper's hold, each with its verdict, then
    those beyond the paper."""
    held = sum(c["holds"] for c in metrics["claims"])
    lines = [f"{name}: {held} of {len(metrics['claims'])} claims of the paper hold "
             f"(report.html); Psi_LUT peak {summ['psi_lut_peak_deg']:.2f} deg; {metrics['wall_s']:.0f} s"]
    for c in metrics["claims"]:
        verdict = "holds" if c["holds"] else "FAILS"
        lines.append(f"  [{verdict}] {c['claim']}: paper {c['paper']}, ours {c['ours']}")
    held = sum(c["holds"] for c in metrics["claims_beyond"])
    lines.append(f"beyond the paper (the rotating vector, the start-up): {held} of "
                 f"{len(metrics['claims_beyond'])} hold")
    for c in metrics["claims_beyond"]:
        verdict = "holds" if c["holds"] else "FAILS"
        lines.append(f"  [{verdict}] {c['claim']}: {c['paper']}; ours {c['ours']}")
    return lines


def _step_title(fig: str, sc, motor) -> str:
    """A figure's title from its scenario: the step in mm and electrical degrees, the inverter."""
    sp = sc.spec
    step = sp.reference.position_mm - sp.initial.position_mm
    deg = 360.0 * step * 1e-3 / motor.pole_pitch
    return (f"Fig. {fig[3:]}: {step:g} mm ({deg:.1f} electrical deg) position step, {sp.inverter.fidelity} "
            f"inverter, dead time {sp.inverter.dead_time * 1e6:g} µs")


def _trajectory_title(sc) -> str:
    r = sc.spec.reference
    path = " → ".join(f"{w:g}" for w in [sc.spec.initial.position_mm, *r.waypoints_mm])
    return (f"Fig. 13: minimum-time trajectory {path} mm, {r.v_max:g} m/s, {r.a_max:g} m/s², "
            f"{sc.spec.load.force:g} N load, {sc.spec.inverter.fidelity} inverter")


def _map_robustness(df, lut_scenario) -> dict:
    """How the tuned point's neighbourhood fares on the stability map: stable cells per mode, and
    per step size at the tuned observer bandwidth."""
    out = {}
    bw = lut_scenario.spec.observer.bandwidth_hz
    for mode, g in df.groupby("control.mode"):
        stable = g["stable"].fillna(False).astype(bool)
        near = g[np.isclose(g["observer.bandwidth_hz"].astype(float), bw)]
        steps = near["reference.position_mm"].astype(float)
        ok = near["stable"].fillna(False).astype(bool)
        out[mode] = {"stable": int(stable.sum()), "runs": int(len(g)),
                     "at_tuned_bandwidth": {f"{k:g} mm": bool(v) for k, v in zip(steps, ok, strict=True)}}
    return {"tuned_bandwidth_hz": bw, "modes": out}


def _fig9(st, bars, motor, scen_motor, quick: bool, figs: dict) -> dict:
    """Fig. 9: the calibration at three loads (the measured tables into ``st``); its metrics."""
    from linsense.analysis.hf import psi_lut, psi_lut_resistive
    from linsense.report import paper_figures as pf
    from linsense.report.figures import png_bytes
    from linsense.studies.calibrate import lut_csv

    n_cal = CAL_POSITIONS[quick]
    stage = _Stage(bars, f"Fig. 9: calibration, {n_cal} points", len(paper_runs.LOADS_N))
    cals = paper_runs.calibrations(scen_motor or "ecce2010", n_cal, stage.tick)
    f_inj = next(iter(cals.values())).metrics["f_inj_hz"]
    for load, cal in cals.items():
        st.write(f"calibration/lut_{load:g}N.csv", lut_csv(cal))
    base = cals[paper_runs.LOADS_N[0]].psi_measured
    load_diff = [float(np.degrees(np.nanmax(np.abs(c.psi_measured - base)))) for c in cals.values()
                 if np.isfinite(c.psi_measured - base).any()]
    th = np.linspace(0.0, 2.0 * np.pi, 3601)
    fig9 = {
        "model_peak_deg": float(np.degrees(np.max(np.abs(psi_lut(motor, th))))),
        "model_r_s_peak_deg": float(np.degrees(np.max(np.abs(psi_lut_resistive(motor, th, f_inj))))),
        **{f"cal_{load:g}N_max_diff_deg": cal.metrics["max_diff_deg"] for load, cal in cals.items()},
        "load_max_diff_deg": max(load_diff) if load_diff else None,
        "positions": n_cal,
        "calibrations": {f"{load:g}N": cal.metrics for load, cal in cals.items()},
    }
    figs["figures/fig9_calibrated_luts.png"] = png_bytes(pf.fig9_luts(motor, cals, f_inj))
    return fig9


def _figure_runs(st, bars, motor, scen_motor, figs: dict) -> tuple[dict, dict, int]:
    """Figs. 11, 12, 13: the closed-loop runs (their scenarios into ``st``) and their figures;
    ``(results, scenarios, runs per set)``."""
    from linsense.report import paper_figures as pf
    from linsense.report.figures import png_bytes

    n_runs = sum(len(v) for v in paper_runs.FIGURES.values()) + 1
    stage = _Stage(bars, "Figs. 11-13: closed-loop runs", n_runs)
    results, scenarios = paper_runs.figure_runs(scen_motor, stage.tick)
    for fig, variants in scenarios.items():
        for var, sc in variants.items():
            st.write(f"scenarios/{fig}_{var}.toml", _scenario_toml(sc))
    tau = motor.pole_pitch
    figs["figures/fig11_step3.png"] = png_bytes(pf.fig_runs(
        {"a) with the LUT": results["fig11"]["lut"], "b) without the LUT": results["fig11"]["nolut"]},
        tau, _step_title("fig11", scenarios["fig11"]["lut"], motor)))
    figs["figures/fig12_step6.png"] = png_bytes(pf.fig_runs(
        {"a) with the LUT": results["fig12"]["lut"], "b) without the LUT": results["fig12"]["nolut"],
         "c) without the LUT, no dead time": results["fig12"]["nolut_no_dead_time"]},
        tau, _step_title("fig12", scenarios["fig12"]["lut"], motor)))
    return results, scenarios, n_runs


def _fig12_analysis(bars, motor, results: dict, scenarios: dict, quick: bool, figs: dict) -> dict:
    """Fig. 12 analysed: the onset of the run without the LUT and the linearised motion loop along
    the position (with their figures); then Fig. 13's figure."""
    from linsense.report import paper_figures as pf
    from linsense.report.figures import png_bytes
    from linsense.studies.position_margins import margins_along

    tau = motor.pole_pitch
    onset = _onset(motor, results["fig12"]["nolut"], results["fig11"]["nolut"])
    step = 6.0 if quick else 2.0  # (deg between the angles of the linearised loop)
    angles = np.arange(0.0, 360.0, step)
    stage = _Stage(bars, "Fig. 12: the linearised loop", 2 * angles.size)
    along = margins_along(scenarios["fig12"]["nolut"], angles, tick=stage.tick)
    along_lut = margins_along(scenarios["fig12"]["lut"], angles, lut=True, tick=stage.tick)
    linearised = {"worst": along.worst(), "any_unstable": along.any_unstable(),
                  "lut_worst": along_lut.worst(), "lut_any_unstable": along_lut.any_unstable(),
                  "angles_deg_step": step}
    figs["figures/fig12_linearised.png"] = png_bytes(pf.fig_margins(
        along, along_lut, (results["fig12"]["nolut"], tau),
        "The linearised motion loop of the tuning command (linsense.tune.design.loops) along the position:\n"
        "the 6 mm scenarios' gains, without the LUT (solid) and with it (dashed)"))
    figs["figures/fig12_loop_gain.png"] = png_bytes(pf.fig_gain_factor(
        motor, {"6 mm, no LUT": results["fig12"]["nolut"], "3 mm, no LUT": results["fig11"]["nolut"]},
        onset["gain_peak_deg"],
        "Figs. 11/12 without the LUT: the true position's angle and the uncompensated loop-gain "
        "factor 1 + de*/dθ"))
    figs["figures/fig13_trajectory.png"] = png_bytes(pf.fig_runs(
        {"a) with the LUT": results["fig13"]["lut"], "b) without the LUT": results["fig13"]["nolut"]},
        tau, _trajectory_title(scenarios["fig13"]["lut"])))
    return {"onset": onset, "linearised": linearised}


def _rotating(st, bars, motor, scen_motor, n_runs: int, results: dict, scenarios: dict,
              figs: dict) -> dict:
    """The rotating vector: Figs. 11-13 again, beside the pulsating runs (their scenarios into
    ``st`` and ``scenarios``); its metrics."""
    from linsense.report import paper_figures as pf
    from linsense.report.figures import png_bytes

    stage = _Stage(bars, "rotating vector: Figs. 11-13", n_runs)
    rot, rot_sc = paper_runs.rotating_runs(scen_motor, stage.tick)
    for fig, variants in rot_sc.items():
        scenarios[f"rotating_{fig}"] = variants
        for var, sc in variants.items():
            st.write(f"scenarios/rotating_{fig}_{var}.toml", _scenario_toml(sc))
    for fig, name in (("fig11", "fig11_step3"), ("fig12", "fig12_step6"), ("fig13", "fig13_trajectory")):
        title = (_trajectory_title(scenarios["fig13"]["lut"]) if fig == "fig13"
                 else _step_title(fig, scenarios[fig]["lut"], motor))
        figs[f"figures/rotating_{name}.png"] = png_bytes(pf.fig_runs_beside(
            {"a) pulsating, with the LUT": results[fig]["lut"],
             "b) rotating vector, with its table": rot[fig]["lut"],
             "c) pulsating, without the LUT": results[fig]["nolut"],
             "d) rotating vector, without its table": rot[fig]["nolut"]},
            motor.pole_pitch,
            title.replace(f"Fig. {fig[3:]}:",
                          f"Fig. {fig[3:]}, pulsating (the paper's) and rotating-vector injection:", 1)))
    rot_analysis = _rotating_analysis(motor, rot, scenarios["fig11"]["lut"].spec.injection.frequency)
    return {**{fig: {k: r.metrics for k, r in v.items()} for fig, v in rot.items()},
            "analysis": rot_analysis}


def _startup(st, bars, scen_motor, quick: bool, scenarios: dict, figs: dict) -> dict:
    """The magnet polarity at start-up (saturated plant): the worst start's scenario into ``st``
    and ``scenarios``, the figure; its metrics."""
    from linsense.report import paper_figures as pf
    from linsense.report.figures import png_bytes

    n_su = STARTUP_STARTS[quick]
    stage = _Stage(bars, f"start-up: polarity, {n_su} starts", n_su)
    su = paper_runs.startup_study(scen_motor, n_su, stage.tick)
    scenarios["startup"] = {"worst": su.scenario}
    st.write("scenarios/startup_worst.toml", _scenario_toml(su.scenario))
    su_spec = su.scenario.spec
    su_metrics = _startup_metrics(su)
    figs["figures/startup_polarity.png"] = png_bytes(pf.fig_startup(
        su.runs, su.pole_pitch_mm, su_spec.startup.i_min, STARTUP_MOTION_MM,
        f"Magnet polarity at start-up (LS_MODE_STARTUP) from {len(su.runs)} random positions over two "
        "periods:\n"
        f"saturated plant ({su.polarity * 100:g} %/A), {su_spec.inverter.fidelity} inverter with "
        f"{su_spec.inverter.dead_time * 1e6:g} µs dead time, {su_spec.sensors.current_noise * 1e3:g} mA rms "
        f"current noise,\n{su_spec.sensors.adc_bits}-bit ADC, a free frictionless mover without load"))
    return su_metrics


def _beyond(st, bars, motor, scen_motor, quick: bool, lut_scenario, figs: dict) -> dict:
    """Beyond the paper: the hold study and the stability map (a sweep into ``st``), their
    figures; their metrics."""
    from linsense.report import paper_figures as pf
    from linsense.report.figures import png_bytes
    from linsense.report.sweep_figures import stability_map as fig_stability_map

    n_hold = HOLD_POSITIONS[quick]
    stage = _Stage(bars, f"beyond: hold study, {n_hold} positions", 2 * len(paper_runs.HOLD_VARIANTS))
    hold = paper_runs.hold_study(scen_motor, n_hold, stage.tick)
    dt_us = paper_runs.DEAD_TIME * 1e6
    figs["figures/hold_bias.png"] = png_bytes(pf.fig_bias(
        hold.true_deg, hold.bias_deg,
        "Steady estimation error at rest, switching inverter: the LUT of eq. (12) against the LUT\n"
        f"with R_s, and the dead time ({dt_us:g} µs; solid) against none (dashed); pulsating injection",
        motor))
    stage = _Stage(bars, "beyond: stability map (sweep)", 1)
    df, axes, map_line = paper_runs.stability_map(scen_motor, quick, st.path("stability_map"))
    stage.tick()
    figs["figures/stability_map.png"] = png_bytes(fig_stability_map(df, axes))
    return {
        "hold": {"positions_deg": hold.positions_deg.tolist(),
                 "true_deg": {k: [finite_or_none(v) for v in a] for k, a in hold.true_deg.items()},
                 "bias_deg": {k: [finite_or_none(v) for v in a] for k, a in hold.bias_deg.items()},
                 "limit_cycle_max_mm": hold.limit_cycle_mm},
        "stability_map": {"summary": map_line, "runs": len(df), **_map_robustness(df, lut_scenario)},
    }


def _write_results(st, metrics: dict, figs: dict, scenarios: dict, t_start: float) -> None:
    """metrics.json (the claims added to ``metrics``), timing.json, the figures and report.html
    into ``st``; the whole's wall-clock time into ``metrics``."""
    from linsense.io import strip_timing
    from linsense.report.html import render_report

    metrics["claims"] = claims(metrics)
    metrics["claims_beyond"] = claims_beyond(metrics)
    # (the wall-clock times, the runs' and the whole's, go to timing.json: metrics.json and the
    # report are byte-reproducible, docs/cli.md)
    clean, timing = strip_timing(metrics)
    timing = {**(timing or {}), "wall_s": round(time.perf_counter() - t_start, 2)}
    st.write("metrics.json", json.dumps(clean, indent=1, default=_json_default, allow_nan=False) + "\n")
    st.write("timing.json", json.dumps(timing, indent=1, default=_json_default, allow_nan=False) + "\n")
    for name, data in figs.items():
        if not st.path(name).exists():
            st.write(name, data)
    st.write("report.html", render_report(clean, figs, scenarios))
    metrics["wall_s"] = timing["wall_s"]


def _closed_loop(st, bars, motor, scen_motor, summ: dict, quick: bool, figs: dict, t_start: float) -> dict:
    """The stages after the model (Figs. 9, 11-13, beyond the paper) into the output set ``st``:
    the figures, metrics.json and report.html; returns the metrics."""
    fig9 = _fig9(st, bars, motor, scen_motor, quick, figs)
    results, scenarios, n_runs = _figure_runs(st, bars, motor, scen_motor, figs)
    fig12_analysis = _fig12_analysis(bars, motor, results, scenarios, quick, figs)
    rotating = _rotating(st, bars, motor, scen_motor, n_runs, results, scenarios, figs)
    startup = _startup(st, bars, scen_motor, quick, scenarios, figs)
    beyond = _beyond(st, bars, motor, scen_motor, quick, scenarios["fig12"]["lut"], figs)
    lut6 = scenarios["fig12"]["lut"].spec
    metrics = {
        "motor": motor.name,
        "quick": quick,
        "setup": {"fidelity": paper_runs.FIDELITY, "dead_time_s": paper_runs.DEAD_TIME,
                  "f_pwm_hz": lut6.inverter.f_pwm, "v_inj_v": lut6.injection.amplitude,
                  "f_inj_hz": lut6.injection.frequency},
        "lut": {"peak_deg": summ["psi_lut_peak_deg"]},
        "fig9": fig9,
        "fig11": {k: results["fig11"][k].metrics for k in ("lut", "nolut")},
        "fig12": {k: results["fig12"][k].metrics for k in ("lut", "nolut", "nolut_no_dead_time")},
        "fig12_analysis": fig12_analysis,
        "fig13": {k: results["fig13"][k].metrics for k in ("lut", "nolut")},
        "rotating": rotating,
        "startup": startup,
        "beyond": beyond,
    }
    _write_results(st, metrics, figs, scenarios, t_start)
    return metrics


def _rotating_analysis(motor, rot: dict, f_inj: float) -> dict:
    """The rotating runs against the model: the largest |psi_rot|, how far the 6 mm run without the
    table reaches, and per run without the table the mean estimation error over its last 0.3 s
    beside psi_rot at the true position the mover holds there."""
    from linsense.analysis.rotating import psi_rotating

    th = np.linspace(0.0, 2.0 * np.pi, 3601)
    out = {"psi_rot_peak_deg": float(np.degrees(np.max(np.abs(psi_rotating(motor, th, f_inj))))),
           "reach6_deg": _reach_deg(motor, rot["fig12"]["nolut"]), "nolut_vs_model": {}}
    for fig in ("fig11", "fig12", "fig13"):
        r = rot[fig]["nolut"]
        w = (r.t >= r.t[-1] - 0.3) & np.isfinite(r.x) & np.isfinite(r.theta_err)
        if not w.any():
            continue
        true = float(np.mean(r.x[w])) * 2.0 * np.pi / motor.pole_pitch
        out["nolut_vs_model"][fig] = {
            "true_deg": float(np.degrees(true)),
            "error_deg": float(np.degrees(np.mean(r.theta_err[w]))),
            "model_deg": float(np.degrees(psi_rotating(motor, true, f_inj)))}
    return out


def _startup_metrics(su) -> dict:
    """metrics.json's ``startup``: the study's outcome and its runs."""
    rs = su.runs
    sp = su.scenario.spec
    worst = max(rs, key=lambda r: r.motion_mm)
    return {
        "n": len(rs), "right": sum(r.right for r in rs), "faults": sum(r.fault != 0 for r in rs),
        "flips": sum(r.flip for r in rs),
        "motion_max_mm": max(r.motion_mm for r in rs), "worst_x0_mm": worst.x0_mm,
        "motion_after_max_mm": max(r.motion_after_mm for r in rs),
        "detect_s": max(r.detect_s for r in rs), "i_diff_min_a": min(abs(r.i_diff_a) for r in rs),
        "i_min_a": sp.startup.i_min,
        "setup": {"polarity_per_a": su.polarity, "fidelity": sp.inverter.fidelity,
                  "dead_time_s": sp.inverter.dead_time, "current_noise_a": sp.sensors.current_noise,
                  "adc_bits": sp.sensors.adc_bits, "load_n": 0.0, "friction_n": 0.0},
        "runs": [{"x0_mm": r.x0_mm, "right": r.right, "flip": r.flip, "fault": r.fault,
                  "motion_mm": r.motion_mm, "motion_after_mm": finite_or_none(r.motion_after_mm),
                  "i_diff_a": r.i_diff_a, "err_end_deg": r.err_end_deg, "detect_s": r.detect_s} for r in rs],
    }


def _scenario_toml(sc) -> str:
    import tomli_w

    return (f"# {Path(sc.source).name} as run by `linsense reproduce` (the keys it sets; the gains it\n"
            f"# leaves out are designed for the motor). Run it again: linsense simulate THIS_FILE --out DIR\n"
            + tomli_w.dumps(sc.given()))


def _json_default(o):
    if isinstance(o, np.generic):
        return o.item()
    if isinstance(o, np.ndarray):
        return o.tolist()
    raise TypeError(f"not JSON serialisable: {type(o).__name__}")

