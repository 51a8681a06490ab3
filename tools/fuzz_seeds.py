#!/usr/bin/env python3
"""Write the seed inputs of csrc/tests/fuzz_drive.c and its libFuzzer dictionary.

  python3 tools/fuzz_seeds.py SEED_DIR        seeds: each preset in each mode, moves, steps,
                                              hostile values (make fuzz merges the fuzzed corpus
                                              into csrc/tests/fuzz_corpus/, which starts from these)
  python3 tools/fuzz_seeds.py --dict FILE     the dictionary: whole step records

The format (a header, override records, step records) is documented at the top of fuzz_drive.c.
"""

import pathlib
import struct
import sys

OFF, SENSORED, LUT, NOLUT, CAL, STARTUP = range(6)
PRESETS = range(8)
N_FIELDS = 104  # fuzz_drive.c FIELDS; then enc_counts, cal.period, startup.pairs, the types
SCALE = {1: 0x00, 8: 0x10, 64: 0x20, 256: 0x30}


def header(preset=0, flags=0, tables=0, cal=0, n_ovr=0, load=0, plant=0, speed=0):
    return bytes([preset, flags, tables, cal, n_ovr, load & 0xFF, plant, speed])


def ovr(field, kind, value):
    return bytes([field, kind]) + struct.pack(">I", value & 0xFFFFFFFF)


def rec(op=0, arg=0, value=0, n=0, scale=1, meas=0):
    return bytes([op, arg]) + struct.pack(">I", value & 0xFFFFFFFF) + bytes([n, SCALE[scale] | meas])


def mode(m, n=255, scale=8):
    return rec(1, m, 0, n, scale)


def run(n=255, scale=64, meas=0):
    return rec(0, 0, 0, n, scale, meas)


def pos_plain(period, frac):  # arg class 0: period in the high byte (int16 / 256), angle frac of a period
    return ((period & 0xFF) << 24) | int(frac * 65536) & 0xFFFF


def f32(x):
    return struct.unpack(">I", struct.pack(">f", x))[0]


def seeds():
    s = {}
    for p in PRESETS:
        for m in (SENSORED, LUT, NOLUT, CAL, STARTUP):
            s[f"preset{p}_mode{m}"] = header(p) + mode(m) + run() + run()
    s["sensored_move"] = header() + mode(SENSORED) + rec(3, 0, pos_plain(1, 0.3), 255, 64) + run()
    s["sensored_step"] = header() + mode(SENSORED) + rec(4, 0, pos_plain(-1, 0.7), 255, 64) + run()
    s["lut_move"] = (
        header() + rec(2, 0, pos_plain(0, 0.0)) + mode(LUT) + rec(3, 0, pos_plain(2, 0.5), 255, 64)
    )
    s["lut_load"] = (
        header(load=40) + mode(LUT) + rec(5, 4, 0x00034000, 255, 64) + rec(9, 4, 0x00046000, 255, 64)
    )
    s["move_far_end"] = header() + mode(SENSORED) + rec(3, 0x10, 0x00010000, 255, 64)
    s["move_any_period"] = (
        header() + mode(SENSORED) + rec(3, 0x30, 0x7FFFFFFF, 16) + rec(4, 0x30, 0x80000000, 16)
    )
    s["move_nan"] = (
        header() + mode(LUT) + rec(3, 0x22, 1, 16) + rec(2, 0x22, 2, 16) + rec(6, 0x20, f32(1e30), 16)
    )
    s["reset_end"] = header() + rec(6, 0x10, 0x00030000) + mode(LUT, 64)
    s["enc_jumps"] = (
        header()
        + mode(SENSORED, 16)
        + rec(7, 1, 0x7FFFFFFF, 1, meas=2)
        + rec(7, 1, 0x80000000, 1, meas=2)
        + rec(0, 0, 0, 64, 1, meas=4)
        + rec(0, 0, 0, 64, 1, meas=8)
    )
    s["meas_hostile"] = (
        header()
        + mode(LUT, 16)
        + rec(8, 0 | (2 << 2), 1, 8)
        + rec(8, 3 | (1 << 2), 16, 8)
        + rec(8, 1 | (1 << 2), 14, 8)
        + rec(8, 3 | (4 << 2), 0x0005C000, 64)
    )
    s["held_currents"] = (
        header() + mode(LUT, 16, 1) + run(255, 8, meas=1) + mode(SENSORED, 1) + run(255, 8, meas=1 | 4)
    )
    s["plant_noise_sat"] = header(tables=64, plant=10) + mode(STARTUP) + run() + run()
    s["no_tables"] = header(tables=7) + mode(LUT, 4, 1) + mode(CAL, 4, 1) + mode(NOLUT) + run()
    s["flags_all"] = header(flags=255, tables=8 | 16 | 32) + mode(SENSORED) + run() + mode(LUT) + run()
    s["fs_32k"] = header(plant=0x30) + mode(LUT) + run()
    s["ovr_fs_nan"] = header(n_ovr=1) + ovr(0, 2, 1) + mode(LUT, 4)
    s["ovr_kp_huge"] = header(n_ovr=2) + ovr(29, 1, 14) + ovr(30, 1, 10) + mode(SENSORED) + run(64, 8)
    s["ovr_denormal_l"] = header(n_ovr=2) + ovr(51, 0, 1) + ovr(52, 0, 1) + mode(LUT) + run(64, 8)
    s["ovr_enc_coarse"] = header(n_ovr=1) + ovr(N_FIELDS, 0, 6) + mode(SENSORED) + run(64, 8)
    # the SPEED step (h[7]: emf_on, a band the moves cross, the magnets' imbalance compensated)
    for p, sp in ((0, 1), (1, 3), (0, 7)):
        s[f"speed{sp}_preset{p}"] = (
            header(p, speed=sp) + mode(LUT) + rec(3, 0, pos_plain(3, 0.5), 255, 64) + run()
            + rec(3, 0, pos_plain(0, 0.0), 255, 64) + run()
        )
    s["speed_nolut_load"] = header(1, load=40, speed=3) + mode(NOLUT) + rec(3, 0, pos_plain(-3, 0.2), 255, 64)
    return s


