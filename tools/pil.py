"""Processor-in-the-loop replay (``make pil``; docs/firmware.md, "Processor in the loop").

1. record: each case (:data:`CASES`: the Fig. 13 trajectory and a hold in every mode and injection
   shape) is built as ``linsense simulate`` builds it; its drive, as the closed loop starts it, is
   written as C (tools/pil_cgen.py -> build/pil/pil_cases.h), and the closed loop is run by the
   host recorder (csrc/pil/pil_record.c: the simulator with the drive's calls recorded) ->
   build/pil/<case>.in (every ls_drive_step's measurements and every command between them) and
   <case>.sim.out (the outputs of the closed loop's own steps). The recorder's run is checked to end
   where the extension's run of the same scenario ends (steps, faults, final position and speed:
   bit for bit).
2. build the replay (csrc/pil/pil_replay.c) for the host (cc, -O2, -ffp-contract=off as the
   extension, glibc) and for the Cortex-M4F (arm-none-eabi-gcc, the firmware flags of
   tools/check_mcu.sh, at -O2 and in the shipped build (-Os -flto), newlib-nano, with the harness:
   startup_m4.c, pil_io_semihost.c, mps2_an386.ld): :data:`REPLAYS`.
3. run them (the target under ``qemu-system-arm -M mps2-an386`` with semihosting) and compare every
   output of every step: the host replay with the closed loop's own outputs (the recording is
   complete) and both target builds with the host, floats and integers alike (:data:`BOUND`: bit for
   bit). Prints the largest |target - host| per output.

Usage: ``python tools/pil.py [--out DIR] [--quick]``; exit 1 when a comparison fails.
"""

from __future__ import annotations

import argparse
import os
import re
import shutil
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tools"))
PIL = ROOT / "csrc" / "pil"
SCEN = ROOT / "src" / "linsense" / "examples" / "scenarios"

#: per step, the words of pil_pack_cmd (csrc/pil/pil.h): name, kind ("f" float bits, "i" int32, "u" uint32)
OUT_FIELDS = [("duty_a", "f"), ("duty_b", "f"), ("duty_c", "f"), ("enable", "u"), ("fault", "u"),
              ("mode", "u"), ("pos_fb.period", "i"), ("pos_fb.theta", "f"), ("pos_est.period", "i"),
              ("pos_est.theta", "f"), ("pos_ref.period", "i"), ("pos_ref.theta", "f"), ("v_est", "f"),
              ("v_fb", "f"), ("f_load_est", "f"),
              ("err_sig", "f"), ("err_valid", "u"), ("hf_level", "f"), ("psi_comp", "f"), ("i_d", "f"),
              ("i_q", "f"), ("i_d_ref", "f"), ("i_q_ref", "f"), ("v_d", "f"), ("v_q", "f"), ("v_hf", "f"),
              ("cal_index", "u"), ("cal_done", "u"), ("psi_cal", "f")]
IN_WORDS = 8

#: the host and the target must agree bit for bit on every output of every step (docs/firmware.md,
#: "Processor in the loop": both round every operation as written, -ffp-contract=off, and the
#: library calls no libm function that could round differently: its own ls_exp and ls_sincos,
#: sqrtf and floorf exact on both); any difference fails
BOUND = 0.0


def _hold(name: str, duration: float, mode: str, injection: dict | None = None, **extra) -> tuple:
    data = {"motor": "ecce2010", "scenario": {"name": name, "duration": duration, "seed": 1},
            "inverter": {"fidelity": "switching"}, "control": {"mode": mode},
            "reference": {"type": "hold"}, "initial": {"position_mm": 14.2}}
    if injection:
        data["injection"] = injection
    for sec, vals in extra.items():
        data.setdefault(sec, {}).update(vals)
    return name, data


