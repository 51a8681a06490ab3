#!/usr/bin/env python3
"""Write the seed corpus of csrc/tests/fuzz_drive.c (csrc/tests/fuzz_corpus/): small inputs that
reach each operation, mode and class of hostile value; libFuzzer mutates from there.

The byte format is documented at the top of fuzz_drive.c; FIELDS below follows its FIELDS list.
Run from the repository root: python3 tools/fuzz_seeds.py
"""

import pathlib
import struct

FIELDS = (
    "fs pole_pitch force_constant i_max delay_comp enc_v_max inject.amplitude inject.freq "
    "inject.ramp_rate inject.quad bpf.f0 bpf.q sep.f0 sep.q demod.f_lpf demod.gain demod.min_level "
    "demod.f_notch obs.k1 obs.k2 obs.k3 obs.pole_pitch obs.mass obs.omega_max obs.force_max "
    "enc_obs.k1 enc_obs.k2 enc_obs.omega_max enc_obs.pole_pitch current.kp current.ki current.l_d "
    "current.l_q current.psi_pm pos.kp_x pos.kd_x pos.v_max pos.speed.kp pos.speed.ki pos.mass "
    "pos.force_max traj.v_max traj.a_max traj.pole_pitch mod.dead_time mod.i_band mod.dtc_lead "
    "dtres.r_s dtres.l_d dtres.l_q prot.i_max prot.v_dc_min prot.v_dc_max prot.err_max prot.err_time "
    "prot.omega_max cal.k_int cal.t_settle cal.t_hold cal.tol cal.t_max cal.dither_amp "
    "cal.dither_freq"
).split()
assert len(FIELDS) == 63
SPECIAL = [0.0, -0.0, 1.0, -1.0, 0.5, 1e-3, 1e-30, -1e-30, 1e6, -1e6, 1e10, -1e10, 1e20, -1e20, 1e30, -1e30,
           3e38, -3e38, 1e-38, 1.4e-45, 1e300, -1e300, 16000.0, 72.0, 2147483647.0, -2147483648.0, 4.3e9,
           1.6777216e7, 8.0e6, 0.056, 100.0, 1e4]
NAN, INF, NINF = bytes([2 | 8]), bytes([2 | 16]), bytes([2])
OFF, SENSORED, LUT, NOLUT, CAL = range(5)


def special(x):
    return bytes([1 | (SPECIAL.index(x) << 3)])


def factor(byte):  # a factor 0.5 + byte / 170 (with a relative override)
    return bytes([4, byte])


def small(v, scale_idx=3):  # v / 128 * 10^(scale_idx - 3), v in [-128, 127]
    return bytes([5 | (scale_idx << 3), v & 0xFF])


def cfg(*overrides):  # (field name or int index, kind, value bytes)
    out = bytes([len(overrides)])
    for name, kind, val in overrides:
        idx = FIELDS.index(name) if isinstance(name, str) else name
        out += bytes([idx, kind]) + val
    return out


def mode(m):
    return bytes([0, m])


def pos(op, period=None, theta=b"\x03\x00", near_end=0):
    if near_end:
        return bytes([op, 2 | (4 if near_end < 0 else 0), 0]) + theta
    if period is None:
        return bytes([op, 3]) + theta
    return bytes([op, 0]) + struct.pack(">i", period) + theta


def steps(n, what=4, meas=b"", x16=True):
    return bytes([7 | (16 if x16 else 0), n, what]) + meas


def enc(count=None, delta=0, valid=True):
    if count is None:
        return bytes([6, 0 if valid else 2, delta & 0xFF])
    return bytes([6, 1 if valid else 3]) + struct.pack(">i", count)


