#!/usr/bin/env python3
"""libFuzzer runs of csrc/tests/fuzz_drive.c (make fuzz): time-stamped logs, the coverage curve,
the saturation verdict. Standard library only.

  fuzz_report.py run --log LOG -- FUZZER ARGS...
      runs the fuzzer, writes each line of its output to LOG prefixed with the seconds since its
      start, and exits with the fuzzer's exit code
  fuzz_report.py summary LOG [--quiet 0.5] [--growth 0.005] [--min-run 300] [--label NAME]
      prints "coverage saturated: cov N; +k edges (x %) in the last 50 % of the run ..." when `cov`
      (the edges of the firmware library covered) grew by at most GROWTH of itself during the last
      QUIET fraction of the run's wall time (a plateau), else "NOT saturated: ..."; a run shorter
      than MIN_RUN s after its corpus loaded is "not judged"; never fails on that
  fuzz_report.py curve LOG[=LABEL[@T0]]... --csv OUT [--png OUT.png]
      writes the curve (label, t_s, execs, cov, ft, corp) of each log; the label defaults to the
      log's parent directory name; @T0 adds T0 s to its times (a run that continued an earlier
      one's corpus: same label, the later start)

The curve comes from libFuzzer's status lines (#<execs> INITED/NEW/REDUCE/pulse/DONE cov: ft: corp:).
"""

import argparse
import re
import subprocess
import sys
import time
from pathlib import Path

STATUS = re.compile(
    r"^#(\d+)\s+(INITED|NEW|REDUCE|pulse|DONE|RELOAD)\s+cov: (\d+) ft: (\d+)(?: corp: (\d+))?"
)


def run(args):
    cmd = args.cmd[1:] if args.cmd and args.cmd[0] == "--" else args.cmd
    t0 = time.monotonic()
    with open(args.log, "w", encoding="utf-8", errors="replace") as log:
        proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT)
        for raw in proc.stdout:
            line = raw.decode("utf-8", errors="replace").rstrip("\n")
            log.write(f"{time.monotonic() - t0:.3f}\t{line}\n")
            log.flush()
        rc = proc.wait()
        log.write(f"{time.monotonic() - t0:.3f}\t#END rc={rc}\n")
    return rc


def parse(path):
    """(points, t_end): points are (t, execs, cov, ft, corp) of the status lines."""
    points, t_end = [], 0.0
    for line in Path(path).read_text(encoding="utf-8", errors="replace").splitlines():
        t, _, text = line.partition("\t")
        try:
            t = float(t)
        except ValueError:
            continue
        t_end = max(t_end, t)
        m = STATUS.match(text)
        if m:
            points.append((t, int(m.group(1)), int(m.group(3)), int(m.group(4)), int(m.group(5) or 0)))
    return points, t_end


def inited(path):
    """The time of the INITED line (the corpus loaded), 0 without one."""
    for line in Path(path).read_text(encoding="utf-8", errors="replace").splitlines():
        t, _, text = line.partition("\t")
        m = STATUS.match(text)
        if m and m.group(2) == "INITED":
            return float(t)
    return 0.0