#: name -> scenario (a file of the examples, or a dict); every mode and injection shape of the
#: drive's step table (csrc/ctrl/ls_drive.c) that a scenario can run, the SPEED column included
def cases(quick: bool = False) -> list[tuple[str, object]]:
    d = 0.1 if quick else 0.2  # s of each hold (3,200 steps at 16 kHz)
    fig13 = ("fig13", {"file": SCEN / "fig13_trajectory_switching.toml",
                       "scenario": {"duration": 0.5 if quick else 3.0}})
    if quick:  # (the first move alone: the scenario checks refuse a waypoint the run never reaches)
        fig13[1]["reference"] = {"waypoints_mm": [40.0]}
    return [
        fig13,
        _hold("sensored", d, "sensored", control={"inject_sensored": False}),
        _hold("sensored_inject", d, "sensored", control={"inject_sensored": True}),
        _hold("lut_elliptical", d, "sensorless_lut"),  # (the default: quadrature 0.9)
        _hold("lut_pulsating", d, "sensorless_lut", {"quadrature": 0.0}),
        _hold("nolut_elliptical", d, "sensorless_nolut"),
        _hold("lut_rotating", d, "sensorless_lut", {"shape": "rotating"}),
        _hold("lut_square", d, "sensorless_lut", {"shape": "square"}),
        _hold("nolut_square", d, "sensorless_nolut", {"shape": "square"}),
        _hold("calibration", d, "calibration"),
        # (the start-up needs the saturated plant: its polarity pulses see nothing on the linear one)
        _hold("startup", 0.5 if quick else 0.6, "startup", saturation={"enabled": True}),
        speed_case(quick),
        commission_case(quick),
    ]


#: the speed case's drive: ecce2010 designed by ``linsense tune --v-max`` for this speed (m/s) and
#: acceleration (m/s^2): its hand-over band (about 0.39-0.77 m/s, the injection off from 0.90 m/s)
#: lies inside the move
SPEED_V, SPEED_A = 1.0, 4.0


def speed_case(quick: bool = False) -> tuple[str, dict]:
    """The whole speed range (``observer.emf``: the step table's SPEED column, ls_drive_speed.c): a
    move at :data:`SPEED_V` designed as ``linsense tune --motor ecce2010 --v-max 1`` designs it
    (:func:`linsense.tune.drive_design.design_drive`, written out by
    :func:`linsense.tune.export.scenario_dict`), against a 20 N load, through the hand-over band up
    to the speed where the injection is off and back (the quick set: the way out alone).

    Parameters
    ----------
    quick : bool, optional
        The way out alone (0.6 s) instead of out and back (1.55 s).

    Returns
    -------
    tuple of (str, dict)
        The case's name and scenario.
    """
    from linsense.model.motor import load_motor
    from linsense.tune.design import DriveData
    from linsense.tune.drive_design import design_drive
    from linsense.tune.export import scenario_dict

    made = design_drive(load_motor("ecce2010"), DriveData(v_max=SPEED_V, a_max=SPEED_A), source="ecce2010",
                        analyse=False, startup=False)
    x0 = 14.2
    base = {"scenario": {"name": "speed", "duration": 0.6 if quick else 1.55, "seed": 1},
            "inverter": {"fidelity": "switching"},
            "reference": {"type": "trajectory", "waypoints_mm": [300.0] if quick else [350.0, x0],
                          "at": 0.02, "v_max": SPEED_V, "a_max": SPEED_A, "dwell": 0.05},
            "initial": {"position_mm": x0, "load_balanced": True},
            "load": {"type": "constant", "force": 20.0}}
    data = scenario_dict(made, motor_ref="ecce2010", base=base)
    if not data.get("observer", {}).get("emf"):
        raise SystemExit("pil: the speed case's design has no EMF observer (observer.emf): it would not run "
                         "the SPEED step")
    return "speed", data


