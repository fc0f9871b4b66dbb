#!/usr/bin/env python3
"""Batches of scans on Dask (issue 32, item 1): the per-scan overhead of fringe.batch over the CLI.

    PYTHONPATH=build/python python3 bench/bench_scale.py --fringe build/fringe [--json]
        [--projects 6] [--rig-scale 0.5] [--views 2] [--workers 2] [--work DIR]

N simulated scan folders (the demo part, half rig by default) are scanned twice: one after the
other by `fringe scan` (the CLI, one process per scan), and by fringe.batch on a LocalCluster of
--workers processes bound to 127.0.0.1. On this 2-core machine the batch cannot be much faster
than the CLI (each scan already uses both cores through TBB): the figure is the batch's overhead,
(batch wall - CLI wall) / CLI wall, over the whole run, and whether the outputs are identical
(clouds, mesh, poses byte for byte; summaries less their timings). Default run: about 3 minutes.

Out-of-core scans (item 2), with --ooc-views 8,16,32,64: the demo part simulated on the full rig
with that many views (or taken from --scans DIR/pN when present), each scanned by `fringe scan`
with --memory-limit (default 4 GiB, the issue's target): peak memory per view count
(`peak_mem_gib_N_views`, the summary's VmHWM), the time per view (least-squares slope of the
scan's total_s over the views, `time_per_view_s`), and at the smallest count the tiled fusion
against the whole at once (`tiled_fused_rms_ratio`: fused RMS to the truth of a run with
--fusion-tile over that of a run that fuses at once; `tiled_mesh_rms_ratio` the same for the
mesh). --ooc-only skips the batch figures. Each full-rig scan takes ~1 minute per 8 views.
"""

import argparse
import json
import os
import pathlib
import shutil
import subprocess
import sys
import tempfile
import time


# checkpoint_mib: the --resume cache written, whose keys hold the output path and the options.
TIMING_KEYS = {"peak_mem_gib", "seconds", "time_s", "checkpoint_mib"}


def without_timings(value):
    if isinstance(value, dict):
        return {k: without_timings(v) for k, v in value.items()
                if k not in TIMING_KEYS and not k.endswith("_s")}
    if isinstance(value, list):
        return [without_timings(v) for v in value]
    return value


def run(cmd):
    r = subprocess.run([str(c) for c in cmd], capture_output=True, text=True)
    if r.returncode != 0:
        sys.exit(f"{' '.join(map(str, cmd))} exited {r.returncode}: {r.stderr}")


def main():
    ap = argparse.ArgumentParser(description="fringe.batch overhead over the CLI")
    ap.add_argument("--fringe", required=True, help="the fringe program")
    ap.add_argument("--json", action="store_true")
    ap.add_argument("--projects", type=int, default=6)
    ap.add_argument("--rig-scale", type=float, default=0.5)
    ap.add_argument("--views", type=int, default=2)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--work", help="working folder (default: a temporary one, removed)")
    ap.add_argument("--ooc-views", default="", help="view counts of the out-of-core runs, e.g. 8,16,32")
    ap.add_argument("--memory-limit", type=float, default=4.0, help="GiB, the out-of-core runs' limit")
    ap.add_argument("--fusion-tile", type=float, default=60.0,
                    help="mm, the tiled run of tiled_fused_rms_ratio")
    ap.add_argument("--scans", help="folder of simulated full-rig scans pN (reused, else simulated)")
    ap.add_argument("--ooc-only", action="store_true", help="only the out-of-core figures")
    a = ap.parse_args()
    work = pathlib.Path(a.work) if a.work else pathlib.Path(tempfile.mkdtemp(prefix="bench_scale_"))
    shutil.rmtree(work, ignore_errors=True)
    work.mkdir(parents=True)
    result = {"projects": a.projects, "views_per_project": a.views, "rig_scale": a.rig_scale,
              "workers": a.workers, "cpu_count": os.cpu_count()}
    if not a.ooc_only:
        result.update(batch_figures(a, work))
    else:
        result.update({"batch_overhead": None, "batch_identical": None})
    result.update({"peak_mem_gib_8_views": None, "peak_mem_gib_16_views": None,
                   "peak_mem_gib_32_views": None, "peak_mem_gib_64_views": None,
                   "time_per_view_s": None, "tiled_fused_rms_ratio": None})
    if a.ooc_views:
        result.update(out_of_core_figures(a, work))
    if a.json:
        print(json.dumps(result, indent=2))
    else:
        for k, v in result.items():
            print(f"{k}: {v}")
    if not a.work:
        shutil.rmtree(work, ignore_errors=True)


def scan_summary(fringe, project, out, *args):
    shutil.rmtree(out, ignore_errors=True)
    run([fringe, "-q", "scan", project, "--out", out, "--calib", project / "truth" / "rig.json",
         "--no-report", *args])
    return json.loads((out / "summary.json").read_text())


