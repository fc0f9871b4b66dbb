#!/usr/bin/env python3
"""Crash consistency of fringe's outputs (issue 30): `fringe scan` killed with SIGKILL at random
moments of committing its outputs (the moments a power cut or the OOM killer could hit), through
the test hook of util/files.cc (FRINGE_TEST_KILL_AT=N: SIGKILL at the Nth output checkpoint;
FRINGE_TEST_CHECKPOINTS=FILE: one line per checkpoint), not through sleeps.

After each kill the output folder must be absent or complete and equal to an uninterrupted
run's (a fresh output), or still the complete earlier output it was replacing (never none, never
a mix, never a torn file); a rerun must then give the uninterrupted run's output and leave no
temporary beside it. Usage: kill_outputs.py --fringe build/fringe [--work DIR] [--kills 20]
Prints one line per kill and exits 0 when every one held.
"""

import argparse
import hashlib
import json
import os
import random
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

# Files whose bytes hold timings: compared by structure, not bytes.
TIMED = {"summary.json", "report.html"}


def tree(path):
    """{relative name: digest} of every file under path; timed files by a digest of their
    structure (JSON keys / that the page is whole)."""
    out = {}
    for p in sorted(Path(path).rglob("*")):
        if not p.is_file():
            continue
        rel = str(p.relative_to(path))
        data = p.read_bytes()
        if p.name == "summary.json":
            j = json.loads(data)  # a torn file fails here
            out[rel] = "json:" + ",".join(sorted(j.keys()))
        elif p.name == "report.html":
            out[rel] = "html:" + str(data.rstrip().endswith(b"</html>"))
        else:
            out[rel] = hashlib.sha256(data).hexdigest()
    return out


