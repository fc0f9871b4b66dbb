"""Batches of scans on a Dask cluster: one `fringe.scan` task per scan folder, one table of results.

    python3 -m fringe.batch PROJECT... --out DIR [--scheduler tcp://HOST:8786] [--workers N]
                            [--threads T] [--force] [fringe scan options]

or from Python::

    import fringe.batch
    rows = fringe.batch.scan_all(["part1", "part2"], "results", calib="rig.json")

Each project's output is DIR/<project folder name>/, exactly what `fringe scan PROJECT --out
DIR/<name>` writes (the task calls the same library function, with the GIL released). A project
that fails is reported with its error and does not stop the others. A rerun skips the projects
whose output is complete (fringe writes an output folder atomically: when DIR/<name>/summary.json
exists, the folder is complete); `force=True` (`--force`) scans them again. The table is written
to DIR/batch.json and DIR/batch.csv (atomically) and returned: a list of dicts, or a pandas
DataFrame with `as_dataframe=True` when pandas is installed.

Without a scheduler address the batch runs on a LocalCluster on this machine bound to loopback
(127.0.0.1): nothing is sent to any other address. Dask distributed (Debian python3-distributed)
is imported only when a batch runs.
"""

import argparse
import csv
import io
import json
import os
import pathlib
import sys
import time

# The summary keys copied into the table, in column order (absent ones stay empty).
_SUMMARY_COLUMNS = (
    "mode", "views", "views_ok", "points", "fused_points", "fused_rms_mm", "mesh_triangles",
    "registration_status", "icp_rms_mm", "marker_adjusted_rms_mm", "pose_rot_err_deg",
    "pose_trans_err_mm", "mesh_truth_rms_mm", "total_s", "peak_mem_gib")
_COLUMNS = ("project", "output", "status", "error", "wall_s", "worker") + _SUMMARY_COLUMNS


def _output_names(projects):
    """DIR/<folder name> for each project; two projects of one name are an error naming both."""
    names = {}
    for p in projects:
        name = pathlib.Path(p).resolve().name
        if not name:
            raise ValueError(f"{p}: a scan folder needs a name (not the file system root)")
        if name in names:
            raise ValueError(f"{names[name]} and {p} would both write {name}/: give the scan "
                             "folders different names or run them as two batches")
        names[name] = p
    return [pathlib.Path(p).resolve().name for p in projects]


def _row(project, output, status, error="", wall_s=None, worker="", summary=None):
    row = {"project": str(project), "output": str(output), "status": status, "error": error,
           "wall_s": wall_s, "worker": worker}
    for key in _SUMMARY_COLUMNS:
        row[key] = (summary or {}).get(key)
    # VDI/VDE 2634-2 figures where the scan had artefacts (any top-level vdi_* figure).
    for key, value in sorted((summary or {}).items()):
        if key.startswith("vdi_") and not isinstance(value, (dict, list)):
            row[key] = value
    return row


def _scan_one(project, output, options):
    """One task: `fringe.scan` on one folder; never raises (the error goes into the row)."""
    import socket

    import fringe
    start = time.monotonic()
    worker = socket.gethostname() + ":" + str(os.getpid())
    try:
        summary = fringe.scan(project, output, **options)
    except Exception as e:  # noqa: BLE001 -- every failure is a row, the batch goes on
        return _row(project, output, "failed", f"{type(e).__name__}: {e}",
                    time.monotonic() - start, worker)
    return _row(project, output, summary.get("status", "ok"), summary.get("message", ""),
                time.monotonic() - start, worker, summary)


def _complete_output(output):
    summary = output / "summary.json"
    if not summary.is_file():
        return None
    try:
        return json.loads(summary.read_text())
    except (OSError, ValueError):
        return None


def _write_atomically(path, text):
    tmp = path.with_name(f".{path.name}.tmp{os.getpid()}")
    with open(tmp, "w", newline="") as f:
        f.write(text)
        f.flush()
        os.fsync(f.fileno())
    os.replace(tmp, path)


def write_table(rows, out):
    """DIR/batch.json and DIR/batch.csv (one row per project), each written atomically."""
    out = pathlib.Path(out)
    columns = list(_COLUMNS) + sorted({k for r in rows for k in r} - set(_COLUMNS))
    _write_atomically(out / "batch.json", json.dumps(rows, indent=2) + "\n")
    text = io.StringIO()
    writer = csv.DictWriter(text, fieldnames=columns, extrasaction="ignore")
    writer.writeheader()
    for r in rows:
        writer.writerow({k: ("" if r.get(k) is None else r.get(k)) for k in columns})
    _write_atomically(out / "batch.csv", text.getvalue())