def commission_case(quick: bool = False) -> tuple[str, dict]:
    """LS_MODE_COMMISSION (ls_drive_commission.c): the speed case's drive with the pulsating injection,
    as ``linsense commission`` runs it (:mod:`linsense.studies.commission`: its d-current, learning
    rate, settle and hold times and the ratio's slope), out at ``SPEED_OVER_V_HI`` times the
    hand-over band's top against a 20 N load (learning over the cruise's 180 mm) and, in
    the full set, back.

    Parameters
    ----------
    quick : bool, optional
        The way out alone (0.8 s) instead of out and back (1.6 s).

    Returns
    -------
    tuple of (str, dict)
        The case's name and scenario.
    """
    from linsense.model.motor import load_motor
    from linsense.studies import commission as com

    _, data = speed_case(quick)
    motor = load_motor("ecce2010")
    inj = data["injection"]
    v = com.SPEED_OVER_V_HI * float(data["observer"]["handover_v_hi"])
    x0 = data["initial"]["position_mm"]
    data["scenario"].update(name="commission", duration=0.8 if quick else 1.6)
    data["control"] = {**data.get("control", {}), "mode": "commission"}
    i_d = com.D_SHARE * float(data["controller"]["i_max"])
    data["injection"] = {**inj, "quadrature": 0.0, "d_current": i_d}
    data["reference"].update(waypoints_mm=[450.0] if quick else [450.0, x0], v_max=v)
    slope = com.ratio_slope(motor, float(inj["amplitude"]), float(inj["frequency"]), 0.0)
    data["calibration"] = {"points": 56, "k_int": com.K_INT, "t_hold": com.T_HOLD, "t_settle": com.T_SETTLE,
                           "slope": slope}
    return "commission", data


def _scenario(spec):
    from linsense.scenario.load import as_scenario

    if isinstance(spec, dict) and "file" in spec:
        sc = as_scenario(spec["file"])
        return sc.replace(**{k: v for k, v in spec.items() if k != "file"})
    return as_scenario(spec)


def extension_flags() -> tuple[list[str], list[str]]:
    """The extension's gcc flags from their one home, tools/build_flags.py (``COMPILE_ARGS``: -O3,
    C99, the library without contraction; ``PLANT_ARGS``: the plant with it), as the Makefile's venv
    builds it (with ``NATIVE_ARGS``, its ``LINSENSE_NATIVE=1``): the library's flags and what the
    plant adds."""
    from build_flags import COMPILE_ARGS, NATIVE_ARGS, PLANT_ARGS

    gcc = COMPILE_ARGS["gcc"]
    return [*gcc, *(f for f in NATIVE_ARGS if f not in gcc)], list(PLANT_ARGS["gcc"])


def build_recorder(out: Path) -> Path:
    """The host recorder as a shared object, with the extension's flags (tools/build_flags.py)."""
    lib = out / "pil_record.so"
    srcs = sorted((ROOT / "csrc" / "ctrl").glob("*.c"))
    deps = srcs + list(PIL.glob("*")) + list((ROOT / "csrc" / "sim").glob("*")) + \
        list((ROOT / "csrc" / "include" / "linsense").glob("*.h"))
    if lib.exists() and lib.stat().st_mtime > max(p.stat().st_mtime for p in deps):
        return lib
    cc = os.environ.get("CC", "cc")
    compile_args, plant_args = extension_flags()
    base = [*compile_args, "-fPIC", "-fvisibility=hidden", f"-I{ROOT / 'csrc/include'}"]
    objs = []
    for s in srcs:
        o = out / "rec" / (s.stem + ".o")
        o.parent.mkdir(parents=True, exist_ok=True)
        subprocess.run([cc, *base, "-c", str(s), "-o", str(o)], check=True)
        objs.append(str(o))
    o = out / "rec" / "pil_record.o"
    subprocess.run([cc, *base, *plant_args, f"-I{ROOT / 'csrc/sim'}", f"-I{PIL}", "-c",
                    str(PIL / "pil_record.c"), "-o", str(o)], check=True)
    subprocess.run([cc, "-shared", "-Wl,-Bsymbolic", str(o), *objs, "-lm", "-o", str(lib)], check=True)
    return lib