def dictionary():
    """Whole records: each mode with a long run, the setters, hostile measurements."""
    toks = {}
    for m in range(6):
        toks[f"mode{m}_run"] = mode(m, 255, 64)
    toks["run_plant"] = run(255, 256)
    toks["run_held"] = run(255, 8, meas=1)
    toks["run_enc_up"] = run(255, 8, meas=4)
    toks["run_enc_invalid"] = run(16, 1, meas=8)
    toks["move_to"] = rec(3, 0, pos_plain(1, 0.25), 255, 64)
    toks["step_to"] = rec(4, 0, pos_plain(-2, 0.5), 255, 64)
    toks["set_position"] = rec(2, 0, pos_plain(0, 0.1), 16)
    toks["move_end"] = rec(3, 0x10, 0x00030000, 255, 8)
    toks["set_load"] = rec(5, 4, 0x00034000, 255, 8)
    toks["plant_load"] = rec(9, 4, 0x00046000, 255, 64)
    toks["nan_current"] = rec(8, 2 << 2, 1, 4)
    toks["inf_vdc"] = rec(8, 3 | (2 << 2), 2, 4)
    toks["enc_max"] = rec(7, 1, 0x7FFFFFFF, 1, meas=2)
    return toks


def main():
    if len(sys.argv) == 3 and sys.argv[1] == "--dict":
        lines = ["# csrc/tests/fuzz_drive.c: whole step records (tools/fuzz_seeds.py --dict)"]
        for name, b in dictionary().items():
            lines.append(f'{name}="' + "".join(f"\\x{c:02x}" for c in b) + '"')
        pathlib.Path(sys.argv[2]).write_text("\n".join(lines) + "\n")
        return 0
    if len(sys.argv) != 2:
        print(__doc__, file=sys.stderr)
        return 2
    out = pathlib.Path(sys.argv[1])
    out.mkdir(parents=True, exist_ok=True)
    for name, data in seeds().items():
        (out / f"seed_{name}").write_bytes(data)
    print(f"{len(seeds())} seeds in {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
