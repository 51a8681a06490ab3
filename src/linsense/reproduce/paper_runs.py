"""The closed-loop runs of ``linsense reproduce``: the paper's scenarios (package data, one TOML file
each), the calibration at three loads, the hold study, the stability map, the rotating-vector
variant of Figs. 11-13 and the magnet-polarity start-up (docs/reproduce.md).

Every run is on the switching inverter with the paper's 0.8 us dead time unless its name says
otherwise (``nolut_no_dead_time``): the scenario files set it, and :func:`paper_scenario` refuses a
file that does not.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path

import numpy as np

from linsense.errors import InputError

#: the paper's dead time (s) and inverter model, for every closed-loop claim
DEAD_TIME = 0.8e-6
FIDELITY = "switching"
#: the scenario files of the paper's figures: figure -> variant -> file under scenarios/
FIGURES = {
    "fig11": {"lut": "paper_step3_lut.toml", "nolut": "paper_step3_nolut.toml"},
    "fig12": {"lut": "paper_step6_lut.toml", "nolut": "paper_step6_nolut.toml"},
    "fig13": {"lut": "paper_fig13_lut.toml", "nolut": "paper_fig13_nolut.toml"},
}
#: loads (N) of the calibration (paper Fig. 9: no load and loaded; 20 N per A of q-current)
LOADS_N = (0.0, 20.0, 40.0)
#: the hold study's variants: label -> (scenario sections changed, dead time on)
HOLD_VARIANTS = {
    "LUT with R_s": {},
    "LUT of eq. (12)": {"observer": {"lut_model": "eq12"}},
    "no LUT": {"control": {"mode": "sensorless_nolut"}, "observer": {"lut_model": None}},
    "linsense default drive (elliptical, dead-time residual)": {
        "injection": {"quadrature": None}, "observer": {"bandwidth_hz": None}},
}
#: the rotating-vector variant of a paper scenario: the same drive, gains and estimator settings
#: with the stationary-frame rotating vector (negative-sequence demodulation; its own table
#: psi_rot in sensorless_lut, none in sensorless_nolut) instead of the pulsating injection; like the
#: paper's drive without a d-current (the design's 0.4 i_max, linsense.tune.injection.injection_d_current,
#: would push with a share of its force wherever the estimate is off: the runs without the table are
#: judged against the estimator's model)
ROTATING = {"injection": {"shape": "rotating", "quadrature": None, "d_current": 0.0},
            "observer": {"demod_method": None}}


def data_path(*parts: str) -> Path:
    """A file of the package's reproduction data (scenarios/, sweeps/).

    Parameters
    ----------
    *parts : str
        Path parts below the package, e.g. ``"scenarios", "paper_hold.toml"``.

    Returns
    -------
    Path
        The file.
    """
    return Path(str(resources.files("linsense.reproduce").joinpath(*parts)))


def paper_scenario(name: str, motor: str | None = None):
    """The scenario file ``name`` of scenarios/, checked to be the paper's set-up.

    Switching inverter, 0.8 us dead time.

    Parameters
    ----------
    name : str
        File name in scenarios/.
    motor : str or None, optional
        Replaces the scenario's motor (a preset name or an absolute path).

    Returns
    -------
    Scenario
        The scenario.

    Raises
    ------
    linsense.errors.InputError
        A scenario that is not on the paper's inverter.
    """
    from linsense.scenario.load import load_scenario, scenario_from_dict

    sc = load_scenario(data_path("scenarios", name))
    inv = sc.spec.inverter
    if inv.fidelity != FIDELITY or inv.dead_time != DEAD_TIME:
        raise InputError(sc.source, "inverter", f"the paper's runs are on the {FIDELITY} inverter with "
                         f"{DEAD_TIME * 1e6:g} us dead time, got {inv.fidelity}, {inv.dead_time:g} s")
    if motor is None:
        return sc
    data = sc.given()
    data["motor"] = motor
    return scenario_from_dict(data, sc.source, sc.base_dir)


def with_changes(sc, changes: dict):
    """``sc`` with the sections in ``changes`` updated, validated again.

    Parameters
    ----------
    sc : Scenario
        The scenario.
    changes : dict
        Section to keys; a value None removes the key (back to its default or its designed value).

    Returns
    -------
    Scenario
        The new scenario.
    """
    from linsense.scenario.load import scenario_from_dict

    data = sc.given()
    for sec, vals in changes.items():
        d = data.setdefault(sec, {})
        for k, v in vals.items():
            if v is None:
                d.pop(k, None)
            else:
                d[k] = v
    return scenario_from_dict(data, sc.source, sc.base_dir)


def figure_runs(motor: str | None, tick=lambda: None, changes: dict | None = None,
                prefix: str = "") -> tuple[dict, dict]:
    """The runs of Figs. 11, 12, 13 and Fig. 12's uncompensated run without dead time.

    Traces kept, for the figures.

    Parameters
    ----------
    motor : str or None
        Preset or absolute motor-file path (None: the scenarios' own).
    tick : callable, optional
        Called after each run (progress).
    changes : dict or None, optional
        Sections changed in every scenario (:func:`with_changes`).
    prefix : str, optional
        Before the scenarios' names.

    Returns
    -------
    results : dict
        Figure to variant to Result.
    scenarios : dict
        Figure to variant to Scenario.
    """
    from linsense.sim.simulation import simulate

    results: dict = {}
    scenarios: dict = {}
    for fig, variants in FIGURES.items():
        results[fig], scenarios[fig] = {}, {}
        for var, name in variants.items():
            sc = paper_scenario(name, motor)
            if changes:
                sc = with_changes(sc, {**changes, "scenario": {"name": prefix + sc.spec.scenario.name}})
            scenarios[fig][var] = sc
            results[fig][var] = simulate(with_changes(sc, {"record": {"decimate": 4}}))
            tick()
    name = f"{prefix}paper_step6_nolut_no_dead_time"
    sc = with_changes(scenarios["fig12"]["nolut"],
                      {"inverter": {"dead_time": 0.0}, "scenario": {"name": name}})
    scenarios["fig12"]["nolut_no_dead_time"] = sc
    results["fig12"]["nolut_no_dead_time"] = simulate(with_changes(sc, {"record": {"decimate": 4}}))
    tick()
    return results, scenarios


def rotating_runs(motor: str | None, tick=lambda: None) -> tuple[dict, dict]:
    """:func:`figure_runs` with the rotating vector (:data:`ROTATING`; names prefixed "rotating_").

    Parameters
    ----------
    motor : str or None
        Preset or absolute motor-file path.
    tick : callable, optional
        Called after each run.

    Returns
    -------
    results : dict
        Figure to variant to Result.
    scenarios : dict
        Figure to variant to Scenario.
    """
    return figure_runs(motor, tick, ROTATING, "rotating_")


def calibrations(motor, positions: int, tick=lambda: None) -> dict:
    """The calibration (paper Fig. 9) at each of :data:`LOADS_N`.

    Pulsating injection, switching inverter with dead time.

    Parameters
    ----------
    motor : Motor or str
        The motor.
    positions : int
        Calibration points.
    tick : callable, optional
        Called after each calibration.

    Returns
    -------
    dict
        Load (N) to :class:`~linsense.studies.calibrate.Calibration`.
    """
    from linsense.studies.calibrate import calibrate

    out = {}
    for load in LOADS_N:
        out[load] = calibrate(motor, positions=positions, load=load, fidelity=FIDELITY, quad=0.0,
                              inverter={"dead_time": DEAD_TIME})
        tick()
    return out


@dataclass
class HoldStudy:
    """Steady estimation error at hold positions for each variant, with and without the dead time.

    And the largest limit cycle of each.

    Attributes
    ----------
    positions_deg : ndarray
        The commanded (estimated) hold positions, electrical deg.
    bias_deg : dict
        Label to the bias at each position, electrical deg.
    true_deg : dict
        Label to the true mean angle over the end window, electrical deg.
    limit_cycle_mm : dict
        Label to the largest limit cycle over the positions, mm.
    """

    positions_deg: np.ndarray  # the commanded (estimated) hold positions
    bias_deg: dict = field(default_factory=dict)  # label -> array
    true_deg: dict = field(default_factory=dict)  # label -> the true mean angle over the end window
    limit_cycle_mm: dict = field(default_factory=dict)  # label -> max over positions


def hold_study(motor: str | None, n_positions: int, tick=lambda: None) -> HoldStudy:
    """The hold at ``n_positions`` over one period for :data:`HOLD_VARIANTS` (metrics only).

    Each with the paper's dead time and without.

    Parameters
    ----------
    motor : str or None
        Preset or absolute motor-file path.
    n_positions : int
        Hold positions.
    tick : callable, optional
        Called after each variant.

    Returns
    -------
    HoldStudy
        The biases and limit cycles.
    """
    from linsense.sim.build import resolve_motor
    from linsense.sim.simulation import metrics_only

    base = paper_scenario("paper_hold.toml", motor)
    tau_mm = resolve_motor(base).pole_pitch * 1e3
    pos_mm = tau_mm * np.arange(n_positions) / n_positions
    st = HoldStudy(360.0 * np.arange(n_positions) / n_positions)
    for label, changes in HOLD_VARIANTS.items():
        for dt in (DEAD_TIME, 0.0):
            key = f"{label}, {'dead time' if dt else 'no dead time'}"
            bias, lc, true = [], [], []
            for x in pos_mm:
                sc = with_changes(base, {**changes, "initial": {"position_mm": float(x)},
                                         "inverter": {"dead_time": dt}})
                m = metrics_only(sc)
                bias.append(np.nan if m["bias_deg"] is None else m["bias_deg"])
                lc.append(np.nan if m["limit_cycle_mm"] is None else m["limit_cycle_mm"])
                off = m["final_offset_mm"]  # (the drive holds its estimate: the mover sits beside x)
                true.append(np.nan if off is None else 360.0 * (x + off) / tau_mm)
            st.bias_deg[key] = np.array(bias)
            st.true_deg[key] = np.array(true)
            st.limit_cycle_mm[key] = float(np.nanmax(lc)) if np.isfinite(lc).any() else None
            tick()
    return st


def stability_map(motor: str | None, quick: bool, out: Path):
    """The stability map (step size x observer bandwidth, LUT on/off) on the sweep engine.

    One worker thread per core.

    Parameters
    ----------
    motor : str or None
        Preset or absolute motor-file path (None: the base scenario's).
    quick : bool
        A coarser grid: 3, 6 and 9 mm steps, 3 bandwidths.
    out : Path
        The sweep's folder.

    Returns
    -------
    df : pandas.DataFrame
        The sweep's rows.
    axes : list of str
        The axis keys.
    summary : str
        The summary line.
    """
    from linsense.io import read_toml
    from linsense.sweep import sweep, sweep_from_dict
    from linsense.sweep.study_summary import summary_line

    path = data_path("sweeps", "stability_map.toml")
    data = read_toml(path, "sweep file")
    base = (path.parent / data["sweep"]["scenario"]).resolve()
    if motor is not None:  # (the base scenario with the motor replaced, in scenarios/ beside ``out``)
        import tomli_w

        from linsense.io import write_atomic

        sc = read_toml(base, "scenario file")
        sc["motor"] = motor
        base = out.parent / "scenarios" / "stability_map_base.toml"
        base.parent.mkdir(parents=True, exist_ok=True)
        write_atomic(base, tomli_w.dumps(sc))
    data["sweep"]["scenario"] = str(base)
    if quick:  # (a coarser grid: the paper's 3 and 6 mm and 9 mm, 3 bandwidths)
        for ax in data["axis"]:
            if ax["key"] == "reference.position_mm":
                ax["values"] = [3.0, 6.0, 9.0]
            if ax["key"] == "observer.bandwidth_hz":
                ax["n"] = 3
    spec = sweep_from_dict(data, str(path), path.parent)
    df = sweep(spec, out)
    axes = [a.key for a in spec.spec.axis]
    return df, axes, summary_line("stability-map", df, axes)


@dataclass
class StartupStudy:
    """Start-ups (control.mode = "startup") from random positions over two electrical periods.

    Attributes
    ----------
    runs : list of StartupRun
        One per start (:class:`linsense.studies.startup_runs.StartupRun`).
    pole_pitch_mm : float
        mm.
    scenario : Scenario
        The start with the largest motion while detecting.
    polarity : float
        The saturated plant's polarity signal, 1/A.
    """

    runs: list  # linsense.studies.startup_runs.StartupRun, one per start
    pole_pitch_mm: float
    scenario: object  # the Scenario of the start with the largest motion while detecting
    polarity: float  # 1/A, the saturated plant's


#: the start-up study's saturated plant: ecce2010 at 1.31 %/A (the FEA's thin back iron; the
#: firmware's default pulses are designed for it), 10 mA rms current noise and a 12-bit ADC
STARTUP_POLARITY = 0.0131


def startup_study(motor: str | None, n: int, tick=lambda: None) -> StartupStudy:
    """The magnet-polarity start-up from ``n`` random positions over two electrical periods.

    docs/firmware.md, ``LS_MODE_STARTUP``: the drive's estimate at 0, on the saturated plant, the
    switching inverter with the paper's dead time, a free frictionless mover without load
    (:mod:`linsense.studies.startup_runs`).

    Parameters
    ----------
    motor : str or None
        Preset or absolute motor-file path (None: ecce2010).
    n : int
        Starts.
    tick : callable, optional
        Called after each start.

    Returns
    -------
    StartupStudy
        The runs.
    """
    from linsense.scenario.load import scenario_from_dict
    from linsense.sim.build import resolve_motor
    from linsense.studies.startup_runs import AFTER_S, base_scenario, start_positions, startup_run

    base = base_scenario(motor=motor or "ecce2010", polarity=STARTUP_POLARITY, fidelity=FIDELITY)
    base["inverter"]["dead_time"] = DEAD_TIME
    base["scenario"]["name"] = "startup"
    probe = scenario_from_dict({**base, "initial": {"position_mm": 0.0}})
    tau_mm = resolve_motor(probe).pole_pitch * 1e3
    rs = []
    for k, x in enumerate(start_positions(n, pole_pitch_mm=tau_mm)):
        rs.append(startup_run(base, float(x), 0.0, seed=k + 1))
        tick()
    worst = max(range(len(rs)), key=lambda k: rs[k].motion_mm)
    su = probe.spec.startup  # (the run's duration as startup_run sets it)
    t_max = su.t_lock + su.t_quiet + (2 * su.pairs + 1) * (su.t_pulse + su.t_rest) + su.t_settle + 0.01
    d = {**base, "initial": {"position_mm": rs[worst].x0_mm}, "load": {"force": 0.0},
         "scenario": {**base["scenario"], "seed": worst + 1, "duration": round(t_max + AFTER_S, 6)}}
    return StartupStudy(rs, tau_mm, scenario_from_dict(d, "startup.toml"), STARTUP_POLARITY)