def record(out: Path, quick: bool) -> list[tuple[str, int]]:
    """Record every case; writes pil_cases.h, <case>.in, <case>.sim.out. Returns (name, steps)."""
    import cffi
    from linsense._ctrl import ffi
    from pil_cgen import DriveWriter

    from linsense.sim.build import build
    from linsense.sim.core import _c_commands, run_closed_loop

    rffi = cffi.FFI()
    rffi.cdef("int pil_record(void *cfg, void *drive, void *cmds, int32_t n_cmds, int64_t n_steps, "
              "void *out, void *res, const char *in_path, const char *out_path);")
    rlib = rffi.dlopen(str(build_recorder(out)))

    def addr(p):
        return rffi.cast("void *", int(ffi.cast("uintptr_t", p)))

    header = ["/* generated by tools/pil.py: the drives of the processor-in-the-loop cases, as the host's",
              " * closed loop starts them (configuration, tables and state) */",
              "#include <math.h>", "#include <stddef.h>", '#include "pil.h"', ""]
    names, done = [], []
    for name, spec in cases(quick):
        b = build(_scenario(spec))
        w = DriveWriter(ffi, f"pil_{name}")
        header.append(w.drive(b.drive.state))
        header.append("")
        names.append(name)
        # the recorder runs a copy (the tables are shared: the calibration writes its own)
        drive = ffi.new("ls_drive *")
        ffi.memmove(drive, b.drive.state, ffi.sizeof("ls_drive"))
        c_cmds, n_cmds = _c_commands(b.commands)
        # (the tables the drive writes are shared with the reference run below: put back after the recorder)
        saved = [(at, ffi.buffer(ffi.cast("float *", at), ffi.sizeof("float") * n)[:])
                 for at, n in w.writable()]
        o = ffi.new("ls_sim_out *")  # (every pointer NULL: nothing recorded; the recorder writes files)
        res = ffi.new("ls_sim_result *")
        st = rlib.pil_record(addr(b.cfg), addr(drive), addr(c_cmds), n_cmds, b.n_steps, addr(o), addr(res),
                             str(out / f"{name}.in").encode(), str(out / f"{name}.sim.out").encode())
        if st != 0:
            raise SystemExit(f"pil: recording {name} failed (status {st})")
        for at, data in saved:
            ffi.memmove(ffi.cast("float *", at), data, len(data))
        ref = run_closed_loop(b.cfg, b.drive.state, b.n_steps, b.commands, signals=["t"])
        mine = (int(res.steps_done), int(res.fault), float(res.x_end), float(res.v_end))
        theirs = (ref.steps_done, ref.fault, ref.x_end, ref.v_end)
        if mine != theirs:
            raise SystemExit(f"pil: {name}: the recorder's closed loop {mine} is not the extension's "
                             f"{theirs} (the recorder is built as the Makefile's venv builds the extension, "
                             "tools/build_flags.py's flags with LINSENSE_NATIVE=1: another build fuses the "
                             "plant's multiply-adds differently)")
        done.append((name, int(res.steps_done)))
    header.append("static const pil_case pil_cases[] = {")
    header += [f'    {{"{n}", &pil_{n}_drive}},' for n in names]
    header.append("};")
    (out / "pil_cases.h").write_text("\n".join(header) + "\n")
    return done


WARN = ["-std=c99", "-Wall", "-Wextra", "-Wpedantic", "-Werror", "-Wdouble-promotion", "-Wshadow"]
#: the firmware flags (compile, link), from their one home: the CMake toolchain file
TOOLCHAIN = ROOT / "csrc" / "cmake" / "arm-none-eabi-m4f.cmake"


def _toolchain_flags(var: str) -> list[str]:
    m = re.search(rf'^set\({var} "([^"]*)"\)$', TOOLCHAIN.read_text(), re.M)
    if m is None:
        raise SystemExit(f"pil: no one-line {var} in {TOOLCHAIN}")
    return m.group(1).split()


ARM, ARM_LINK = _toolchain_flags("CMAKE_C_FLAGS_INIT"), _toolchain_flags("CMAKE_EXE_LINKER_FLAGS_INIT")
#: the shipped build's optimisation (the toolchain file's MinSizeRel: -Os with link-time optimisation)
SHIPPED = " ".join(_toolchain_flags("CMAKE_C_FLAGS_MINSIZEREL_INIT"))


