"""The class table of docs/tuning.md ("Where the design stands"): the full certificate of every
shipped motor with its drive data (src/linsense/examples/motors/class/drives.toml), one row each
(linsense.verify.certificate.summary_row), written between the page's markers.

    .venv/bin/python tools/class_table.py            # run, print and write the table into the page
    .venv/bin/python tools/class_table.py --check    # run and fail (exit 1) if the page differs

tests/test_verify.py checks each row against its own run of the certificate.
"""

from __future__ import annotations

import sys
import time
import tomllib
from pathlib import Path

from linsense.examples import ROOT as EXAMPLES
from linsense.tune.design import DriveData
from linsense.verify.certificate import SUMMARY_COLUMNS, design_and_verify, summary_row

PAGE = Path(__file__).resolve().parents[1] / "docs" / "tuning.md"
BEGIN, END = "<!-- class-table: tools/class_table.py writes this table -->", "<!-- class-table end -->"


def shipped() -> dict:
    """Every shipped motor's spec and drive data, by name."""
    motors = EXAMPLES / "motors"
    drives = tomllib.loads((motors / "class" / "drives.toml").read_text())
    out = {"ecce2010": ("ecce2010", DriveData()), "small30": (str(motors / "small30.toml"), DriveData()),
           "harmonic": (str(motors / "harmonic.toml"), DriveData())}
    for name, data in drives.items():
        dd = DriveData()
        for k, v in data.items():
            setattr(dd, k, v)
        out[name] = (str(motors / "class" / f"{name}.toml"), dd)
    return out


def markdown(rows: list[list[str]]) -> str:
    """The table's Markdown."""
    lines = ["| " + " | ".join(SUMMARY_COLUMNS) + " |", "|" + "---|" * len(SUMMARY_COLUMNS)]
    return "\n".join(lines + ["| " + " | ".join(r) + " |" for r in rows])


def main(argv: list[str]) -> int:
    rows = []
    for name, (spec, dd) in shipped().items():
        t0 = time.perf_counter()
        cert = design_and_verify(spec, dd)[1]
        rows.append(summary_row(name, cert))
        print(f"{name}: {cert.verdict()} ({time.perf_counter() - t0:.1f} s)", file=sys.stderr)
    table = markdown(rows)
    print(table)
    text = PAGE.read_text()
    head, rest = text.split(BEGIN, 1)
    _, tail = rest.split(END, 1)
    new = f"{head}{BEGIN}\n{table}\n{END}{tail}"
    if "--check" in argv:
        if new != text:
            print(f"{PAGE}: the class table differs from this run: run tools/class_table.py", file=sys.stderr)
            return 1
        return 0
    PAGE.write_text(new)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