def verdict(path, quiet, growth, min_run=300.0):
    """Saturated when the library's edges (`cov`) grew by at most ``growth`` (a fraction of the
    edges at the window's start) during the last ``quiet`` fraction of the run's wall time: a
    plateau, where the edges still found are a tail of rare combinations (one per minutes); with
    ``growth`` 0, not one new edge."""
    points, t_end = parse(path)
    if not points:
        return False, "NOT saturated: no coverage reported (see the log)"
    cov_max, t_new, n_new = -1, 0.0, 0
    for t, execs, cov, _, _ in points:
        if cov > cov_max:
            cov_max, t_new, n_new = cov, t, execs
    t0 = inited(path)  # (the run proper starts once the corpus is loaded)
    t_win = t0 + (1.0 - quiet) * (t_end - t0)
    before = [cov for t, _, cov, _, _ in points if t <= t_win]
    cov_win = max(before) if before else points[0][2]
    gained = cov_max - cov_win
    execs_end = points[-1][1]
    if t_end - t0 < min_run:
        return False, (f"coverage not judged: cov {cov_max}, +{gained} edges in the last {quiet:.0%} of "
                       f"a {t_end:.0f}-s run (saturation is judged on runs of {min_run:.0f} s or more "
                       "after the corpus is loaded: make fuzz FUZZ_TIME=600)")
    ok = t_end > 0 and gained <= growth * cov_win
    word = "coverage saturated" if ok else "NOT saturated"
    return ok, (
        f"{word}: cov {cov_max}, ft {points[-1][3]}; +{gained} edges ({gained / max(cov_win, 1):.2%}) in the "
        f"last {quiet:.0%} of the run after the corpus loaded ({t_end - t_win:.0f} s), the last new edge at "
        f"{t_new:.0f} s of {t_end:.0f} s (exec {n_new} of {execs_end}; saturated = at most {growth:.1%} "
        f"more edges in the last {quiet:.0%})"
    )


def summary(args):
    _, line = verdict(args.log, args.quiet, args.growth, args.min_run)
    print(f"[{args.label}] {line}" if args.label else line)
    return 0


def curve(args):
    rows = []
    for spec in args.logs:
        path, _, rest = spec.partition("=")
        label, _, t0 = rest.partition("@")
        label = label or Path(path).parent.name
        points, _ = parse(path)
        if t0:  # a continuation: from its corpus loaded (INITED) on, the loading's partial counts left out
            t_init = inited(path)
            points = [p for p in points if p[0] >= t_init]
        last_t, last_cov = -1e9, -1
        for i, p in enumerate(points):  # thinned: each new edge, else one row per 5 s, and the end
            if p[2] > last_cov or p[0] - last_t >= 5.0 or i == len(points) - 1:
                rows.append((label, p[0] + float(t0 or 0)) + p[1:])
                last_t, last_cov = p[0], max(last_cov, p[2])
    with open(args.csv, "w", encoding="utf-8") as f:
        f.write("label,t_s,execs,cov,ft,corp\n")
        for r in rows:
            f.write(f"{r[0]},{r[1]:.1f},{r[2]},{r[3]},{r[4]},{r[5]}\n")
    if args.png:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        fig, axes = plt.subplots(1, 2, figsize=(10, 3.6))
        for label in dict.fromkeys(r[0] for r in rows):
            pts = [r for r in rows if r[0] == label]
            for ax, k in zip(axes, (3, 4), strict=True):
                ax.step([p[1] for p in pts], [p[k] for p in pts], where="post", label=label)
        for ax, name in zip(axes, ("cov (edges of the library)", "ft (features)"), strict=True):
            ax.set_xlabel("wall time, s")
            ax.set_ylabel(name)
            ax.grid(True, alpha=0.3)
        axes[0].legend(fontsize=7)
        fig.tight_layout()
        fig.savefig(args.png, dpi=90)
    return 0


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = p.add_subparsers(dest="what", required=True)
    r = sub.add_parser("run")
    r.add_argument("--log", required=True)
    r.add_argument("cmd", nargs=argparse.REMAINDER)
    s = sub.add_parser("summary")
    s.add_argument("log")
    s.add_argument("--quiet", type=float, default=0.5)
    s.add_argument("--growth", type=float, default=0.005)
    s.add_argument("--min-run", type=float, default=300.0)
    s.add_argument("--label", default="")
    c = sub.add_parser("curve")
    c.add_argument("logs", nargs="+")
    c.add_argument("--csv", required=True)
    c.add_argument("--png")
    args = p.parse_args()
    return {"run": run, "summary": summary, "curve": curve}[args.what](args)


if __name__ == "__main__":
    sys.exit(main())