def build_replay(out: Path, tag: str, target: str, opt: str = "-O2", defines: tuple = (),
                 harness_lto: bool = True) -> Path:
    """The replay for the host (-O2 whatever ``opt``) or the Cortex-M4F at ``opt`` (``target`` "host" or
    "m4f"; an ELF for QEMU), each with its own C library; its outputs go to <case>.<tag>.out. With
    ``harness_lto`` False the harness (the replay, its I/O and start-up) is compiled without link-time
    optimisation, the library at ``opt``: the replay's call of ``ls_drive_step`` stays a call, which
    tools/bench_pil.py counts from its entry to its return (an LTO build inlines it otherwise)."""
    srcs = [str(p) for p in sorted((ROOT / "csrc" / "ctrl").glob("*.c"))]
    inc = [f"-I{ROOT / 'csrc/include'}", f"-I{PIL}", f"-I{out}", f'-DPIL_TAG="{tag}"', *defines]
    if target == "host":
        exe = out / f"pil_replay_{tag}"
        subprocess.run([os.environ.get("CC", "cc"), *WARN, "-O2", "-ffp-contract=off", *inc,
                        str(PIL / "pil_replay.c"), str(PIL / "pil_io_host.c"), *srcs, "-lm", "-o", str(exe)],
                       check=True)
        return exe
    exe = out / f"pil_replay_{tag}.elf"
    arm = os.environ.get("ARM_CC", "arm-none-eabi-gcc")
    harness = [str(PIL / s) for s in ("pil_replay.c", "pil_io_semihost.c", "startup_m4.c")]
    if not harness_lto:
        for k, src in enumerate(harness):
            obj = out / f"pil_harness_{tag}_{Path(src).stem}.o"
            subprocess.run([arm, *WARN, *ARM, *opt.split(), "-fno-lto", "-ffp-contract=off", "-DPIL_TARGET",
                            *inc, "-c", src, "-o", str(obj)], check=True)
            harness[k] = str(obj)
    subprocess.run([arm, *WARN, *ARM, *opt.split(), "-ffp-contract=off", "-DPIL_TARGET", *inc, *harness,
                    *srcs, "-nostartfiles", *ARM_LINK, f"-T{PIL / 'mps2_an386.ld'}",
                    f"-Wl,-Map={out / f'pil_replay_{tag}.map'}", "-lm", "-o", str(exe)],
                   check=True)
    return exe


#: the replays: tag -> (target, optimisation); the host's as the extension (glibc), the target's at the
#: firmware flags' -O2 and in the shipped build (:data:`SHIPPED`, the size tools/check_mcu.sh holds to
#: 32 kB; the harness link-time optimised with the library), newlib-nano
REPLAYS = {"host": ("host", "-O2"), "m4f": ("m4f", "-O2"), "m4f_os": ("m4f", SHIPPED)}
#: the target builds, each compared with the host's
TARGETS = [t for t, (target, _) in REPLAYS.items() if target != "host"]


def run_replays(out: Path) -> float:
    """Build and run every replay of :data:`REPLAYS`; the CPU time (s) of the QEMU runs."""
    cpu = 0.0
    for tag, (target, opt) in REPLAYS.items():
        exe = build_replay(out, tag, target, opt)
        c0 = os.times()
        cmd = [str(exe)] if target == "host" else qemu_cmd(exe)
        subprocess.run(cmd, cwd=out, check=True, timeout=600, stdout=subprocess.DEVNULL)
        c1 = os.times()
        if target != "host":
            cpu += c1.children_user - c0.children_user + c1.children_system - c0.children_system
    return cpu


def qemu_cmd(elf: Path, *extra: str) -> list[str]:
    """qemu-system-arm running ``elf`` on mps2-an386 with semihosting (files relative to the cwd)."""
    return ["qemu-system-arm", "-M", "mps2-an386", "-nographic", "-monitor", "none", "-serial", "none",
            "-semihosting-config", "enable=on,target=native", "-kernel", str(elf), *extra]


def read_out(path: Path) -> np.ndarray:
    """A replay's outputs, shape (steps, len(OUT_FIELDS)), as uint32 words."""
    return np.fromfile(path, dtype="<u4").reshape(-1, len(OUT_FIELDS))


