"""The sweep engine: runs in batches on worker threads or dask, rows in Parquet partitions, resumable.

``sweep(spec, out)`` expands the sweep's points, groups them in batches of ``[sweep] batch`` runs
and runs one task per batch: on a pool of worker threads by default (the C loop releases the GIL,
so threads run in parallel; a pool starts in microseconds and needs no dask), on a local dask
cluster of worker processes (``processes=True``), or on any dask cluster by address
(``scheduler="tcp://host:8786"``). Each finished batch is written as one Parquet
partition ``parts/part-NNNNNN.parquet`` through a temporary file and a rename, so a partition is
either complete or absent; a sweep killed at any point and started again with the same command
runs only the batches without a partition: no row is lost, none is duplicated. ``sweep.json``
records the digest of everything the rows depend on (:mod:`linsense.sweep.inputs`): a resume or a
reuse of the folder after any of it changed is refused naming what changed, ``restart`` discards
the old rows first. The table of all rows is returned as a pandas DataFrame, sorted by run.
docs/sweeps.md.
"""

from __future__ import annotations

import json
import os
import shutil
import signal
import tempfile
import threading
import uuid
from concurrent.futures import ThreadPoolExecutor
from concurrent.futures import as_completed as futures_completed
from contextlib import closing, nullcontext
from pathlib import Path
from typing import TYPE_CHECKING

from linsense._check import instance, integer, path_arg
from linsense.errors import InputError
from linsense.io import held, os_reason, out_target, output_error, write_atomic, write_atomic_with
from linsense.sim.cluster import cluster_client
from linsense.sweep.inputs import changed_on_disk, changes, code_identity, show, sweep_inputs, valid_record
from linsense.sweep.inputs import digest as inputs_digest
from linsense.sweep.points import points
from linsense.sweep.runner import context, run_batch
from linsense.sweep.spec import STUDIES, SweepSpec, as_sweep

if TYPE_CHECKING:
    import pandas as pd

MANIFEST = "sweep.json"
#: what the CLI writes into a sweep's folder from its rows (``--restart`` deletes them first)
OUTPUTS = ("results.parquet", "summary.txt", *(f"{s}.png" for s in STUDIES))


