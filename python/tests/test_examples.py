"""The example scripts run (the real-data one skips without ../shared/data, fails in CI)."""

import os
import pathlib
import subprocess
import sys

import pytest

import fringe

SOURCE = pathlib.Path(os.environ.get("FRINGE_SOURCE_DIR", pathlib.Path(__file__).resolve().parents[2]))
EXAMPLES = SOURCE / "examples" / "python"
SHARED = pathlib.Path(os.environ.get("FRINGE_SHARED_DATA", SOURCE / ".." / "shared" / "data"))
REAL = SHARED / "slsdk-stereo-phasegray"


def run(script, *args):
    result = subprocess.run([sys.executable, EXAMPLES / script, *map(str, args)], capture_output=True,
                            text=True, env=dict(os.environ, MPLBACKEND="Agg"))
    assert result.returncode == 0, result.stderr
    return result.stdout


def test_simulate_reconstruct_example(tmp_path):
    out = tmp_path / "view.ply"
    text = run("simulate_reconstruct.py", "--out", out, "--rig-scale", 0.25)
    assert "error against truth" in text
    ply = fringe.read_ply(out)
    assert ply.grid_shape == (256, 320) and len(ply.cloud) > 1000


def test_decode_real_example(tmp_path):
    if not REAL.is_dir():
        if os.environ.get("FRINGE_REQUIRE_SHARED_DATA") == "1":
            pytest.fail(f"{REAL} is missing and FRINGE_REQUIRE_SHARED_DATA=1")
        pytest.skip(f"real data not present: {REAL}")
    text = run("decode_real.py", "--data", REAL, "--save", tmp_path / "phase.png")
    assert "absolute phase over" in text
    # The projector is 1920 columns wide: decoded columns stay inside it (within one 60 px
    # period, the size of a wrong fringe order, which the decoder must not produce).
    low, high = [float(v) for v in text.split("valid pixels: ")[1].split(" projector")[0].split(" .. ")]
    period_px = 60
    assert -period_px < low < high < 1920 + period_px