def differences(a: np.ndarray, b: np.ndarray) -> dict[str, tuple[float, int]]:
    """Per output: the largest difference between two replays (floats as values: NaN equals NaN;
    integers exactly) and the number of steps that differ at all (bits; NaN payloads aside)."""
    res = {}
    for j, (name, kind) in enumerate(OUT_FIELDS):
        if kind == "f":
            x = a[:, j].view("<f4").astype(np.float64)
            y = b[:, j].view("<f4").astype(np.float64)
            both_nan = np.isnan(x) & np.isnan(y)
            with np.errstate(invalid="ignore"):
                d = np.where(both_nan, 0.0, np.abs(x - y))
            d = np.where(np.isnan(d), np.inf, d)
            n = int(np.count_nonzero((a[:, j] != b[:, j]) & ~both_nan))
        else:
            x = a[:, j].view("<i4").astype(np.int64) if kind == "i" else a[:, j].astype(np.int64)
            y = b[:, j].view("<i4").astype(np.int64) if kind == "i" else b[:, j].astype(np.int64)
            d = np.abs(x - y).astype(np.float64)
            n = int(np.count_nonzero(d))
        res[name] = (float(d.max()) if d.size else 0.0, n)
    return res


def _summary(dif: dict) -> str:
    n = max(n for _, n in dif.values())
    if n == 0:
        return "identical"
    return f"{n} steps differ: " + ", ".join(f"{k} {v:.3g} ({m})" for k, (v, m) in dif.items() if m)


def compare(out: Path, names: list[tuple[str, int]]) -> bool:
    """For every case: the host replay against the closed loop's own steps (the recording is complete)
    and every target build (:data:`TARGETS`) against the host replay, on every output, floats
    included: identical (:data:`BOUND`), else False. Prints each case's verdict and the largest
    |target - host| per output over every case."""
    ok = True
    worst = {n: 0.0 for n, _ in OUT_FIELDS}
    total = 0
    for name, steps in names:
        r = {t: read_out(out / f"{name}.{t}.out") for t in ("sim", *REPLAYS)}
        lens = {t: len(v) for t, v in r.items()}
        if set(lens.values()) != {steps}:
            print(f"pil: {name}: steps per replay {lens}, expected {steps}")
            ok = False
            continue
        total += steps
        if not np.array_equal(r["sim"], r["host"]):
            print(f"pil: {name}: the host replay differs from the closed loop's own steps "
                  f"({_summary(differences(r['sim'], r['host']))}): the recording is incomplete")
            ok = False
        verdicts = []
        for t in TARGETS:
            dif = differences(r["host"], r[t])
            for k, (v, n) in dif.items():
                worst[k] = max(worst[k], v)
                ok &= v <= BOUND and n == 0
            verdicts.append(f"{_summary(dif)} ({REPLAYS[t][1]})")
        modes = sorted({int(m) for m in r["host"][:, 5]})
        print(f"pil: {name:16s} {steps:6d} steps, modes {modes}: target/host " + ", ".join(verdicts))
    print(f"pil: largest |target - host| per output over {total} steps, -O2 and {SHIPPED} (newlib on the "
          "target, glibc on the host): " + ", ".join(f"{k} {v:.3g}" for k, v in worst.items()))
    return ok


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, default=ROOT / "build" / "pil")
    ap.add_argument("--quick", action="store_true", help="shorter cases")
    a = ap.parse_args(argv)
    out = a.out.resolve()
    out.mkdir(parents=True, exist_ok=True)
    if shutil.which("qemu-system-arm") is None:
        print("pil: qemu-system-arm not found (make tools installs it as root)", file=sys.stderr)
        return 1
    t0 = time.process_time()
    names = record(out, a.quick)
    t1 = time.process_time()
    cpu = run_replays(out)
    print(f"pil: {sum(n for _, n in names)} steps in {len(names)} cases recorded ({t1 - t0:.1f} s CPU), "
          f"replayed on the host and on the Cortex-M4F under QEMU ({cpu:.1f} s CPU)")
    ok = compare(out, names)
    print("pil: " + ("PASS" if ok else "FAIL"))
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