def batch_size(sweep: SweepSpec, n_runs: int) -> int:
    """Runs per batch: the file's ``batch``, or about 32 batches of at most 128 runs.

    A function of the sweep alone, never of the workers: a resumed sweep cuts its batches the same
    way.

    Parameters
    ----------
    sweep : SweepSpec
        The sweep.
    n_runs : int
        Its runs.

    Returns
    -------
    int
        Runs per batch.
    """
    return sweep.spec.sweep.batch or max(1, min(128, -(-n_runs // 32)))


def _manifest(sweep: SweepSpec, n_runs: int, inputs: list[dict], code: dict) -> dict:
    """``DIR/sweep.json``: the sweep, and the digest of everything its rows depend on."""
    return {"format": "linsense-sweep", "version": code["linsense"],
            "spec": sweep.spec.model_dump(mode="json"), "scenario": str(sweep.scenario_path.resolve()),
            "runs": n_runs, "batch": batch_size(sweep, n_runs), "inputs": inputs, "code": code,
            "digest": inputs_digest(inputs, code)}


def _refuse(out: Path, message: str) -> InputError:
    return InputError("--out", "", f"{show(str(out))!r} {message}")


def _check_out(out: Path, manifest: dict, restart: bool) -> bool:
    """``out`` is new, empty, or holds this same sweep (to resume); anything else is refused.

    A folder with a sweep's manifest whose record differs (another sweep file, an edited base
    scenario, motor or table, another linsense or C library) or cannot be read is refused naming
    what changed, unless ``restart``: then the result is True (discard its rows first). A folder
    that is not a sweep's is refused even with ``restart`` (never deleted).
    """
    if out.exists() and not out.is_dir():
        raise _refuse(out, "is a file, not a folder: give a new or empty folder")
    m = out / MANIFEST
    if not (m.exists() or m.is_symlink()):
        if out.exists() and any(out.iterdir()):
            raise _refuse(out, f"exists and is not a sweep folder (no {MANIFEST}): give a new or empty "
                          "folder")
        return False
    for name in (MANIFEST, "parts", "motors"):  # (what the sweep writes: never a stranger's kind of entry)
        p = out / name
        if p.exists() and p.is_dir() != (name != MANIFEST):
            kind = "file" if name == MANIFEST else "folder"
            raise _refuse(out, f"holds {name!r} that is not the sweep's (a {kind} is expected): remove it "
                          "or give another folder")
    if restart:
        return True
    again = "use --restart to start over (discarding its rows)"
    try:
        old = json.loads(m.read_text(encoding="utf-8"))
    except (OSError, ValueError) as exc:
        why = os_reason(exc) if isinstance(exc, OSError) else exc
        raise _refuse(out, f"holds a sweep whose {MANIFEST} cannot be read ({why}): {again}") from None
    why = valid_record(old)
    if why is not None:
        raise _refuse(out, f"holds a sweep whose {MANIFEST} {why}: {again}")
    diff = changes(old["inputs"], old["code"], manifest["inputs"], manifest["code"])
    if diff:
        raise _refuse(out, f"holds a sweep whose inputs changed since it started: {', '.join(diff)}; {again}")
    same = ("spec", "runs", "batch")
    if {k: old.get(k) for k in same} != {k: manifest[k] for k in same}:
        raise _refuse(out, f"holds another sweep (its {MANIFEST} differs): {again}")
    return False


def _discard(out: Path) -> None:
    """Remove the rows of the sweep in ``out`` (``--restart``), keeping the folder consistent at
    every instant: first the tables made from the rows (``results.parquet``, ``summary.txt``, the
    figures), then ``parts/`` and ``motors/``, each renamed aside in one step and then deleted; the
    caller replaces the manifest last. Killed at any point, the folder holds the old manifest and a
    subset of the old rows (resumable as the old sweep, refused for the new one), and the next run
    deletes what was set aside."""
    for name in OUTPUTS:
        p = out / name
        if p.is_file() or p.is_symlink():
            p.unlink()
    for name in ("parts", "motors"):
        d = out / name
        if d.is_dir():
            aside = out / f".{name}.discarded-{os.getpid()}-{uuid.uuid4().hex[:8]}"
            os.replace(d, aside)
            if aside.is_symlink():  # (a link to a folder elsewhere: the link goes, not the files there)
                aside.unlink()
            else:
                shutil.rmtree(aside)


def _write_manifest(out: Path, manifest: dict) -> None:
    write_atomic(out / MANIFEST, json.dumps(manifest, indent=1) + "\n")


def _unchanged_while_running(out: Path, inputs: list[dict]) -> None:
    """Refuse to keep rows when a file the runs read changed after the sweep recorded it."""
    diff = changed_on_disk(inputs)
    if diff:
        raise _refuse(out, f"holds a sweep whose inputs changed while it ran: {', '.join(diff)} (the rows "
                      "computed since are not kept); use --restart to start over (discarding its rows)")


def _write_partition(parts: Path, b: int, rows: list[dict]) -> Path:
    """One batch's partition, written as every other output is (:func:`linsense.io.write_atomic_with`:
    a temporary file and a rename, mode 0644 under the usual umask, an OSError one line naming the
    partition and the reason in words)."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    table = pa.Table.from_pylist(rows)  # (no pandas on the way: it costs per batch)
    return write_atomic_with(parts / f"part-{b:06d}.parquet", lambda f: pq.write_table(table, f))


def _done_batches(parts: Path) -> set[int]:
    for stale in parts.glob(".part-*.tmp"):  # a temporary file of a killed run: never a result
        stale.unlink(missing_ok=True)
    for aside in parts.parent.glob(".*.discarded-*"):  # what a killed --restart set aside
        shutil.rmtree(aside, ignore_errors=True)
    return {int(p.stem.split("-")[1]) for p in parts.glob("part-*.parquet")}


def _progress(total: int, done: int, enabled: bool):
    if not enabled:
        return nullcontext(None)
    from rich.console import Console
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeRemainingColumn

    class Rate(TextColumn):
        def render(self, task):  # runs per second
            return f"{task.speed or 0:.1f} runs/s"

    # (on stderr, as the CLI decides to show it from stderr; stdout keeps the command's output)
    p = Progress(TextColumn("{task.description}"), BarColumn(), MofNCompleteColumn(), Rate(""),
                 TimeRemainingColumn(), console=Console(stderr=True), transient=False)
    return p


def _finished(ctx, batches: list, todo: list[int], relative: dict, workers: int | None,
              scheduler: str | None, processes: bool):
    """Run the batches ``todo`` and yield ``(batch index, rows)`` as each finishes: on worker threads
    (no scheduler, no processes), else on a dask cluster (:func:`linsense.sim.cluster.cluster_client`).
    Closed early (an error, an interrupt), the threads' batches stop at their next run and the
    batches not started are cancelled."""
    if scheduler or processes:
        with cluster_client(workers, scheduler, processes) as client:
            from dask.distributed import as_completed

            ctx_f = client.scatter(ctx, broadcast=True)
            futures = {client.submit(run_batch, ctx_f, batches[b], relative, pure=False): b for b in todo}
            for fut in as_completed(futures):
                yield futures[fut], fut.result()
        return
    stop = threading.Event()
    n = max(1, min(workers or os.cpu_count() or 1, len(todo)))
    with ThreadPoolExecutor(n, thread_name_prefix="linsense-sweep") as pool:
        futures = {pool.submit(run_batch, ctx, batches[b], relative, stop): b for b in todo}
        try:
            for fut in futures_completed(futures):
                yield futures[fut], fut.result()
        finally:
            stop.set()  # (a no-op when every batch is done)
            for fut in futures:
                fut.cancel()


#: local workers of a sweep (the command line's --workers)
MAX_WORKERS = 1024


def _check_args(out, workers, scheduler, **flags: bool) -> None:
    """:func:`sweep`'s arguments besides the sweep, before anything is read or written."""
    src = "linsense.sweep.sweep"
    if out is not None:
        path_arg(out, src, "out", "a folder")
    if workers is not None:
        integer(workers, src, "workers", 1, MAX_WORKERS, "a number of workers")
    if scheduler is not None:
        instance(scheduler, src, "scheduler", str, "a dask scheduler's address such as 'tcp://host:8786'")
    for name, flag in flags.items():
        instance(flag, src, name, bool, "True or False")


def sweep(spec, out: str | Path | None = None, *, workers: int | None = None, scheduler: str | None = None,
          processes: bool = False, progress: bool = False, restart: bool = False) -> pd.DataFrame:
    """Run a sweep and return its rows (docs/sweeps.md).

    Parameters
    ----------
    spec : SweepSpec or str or Path or dict
        The sweep: a :class:`SweepSpec`, a sweep TOML path or a dict.
    out : str or Path or None, optional
        Folder of the partitions (``parts/``), the manifest and the edited motor files; a sweep
        given the same ``out`` again resumes, or returns its rows when it is complete, if
        everything its rows depend on is unchanged (``sweep.json`` records their digests;
        docs/sweeps.md): otherwise :class:`InputError` naming what changed. Without it, a temporary
        folder is used.
    workers : int or None, optional
        Local workers (default: one per core).
    scheduler : str or None, optional
        Address of a running dask scheduler (``tcp://host:8786``); ``workers`` is then ignored.
    processes : bool, optional
        Local workers as processes of a dask cluster instead of threads (threads are the default:
        they start at once, without dask, and the C loop runs without the GIL).
    progress : bool, optional
        Show a progress bar (runs done, rate, time left).
    restart : bool, optional
        Discard the rows of the sweep already in ``out`` (of other inputs, or with an unreadable
        manifest) and start over; a folder that is not a sweep's is still refused.

    Returns
    -------
    pandas.DataFrame
        One row per run, in run order: ``run``, the swept values, every scalar metric and ``error``
        (the message of a run refused, else None).

    Raises
    ------
    linsense.errors.InputError
        An invalid sweep, an ``out`` that is not this sweep's or whose inputs changed, or an input
        file changed while the sweep runs; an argument of the wrong type (``out=123`` was a
        TypeError).
    """
    _check_args(out, workers, scheduler, processes=processes, progress=progress, restart=restart)
    sw = as_sweep(spec)
    pts = points(sw)
    batch = batch_size(sw, len(pts))
    relative = {a.key: a.relative for a in sw.spec.axis}
    batches = [list(enumerate(pts))[i:i + batch] for i in range(0, len(pts), batch)]
    holder = tempfile.TemporaryDirectory(prefix="linsense-sweep-") if out is None else nullcontext(out)
    with holder as out_given:
        out_dir = Path(out_given)
        if out_dir.is_symlink():  # (a link followed, a dangling one made, a loop refused)
            out_dir = out_target(out_dir)
        made = not os.path.lexists(out_dir)
        lock = held(out_dir, BUSY)
        try:
            try:
                lock.__enter__()  # (makes the folder: a read-only parent said as any write is)
            except OSError as exc:
                raise output_error(exc.filename or out_dir, exc) from None
            try:
                return _sweep_in(sw, pts, batches, relative, out_dir, workers, scheduler, processes, progress,
                                 restart)
            finally:
                lock.__exit__(None, None, None)
        except BaseException:
            if made:  # (a refused sweep leaves no folder it made)
                try:
                    out_dir.rmdir()
                except OSError:
                    pass
            raise


#: the refusal of a sweep into a folder another sweep is writing into
BUSY = ("another linsense sweep is writing into this folder: wait for it to finish (the same command then "
        "returns its rows), or choose another folder")


def _sweep_in(sw: SweepSpec, pts: list, batches: list, relative: dict, out_dir: Path, workers: int | None,
              scheduler: str | None, processes: bool, progress: bool, restart: bool) -> pd.DataFrame:
    """The sweep's work in ``out_dir``, its lock held (:func:`sweep`)."""
    inputs = sweep_inputs(sw)
    manifest = _manifest(sw, len(pts), inputs, code_identity())
    discard = _check_out(out_dir, manifest, restart)
    ctx = context(sw, out_dir / "motors")  # (reads the base: bad input refused before a discard)
    _unchanged_while_running(out_dir, inputs)  # (the base read above is the one recorded)
    parts = out_dir / "parts"
    try:
        if discard:
            _discard(out_dir)
        parts.mkdir(parents=True, exist_ok=True)
        (out_dir / "motors").mkdir(exist_ok=True)
        if discard or not (out_dir / MANIFEST).is_file():
            _write_manifest(out_dir, manifest)
    except OSError as exc:
        raise output_error(exc.filename or out_dir, exc) from None
    done = _done_batches(parts)
    todo = [b for b in range(len(batches)) if b not in done]
    n_done = sum(len(batches[b]) for b in done)
    if todo:
        bar_ctx = _progress(len(pts), n_done, progress)
        runs = _finished(ctx, batches, todo, relative, workers, scheduler, processes)
        with closing(runs), bar_ctx as bar:
            task = bar.add_task(sw.name, total=len(pts), completed=n_done) if bar else None
            kill_after = int(os.environ.get("LINSENSE_TEST_KILL_AFTER_PARTS", "0"))  # (tests only)
            for written, (b, rows) in enumerate(runs, start=1):
                _unchanged_while_running(out_dir, inputs)  # (rows of the recorded inputs only)
                _write_partition(parts, b, rows)
                if bar:
                    bar.advance(task, len(batches[b]))
                if kill_after and written >= kill_after:
                    os.kill(os.getpid(), signal.SIGKILL)
    import pandas as pd

    frames = [pd.read_parquet(p) for p in sorted(parts.glob("part-*.parquet"))]
    df = pd.concat(frames, ignore_index=True) if frames else pd.DataFrame()
    if not df.empty:
        df = df.sort_values("run", kind="stable").reset_index(drop=True)
    if len(df) != len(pts) or (not df.empty and df["run"].duplicated().any()):
        raise InputError(str(out_dir), "parts", f"{len(df)} rows for {len(pts)} runs: the partitions "
                         "do not belong to this sweep")
    return df