def run(fringe, args, env_extra=None, cwd=None):
    env = dict(os.environ)
    env.pop("FRINGE_TEST_KILL_AT", None)
    env.pop("FRINGE_TEST_CHECKPOINTS", None)
    env.update(env_extra or {})
    return subprocess.run([fringe, "--quiet", *map(str, args)], env=env, cwd=cwd,
                          capture_output=True, text=True, errors="replace", timeout=600)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--fringe", required=True)
    ap.add_argument("--work")
    ap.add_argument("--kills", type=int, default=20)
    ap.add_argument("--seed", type=int, default=30)
    a = ap.parse_args()
    # ~45 runs of `fringe scan` on a tiny simulated part: re-executing each with huge pages
    # (util/memory.h) would load the ~330 shared libraries twice for little to gain. Results do
    # not depend on it, and the rest of the suite runs with it.
    os.environ.setdefault("FRINGE_HUGE_PAGES", "0")
    fringe = str(Path(a.fringe).resolve())
    work = Path(a.work) if a.work else Path(tempfile.mkdtemp(prefix="fringe_kill_"))
    shutil.rmtree(work, ignore_errors=True)
    work.mkdir(parents=True)
    proj = work / "proj"
    r = run(fringe, ["simulate", "sphere", "--out", proj, "--views", "2", "--rig-scale", "0.25",
                     "--supersampling", "1", "--calibration-images", "0", "--no-truth-maps"])
    if r.returncode != 0:
        sys.exit(f"setup: simulate failed: {r.stderr}")
    shutil.copy(proj / "truth" / "rig.json", work / "rig.json")
    scan = ["scan", proj, "--calib", work / "rig.json"]

    # The uninterrupted run, counting its checkpoints; and an earlier output of another kind
    # (no report) that a killed run may be replacing.
    log = work / "checkpoints.txt"
    r = run(fringe, scan + ["--out", work / "ref"], {"FRINGE_TEST_CHECKPOINTS": str(log)})
    if r.returncode != 0:
        sys.exit(f"setup: scan failed: {r.stderr}")
    steps = log.read_text().splitlines()
    ref = tree(work / "ref")
    r = run(fringe, scan + ["--out", work / "old", "--no-report"])
    if r.returncode != 0:
        sys.exit(f"setup: scan --no-report failed: {r.stderr}")
    old = tree(work / "old")
    if old == ref:
        sys.exit("setup: the earlier output must differ from the new one")
    views = json.loads((work / "ref" / "summary.json").read_text())["views_ok"]
    print(f"{len(steps)} output checkpoints in an uninterrupted scan; {len(ref)} files out")

    rng = random.Random(a.seed)
    # The first checkpoint and the last three (the folder synced, then exchanged or renamed
    # into place: the moments that decide what is left), the rest drawn from the others.
    ends = sorted({1} | set(range(max(1, len(steps) - 2), len(steps) + 1)))
    middle = [k for k in range(1, len(steps) + 1) if k not in ends]
    points = sorted(ends + rng.sample(middle, max(0, min(len(middle), a.kills - len(ends)))))
    failures = 0
    for i, k in enumerate(points):
        case = work / f"kill{k:04d}"
        case.mkdir()
        out = case / "out"
        replacing = (i // 2) % 2 == 1
        # The last file of the run written (the summary), the views' checkpoints not yet
        # removed: --resume must reuse every view there.
        last_file = len(steps) - 2
        resume = i % 2 == 0 or k == last_file
        if replacing:
            shutil.copytree(work / "old", out, symlinks=True)
        r = run(fringe, scan + ["--out", out], {"FRINGE_TEST_KILL_AT": str(k)})
        why = []
        if r.returncode != -9:
            why.append(f"expected SIGKILL at checkpoint {k}, got exit {r.returncode}")
        try:
            now = tree(out) if out.exists() else None
        except (ValueError, UnicodeDecodeError) as e:
            now, why = "torn", why + [f"torn file: {e}"]
        allowed = [ref, old] if replacing else [None, ref]
        if now not in allowed:
            why.append("output is neither " + (" nor ".join(
                "absent" if x is None else ("the new output" if x is ref else "the earlier output")
                for x in allowed)))
        # Rerun after the crash (plain, or --resume reusing the views the killed run finished):
        # the uninterrupted output, and no temporary left beside it.
        r = run(fringe, scan + ["--out", out] + (["--resume"] if resume else []))
        reused = None
        if r.returncode != 0:
            why.append(f"rerun failed: {r.stderr.strip()[:200]}")
        else:
            if tree(out) != ref:
                why.append("rerun output differs from the uninterrupted run")
            reused = json.loads((out / "summary.json").read_text())["views_resumed"]
            if not resume and reused != 0:
                why.append(f"a plain rerun reused {reused} views")
            # Killed while committing the folder: both views were finished and must be reused.
            if resume and k == last_file and reused != views:
                why.append(f"--resume after the views were done reused {reused} of {views}")
        left = [p.name for p in case.iterdir() if p.name != "out"]
        if left:
            why.append(f"left beside the output: {left}")
        state = "absent" if now is None else ("new" if now == ref else
                                              ("earlier" if now == old else "BROKEN"))
        step = steps[k - 1].split(" ", 1)[1] if k <= len(steps) else "?"
        print(f"kill at {k:4d} ({step}; {'replacing' if replacing else 'fresh'}): output {state}"
              f"; rerun{' --resume' if resume else ''} reused {reused} views"
              + ("" if not why else " -- FAIL: " + "; ".join(why)))
        failures += bool(why)
    # --resume never reuses a view whose inputs or options changed: killed when the summary
    # was written (every view finished), then resumed with another option (no report: other pictures) or with one
    # image of view 000 touched.
    for label, extra, touch, want_reused, want in (
            ("another option", ["--no-report"], False, 0, old),
            ("an image of view 000 touched", [], True, views - 1, ref)):
        case = work / f"changed-{len(extra)}"
        case.mkdir()
        out = case / "out"
        run(fringe, scan + ["--out", out], {"FRINGE_TEST_KILL_AT": str(len(steps) - 2)})
        if touch:
            img = sorted((proj / "views" / "000").rglob("*.png"))[0]
            st = img.stat()
            os.utime(img, ns=(st.st_atime_ns, st.st_mtime_ns + 1_000_000_000))
        r = run(fringe, scan + ["--out", out, "--resume"] + extra)
        ok = r.returncode == 0
        reused = json.loads((out / "summary.json").read_text())["views_resumed"] if ok else None
        good = ok and reused == want_reused and tree(out) == want
        print(f"--resume with {label}: reused {reused} views (want {want_reused})"
              + ("" if good else f" -- FAIL{'' if ok else ': ' + r.stderr.strip()[:200]}"))
        failures += not good
    print(f"kill_outputs: {len(points) + 2 - failures} of {len(points) + 2} cases consistent")
    if not a.work:
        shutil.rmtree(work, ignore_errors=True)
    sys.exit(1 if failures else 0)


if __name__ == "__main__":
    main()