def scan_all(projects, out, client=None, force=False, workers=None, threads=None,
             progress=False, as_dataframe=False, **options):
    """Scans every project folder into OUT/<folder name>/ on a Dask cluster; returns the table.

    client: a dask.distributed.Client (None: a LocalCluster on 127.0.0.1 with `workers`
    processes of `threads` threads, closed at the end). options: fringe.scan's keyword
    arguments (calib=..., keep_going=True, fusion={...}), the same for every project.
    """
    projects = [pathlib.Path(p) for p in projects]
    if not projects:
        raise ValueError("no scan folder given")
    out = pathlib.Path(out)
    names = _output_names(projects)
    for p in projects:
        # (A missing folder is that project's failure: fringe.scan names it.)
        if out.resolve() == p.resolve() or p.resolve() in out.resolve().parents:
            raise ValueError(f"--out {out}: lies inside the scan folder {p} (an input)")
    # Bad options fail here, once, rather than in every task.
    import fringe
    fringe.ScannerOptions(**options)
    out.mkdir(parents=True, exist_ok=True)
    rows = [None] * len(projects)
    todo = []
    for i, (p, name) in enumerate(zip(projects, names)):
        output = out / name
        done = None if force else _complete_output(output)
        if done is not None:
            rows[i] = _row(p, output, "skipped", "output complete (force to redo)", 0.0, "",
                           done)
        else:
            todo.append(i)
    own = None
    if todo:
        from distributed import Client, LocalCluster, as_completed
        if client is None:
            own = LocalCluster(n_workers=workers or 1, threads_per_worker=threads or 1,
                               processes=True, host="127.0.0.1", dashboard_address="127.0.0.1:0")
            client = Client(own)
        try:
            if progress:
                link = getattr(client, "dashboard_link", None)
                print(f"fringe.batch: {len(todo)} scan(s) on {client.scheduler.address}"
                      + (f"; dashboard {link}" if link else ""), file=sys.stderr)
            futures = {client.submit(_scan_one, str(projects[i]), str(out / names[i]), options,
                                     pure=False, key=f"fringe-scan-{names[i]}-{time.time_ns()}"):
                       i for i in todo}
            finished = 0
            for future in as_completed(futures):
                i = futures[future]
                try:
                    rows[i] = future.result()
                except Exception as e:  # noqa: BLE001 -- a lost worker: that project failed
                    rows[i] = _row(projects[i], out / names[i], "failed",
                                   f"{type(e).__name__}: {e}")
                finished += 1
                if progress:
                    r = rows[i]
                    print(f"fringe.batch: [{finished}/{len(todo)}] {names[i]}: {r['status']}"
                          + (f" ({r['error']})" if r["status"] == "failed" else ""),
                          file=sys.stderr)
        finally:
            if own is not None:
                client.close()
                own.close()
    write_table(rows, out)
    if as_dataframe:
        import pandas
        return pandas.DataFrame(rows)
    return rows


def _parse_value(text):
    try:
        return json.loads(text)
    except ValueError:
        return text


def main(argv=None):
    ap = argparse.ArgumentParser(
        prog="python3 -m fringe.batch",
        description="fringe scan on many scan folders, as tasks on a Dask cluster; one table "
                    "of results (OUT/batch.csv, OUT/batch.json)")
    ap.add_argument("projects", nargs="+", help="scan folders")
    ap.add_argument("--out", required=True, help="output folder: OUT/<folder name>/ per scan")
    ap.add_argument("--scheduler", help="a Dask scheduler address (tcp://HOST:8786); default: "
                    "a local cluster on 127.0.0.1")
    ap.add_argument("--workers", type=int, default=1, help="local cluster: worker processes")
    ap.add_argument("--threads", type=int, default=None,
                    help="local cluster: threads per worker (default: cores / workers)")
    ap.add_argument("--force", action="store_true", help="scan again the projects whose "
                    "output is complete")
    # The fringe scan options users batch most; any other with --set.
    ap.add_argument("--calib", help="rig calibration (rig JSON) for every project")
    ap.add_argument("--opencv", nargs="+", help="another tool's calibration file(s)")
    ap.add_argument("--keep-going", action="store_true",
                    help="leave out views that fail and finish with the others")
    ap.add_argument("--no-markers", action="store_true", help="register without markers")
    ap.add_argument("--no-report", action="store_true", help="do not write report.html")
    ap.add_argument("--set", action="append", default=[], metavar="FIELD=VALUE",
                    help="any fringe.ScannerOptions field (dotted for nested ones, e.g. "
                         "fusion.spacing_factor=2, mesh.poisson_depth=8); VALUE is JSON or text")
    a = ap.parse_args(argv)
    if a.workers < 1 or (a.threads is not None and a.threads < 1):
        ap.error("--workers and --threads must be at least 1")
    options = {}
    if a.calib:
        options["calib"] = a.calib
    if a.opencv:
        options["opencv"] = a.opencv
    if a.keep_going:
        options["keep_going"] = True
    if a.no_markers:
        options["registration"] = {"use_markers": False}
    if a.no_report:
        options["write_report"] = False
    for item in a.set:
        field, sep, value = item.partition("=")
        if not sep or not field:
            ap.error(f"--set {item}: expected FIELD=VALUE")
        target = options
        *parents, leaf = field.split(".")
        for p in parents:
            target = target.setdefault(p, {})
            if not isinstance(target, dict):
                ap.error(f"--set {item}: {p} is not a group of options")
        target[leaf] = _parse_value(value)
    threads = a.threads or max(1, (os.cpu_count() or 1) // a.workers)
    client = None
    if a.scheduler:
        from distributed import Client
        client = Client(a.scheduler)
    try:
        rows = scan_all(a.projects, a.out, client=client, force=a.force, workers=a.workers,
                        threads=threads, progress=True, **options)
    except (ValueError, TypeError, OSError) as e:
        print(f"fringe.batch: error: {e}", file=sys.stderr)
        return 1
    except Exception as e:  # fringe.Error: an option out of range
        if type(e).__name__ != "Error":
            raise
        print(f"fringe.batch: error: {e}", file=sys.stderr)
        return 1
    finally:
        if client is not None:
            client.close()
    failed = [r for r in rows if r["status"] == "failed"]
    for r in rows:
        print(f"{r['status']:8s} {r['project']} -> {r['output']}"
              + (f": {r['error']}" if r["status"] == "failed" else ""))
    print(f"table: {pathlib.Path(a.out) / 'batch.csv'}, {pathlib.Path(a.out) / 'batch.json'}")
    return 3 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
