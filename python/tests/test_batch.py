"""fringe.batch: scan folders as tasks on a Dask LocalCluster bound to loopback; the outputs equal
`fringe scan`'s, a failing project is reported without stopping the others, a rerun skips
complete outputs and force redoes them."""

import json
import shutil
import subprocess
import sys

import pytest

import fringe.batch
from conftest import cli_path, run_cli

# Figures that measure the run, not the result.
# checkpoint_mib: the --resume cache written, whose keys hold the output path and the options.
TIMING_KEYS = {"peak_mem_gib", "seconds", "time_s", "checkpoint_mib"}


def without_timings(value):
    if isinstance(value, dict):
        return {k: without_timings(v) for k, v in value.items()
                if k not in TIMING_KEYS and not k.endswith("_s")}
    if isinstance(value, list):
        return [without_timings(v) for v in value]
    return value


@pytest.fixture(scope="module")
def projects(tmp_path_factory):
    root = tmp_path_factory.mktemp("batch")
    first = root / "part-a"
    run_cli("-q", "simulate", "sphere", "--out", first, "--views", 1, "--rig-scale", 0.25,
            "--calibration-images", 0, "--supersampling", 1, "--no-truth-maps", "--seed", 3)
    second = root / "part-b"
    run_cli("-q", "simulate", "sphere", "--out", second, "--views", 1, "--rig-scale", 0.25,
            "--calibration-images", 0, "--supersampling", 1, "--no-truth-maps", "--seed", 4)
    broken = root / "part-broken"
    shutil.copytree(second, broken)
    next((broken / "views" / "000" / "left").glob("*.png")).unlink()
    return root, [first, broken, second]


OPTIONS = dict(write_report=False, mesh={"poisson_depth": 6})


def test_batch_on_a_local_cluster(tmp_path, projects):
    root, folders = projects
    rig = folders[0] / "truth" / "rig.json"
    out = tmp_path / "out"
    rows = fringe.batch.scan_all(folders, out, workers=2, threads=1, calib=rig, **OPTIONS)
    assert [r["status"] for r in rows] == ["ok", "failed", "ok"]
    assert "part-broken" in rows[1]["error"] and ".png" in rows[1]["error"]
    assert not (out / "part-broken").exists(), "a failed scan leaves no output"
    table = json.loads((out / "batch.json").read_text())
    assert [r["status"] for r in table] == ["ok", "failed", "ok"]
    csv_lines = (out / "batch.csv").read_text().splitlines()
    assert len(csv_lines) == 4 and csv_lines[0].startswith("project,output,status,error")
    assert table[0]["points"] > 0 and table[0]["fused_rms_mm"] < 0.1
    # The same result as `fringe scan` on that folder alone.
    cli_out = tmp_path / "cli"
    run_cli("-q", "scan", folders[2], "--out", cli_out, "--calib", rig, "--no-report",
            "--poisson-depth", 6)
    for name in ("views/000.ply", "fused.ply", "mesh.ply", "poses.json", "markers.json"):
        assert (out / "part-b" / name).read_bytes() == (cli_out / name).read_bytes(), name
    ours = json.loads((out / "part-b" / "summary.json").read_text())
    theirs = json.loads((cli_out / "summary.json").read_text())
    assert without_timings(ours) == without_timings(theirs)
    # A rerun skips the complete outputs and tries the failed one again; force redoes all.
    mtime = (out / "part-a" / "summary.json").stat().st_mtime_ns
    rows = fringe.batch.scan_all(folders, out, workers=1, calib=rig, **OPTIONS)
    assert [r["status"] for r in rows] == ["skipped", "failed", "skipped"]
    assert rows[0]["points"] == table[0]["points"]
    assert (out / "part-a" / "summary.json").stat().st_mtime_ns == mtime
    rows = fringe.batch.scan_all(folders[:1], out, workers=1, force=True, calib=rig, **OPTIONS)
    assert rows[0]["status"] == "ok"
    assert (out / "part-a" / "summary.json").stat().st_mtime_ns != mtime


def test_batch_command_line(tmp_path, projects):
    root, folders = projects
    rig = folders[0] / "truth" / "rig.json"
    out = tmp_path / "out"
    run = subprocess.run([sys.executable, "-m", "fringe.batch", folders[0], folders[1], "--out",
                          out, "--calib", rig, "--no-report", "--set", "mesh.poisson_depth=6"],
                         capture_output=True, text=True)
    assert run.returncode == 3, run.stderr  # one project failed
    assert "[2/2]" in run.stderr and "part-broken: failed" in run.stderr
    assert (out / "part-a" / "mesh.ply").exists()
    # Bad input: an unknown option, an output inside a scan folder, two folders of one name.
    bad = subprocess.run([sys.executable, "-m", "fringe.batch", folders[0], "--out", out / "x",
                          "--set", "no_such_option=1"], capture_output=True, text=True)
    assert bad.returncode == 1 and "no_such_option" in bad.stderr
    inside = subprocess.run([sys.executable, "-m", "fringe.batch", folders[0], "--out",
                             folders[0] / "results"], capture_output=True, text=True)
    assert inside.returncode == 1 and "lies inside the scan folder" in inside.stderr
    assert not (folders[0] / "results").exists()
    twin = tmp_path / "other" / "part-a"
    twin.mkdir(parents=True)
    with pytest.raises(ValueError, match="would both write part-a/"):
        fringe.batch.scan_all([folders[0], twin], out)