def out_of_core_figures(a, work):
    counts = [int(n) for n in a.ooc_views.split(",")]
    scans = pathlib.Path(a.scans) if a.scans else work / "scans"
    scans.mkdir(parents=True, exist_ok=True)
    out = {"memory_limit_gib": a.memory_limit}
    times = []
    for n in counts:
        p = scans / f"p{n}"
        if not (p / "scan.json").exists():
            run([a.fringe, "-q", "simulate", "demo", "--out", p, "--views", n, "--rig-scale", 1,
                 "--calibration-images", 0, "--seed", 1, "--no-truth-maps"])
        s = scan_summary(a.fringe, p, work / f"ooc{n}", "--memory-limit", a.memory_limit)
        out[f"peak_mem_gib_{n}_views"] = round(s["peak_mem_gib"], 3)
        out[f"total_s_{n}_views"] = round(s["total_s"], 2)
        out[f"fusion_tiles_{n}_views"] = s["fusion_tiles"]
        out[f"views_ok_{n}_views"] = s["views_ok"]
        times.append((n, s["total_s"]))
        shutil.rmtree(work / f"ooc{n}", ignore_errors=True)
    if len(times) >= 2:
        mx = sum(n for n, _ in times) / len(times)
        my = sum(t for _, t in times) / len(times)
        out["time_per_view_s"] = round(sum((n - mx) * (t - my) for n, t in times) /
                                       sum((n - mx) ** 2 for n, _ in times), 3)
    # Tiled against whole at once, at the smallest count.
    p = scans / f"p{counts[0]}"
    whole = scan_summary(a.fringe, p, work / "whole", "--memory-limit", 1000)
    tiled = scan_summary(a.fringe, p, work / "tiled", "--fusion-tile", a.fusion_tile)
    out.update({
        "ratio_views": counts[0], "fusion_tile_mm": a.fusion_tile,
        "tiled_fusion_tiles": tiled["fusion_tiles"],
        "whole_fused_rms_mm": whole["fused_rms_mm"], "tiled_fused_rms_mm": tiled["fused_rms_mm"],
        "tiled_fused_rms_ratio": round(tiled["fused_rms_mm"] / whole["fused_rms_mm"], 4),
        "whole_fused_points": whole["fused_points"], "tiled_fused_points": tiled["fused_points"],
        "whole_mesh_truth_rms_mm": whole["mesh_truth_rms_mm"],
        "tiled_mesh_truth_rms_mm": tiled["mesh_truth_rms_mm"],
        "tiled_mesh_rms_ratio": round(tiled["mesh_truth_rms_mm"] / whole["mesh_truth_rms_mm"], 4),
        "whole_peak_mem_gib": whole["peak_mem_gib"], "tiled_peak_mem_gib": tiled["peak_mem_gib"],
        "whole_fuse_s": whole["fuse_s"], "tiled_fuse_s": tiled["fuse_s"],
    })
    return out


def batch_figures(a, work):
    import fringe.batch  # the Python module (PYTHONPATH=build/python); not needed for --ooc-only

    projects = []
    (work / "projects").mkdir()
    (work / "cli").mkdir()
    for i in range(a.projects):
        p = work / "projects" / f"part{i:02d}"
        run([a.fringe, "-q", "simulate", "demo", "--out", p, "--views", a.views, "--rig-scale",
             a.rig_scale, "--calibration-images", 0, "--seed", 100 + i, "--no-truth-maps"])
        projects.append(p)
    rig = projects[0] / "truth" / "rig.json"

    start = time.monotonic()
    for p in projects:
        run([a.fringe, "-q", "scan", p, "--out", work / "cli" / p.name, "--calib", rig,
             "--no-report"])
    cli_s = time.monotonic() - start

    start = time.monotonic()
    rows = fringe.batch.scan_all(projects, work / "batch", workers=a.workers,
                                 threads=max(1, (os.cpu_count() or 1) // a.workers),
                                 calib=str(rig), write_report=False)
    batch_s = time.monotonic() - start

    identical = all(r["status"] == "ok" for r in rows)
    for p in projects:
        ours, theirs = work / "batch" / p.name, work / "cli" / p.name
        for name in ("fused.ply", "mesh.ply", "poses.json", "markers.json"):
            identical = identical and (ours / name).read_bytes() == (theirs / name).read_bytes()
        for ply in (theirs / "views").glob("*.ply"):
            identical = identical and (ours / "views" / ply.name).read_bytes() == ply.read_bytes()
        s_ours = json.loads((ours / "summary.json").read_text())
        s_theirs = json.loads((theirs / "summary.json").read_text())
        identical = identical and without_timings(s_ours) == without_timings(s_theirs)

    return {"cli_sequential_s": round(cli_s, 2), "batch_s": round(batch_s, 2),
            "batch_overhead": round((batch_s - cli_s) / cli_s, 4),
            "batch_identical": identical}


if __name__ == "__main__":
    main()