SEEDS = {
    "off": cfg() + steps(10),
    "sensorless_lut": cfg() + mode(LUT) + steps(64),
    "sensorless_nolut_move": cfg() + mode(NOLUT) + steps(4) + pos(2, 0, small(100)) + steps(64),
    "sensored_move": cfg() + mode(SENSORED) + pos(2, 1, small(50)) + steps(64, what=8 | 16),
    "sensored_step": cfg() + mode(SENSORED) + steps(2) + pos(3, -1, small(-50)) + steps(64, what=8),
    "calibration": cfg() + mode(CAL) + steps(255, what=8 | 16),
    "move_huge_theta": cfg() + mode(LUT) + steps(1) + pos(2, None, special(1e30)) + steps(16),
    "move_huge_theta_double": cfg() + mode(LUT) + steps(1) + pos(2, None, special(1e300)) + steps(16),
    "step_huge_period": cfg() + mode(SENSORED) + steps(1) + pos(3, 2**31 - 1) + steps(16),
    "step_min_period": cfg() + mode(SENSORED) + steps(1) + pos(3, -2**31, special(-1e20)) + steps(16),
    "set_position_end": cfg() + pos(1, near_end=1) + mode(LUT) + steps(32),
    "set_position_neg_end": cfg() + pos(1, near_end=-1, theta=special(-1.0)) + mode(NOLUT) + steps(32),
    "set_position_nan": cfg() + pos(1, 0, NAN) + mode(LUT) + steps(8),
    "move_inf": cfg() + mode(LUT) + pos(2, 0, INF) + pos(3, 0, NINF) + steps(8),
    "reset_huge": cfg() + bytes([5, 0]) + struct.pack(">i", 2**31 - 1) + special(3e38) + mode(LUT) + steps(8),
    "set_load": cfg() + mode(LUT) + bytes([4]) + special(1e30) + bytes([4]) + NAN + steps(16),
    "enc_jump_extremes": cfg() + mode(SENSORED) + enc(2**31 - 1) + steps(1, x16=False) + enc(-2**31)
    + steps(1, x16=False) + enc(2**31 - 1) + steps(1, x16=False),
    "enc_invalid": cfg() + mode(SENSORED) + enc(valid=False) + steps(4),
    "enc_coarse": cfg(("enc_v_max", 1, factor(0)), (len(FIELDS), 0, struct.pack(">i", 6))) + mode(SENSORED)
    + enc(2**31 - 1) + steps(4),
    "meas_nan_current": cfg() + mode(LUT) + steps(4, what=0, meas=bytes([255]) + NAN),
    "meas_inf_vdc": cfg() + mode(LUT) + steps(4, what=3, meas=bytes([255]) + INF),
    "meas_big_current": cfg() + mode(SENSORED) + steps(4, what=1, meas=bytes([255]) + special(1e30)),
    "meas_low_vdc": cfg() + mode(NOLUT) + steps(4, what=3, meas=bytes([255]) + special(0.5)),
    "current_kp_huge": cfg(("current.kp", 0, special(1e30))) + mode(LUT) + steps(16),
    "current_gains_max": cfg(("current.kp", 0, special(1e6)), ("current.ki", 0, special(1e10)),
                             ("prot.v_dc_max", 0, special(1e4))) + mode(SENSORED) + steps(16, what=8),
    "obs_gains_huge": cfg(("obs.k1", 0, special(1e30)), ("obs.k2", 0, special(1e30))) + mode(LUT) + steps(8),
    "obs_k1_edge": cfg(("obs.k1", 0, special(16000.0))) + mode(NOLUT) + steps(32),
    "obs_mech": cfg((len(FIELDS) + 3, 1, b"")) + mode(LUT) + steps(32),
    "posctrl_pd": cfg((len(FIELDS) + 4, 1, b""), ("pos.kp_x", 0, special(1e6))) + mode(SENSORED)
    + steps(32, what=8),
    "flags_off": cfg((len(FIELDS) + 5, 0, b"")) + mode(SENSORED) + steps(32, what=8),
    "flags_on": cfg((len(FIELDS) + 5, 31, b"")) + mode(LUT) + steps(32),
    "demod_heterodyne_lowpass": cfg((len(FIELDS) + 6, 4, b"")) + mode(LUT) + steps(32),
    "no_tables": cfg((len(FIELDS) + 7, 7, b"")) + mode(LUT) + mode(CAL) + mode(NOLUT) + steps(8),
    "fs_tiny": cfg(("fs", 0, special(1e-30))) + mode(LUT) + steps(4),
    "fs_big": cfg(("fs", 0, special(8.0e6))) + mode(LUT) + steps(4),
    "fs_double": cfg(("fs", 1, factor(255))) + mode(LUT) + steps(64),
    "pole_pitch_tiny": cfg(("pole_pitch", 0, special(1e-38)), ("traj.pole_pitch", 0, special(1e-38)))
    + mode(SENSORED) + steps(4),
    "vdc_max_huge": cfg(("prot.v_dc_max", 0, special(3e38))) + mode(SENSORED) + steps(4),
    "quad_nan": cfg(("inject.quad", 0, NAN)) + mode(LUT) + steps(4),
    "cal_period_far": cfg((len(FIELDS) + 1, 0, struct.pack(">i", 2**30))) + mode(CAL) + steps(8),
    "demod_gain_huge": cfg(("demod.gain", 0, special(1e20))) + mode(LUT) + steps(64),
    "biquad_q_tiny": cfg(("sep.q", 0, special(1e-30)), ("bpf.q", 0, special(1.4e-45))) + mode(LUT) + steps(8),
    "obs_omega_max_huge": cfg(("obs.omega_max", 0, special(3e38))) + mode(LUT) + steps(8),
}


def main():
    out = pathlib.Path("csrc/tests/fuzz_corpus")
    out.mkdir(parents=True, exist_ok=True)
    for name, data in SEEDS.items():
        (out / f"seed_{name}").write_bytes(data)
    print(f"{len(SEEDS)} seeds in {out}")


if __name__ == "__main__":
    main()
