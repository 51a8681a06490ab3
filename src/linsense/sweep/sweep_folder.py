"""A sweep's output set (``linsense sweep``): its rows, its summary, its study's figure, its counts.

:func:`sweep_to` is what the command runs, so that Python reaches it too: the runs of
:func:`~linsense.sweep.engine.sweep` into ``out``, then ``results.parquet``, ``summary.txt`` and
the study's figure written beside its partitions, and the runs counted (stable, not, refused).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

from linsense.io import write_atomic, write_atomic_with
from linsense.sweep.engine import sweep
from linsense.sweep.spec import SweepSpec, as_sweep

if TYPE_CHECKING:
    import pandas as pd

#: ``figure(study, rows, axes, relative, path)`` draws a study's figure into ``path``
SweepFigure = Callable[[str, "pd.DataFrame", list, dict, Path], object]


@dataclass
class SweepOutput:
    """What :func:`sweep_to` ran and wrote.

    Parameters
    ----------
    name : str
        The sweep's name.
    study : str or None
        Its study (None: none).
    axes : list of str
        The swept keys.
    rows : pandas.DataFrame
        One row per run (:func:`~linsense.sweep.engine.sweep`'s).
    summary : str
        What the sweep found, in one line (``summary.txt`` holds it after the name).
    files : list of Path
        The files written.
    """

    name: str
    study: str | None
    axes: list[str]
    rows: pd.DataFrame
    summary: str
    files: list[Path] = field(default_factory=list)

    def _refused(self) -> pd.Series:
        import pandas as pd

        df = self.rows
        return df["error"].notna() if "error" in df else pd.Series(False, index=df.index)

    def _stable(self) -> pd.Series:
        return self.rows["stable"].fillna(False).astype(bool) & ~self._refused()

    @property
    def stable(self) -> int:
        """Runs stable (and not refused)."""
        return int(self._stable().sum())

    @property
    def not_stable(self) -> int:
        """Runs that ran and are not stable."""
        return int((~self._stable() & ~self._refused()).sum())

    @property
    def refused(self) -> int:
        """Runs whose scenario was refused."""
        return int(self._refused().sum())

    @property
    def failed_runs(self) -> list[int]:
        """The run numbers not stable or refused."""
        df, bad = self.rows, ~self._stable()
        return [int(r) for r in df.loc[bad, "run"]] if "run" in df else [int(i) for i in df.index[bad]]


def sweep_to(out: str | Path, spec: SweepSpec | str | Path | dict, *, workers: int | None = None,
             scheduler: str | None = None, processes: bool = False, progress: bool = False,
             restart: bool = False, figure: SweepFigure | None = None) -> SweepOutput:
    """Run a sweep into ``out`` and write its results, summary and study figure there.

    Parameters
    ----------
    out : str or Path
        The sweep's folder (its partitions, manifest and results; the same folder again resumes).
    spec : SweepSpec or str or Path or dict
        The sweep (as :func:`~linsense.sweep.engine.sweep` takes it).
    workers, scheduler, processes, progress, restart
        As :func:`~linsense.sweep.engine.sweep`'s.
    figure : callable or None, optional
        ``figure(study, rows, axes, relative, path)`` draws the study's figure into ``path``
        (``<study>.png``), e.g. :func:`linsense.report.sweep_figures.write_sweep_figure` (the
        sweeps are below the figures); None, or a sweep without a study: no figure.

    Returns
    -------
    SweepOutput
        The rows, the summary line, the counts and the files written.
    """
    sw = as_sweep(spec)
    df = sweep(sw, out, workers=workers, scheduler=scheduler, processes=processes, progress=progress,
               restart=restart)
    out_dir = Path(out)
    axes = [a.key for a in sw.spec.axis]
    study = sw.spec.sweep.study
    from linsense.sweep.study_summary import summary_line  # (pandas: not on `import linsense.sweep`)

    line = summary_line(study, df, axes)
    files = [write_atomic_with(out_dir / "results.parquet", lambda f: df.to_parquet(f, index=False)),
             write_atomic(out_dir / "summary.txt", f"{sw.name}: {line}\n")]
    if study and figure is not None:
        relative = {a.key: a.relative for a in sw.spec.axis}
        png = out_dir / f"{study}.png"
        figure(study, df, axes, relative, png)
        files.append(png)
    return SweepOutput(sw.name, study, axes, df, line, files)
