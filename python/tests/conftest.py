"""Shared fixtures: a small simulated scan written by the C++ CLI (`fringe simulate`), so every
test can compare the bindings with the C++ program on the same input."""

import os
import pathlib
import subprocess

import pytest

import fringe

# The scaled-down rig the C++ tests use for end-to-end work (320x256 cameras).
RIG_SCALE = 0.25
# The simulated cameras' read noise, for the tests that pass the decoder's noise explicitly (option
# plumbing, CLI equality). The accuracy tests decode with the automatic estimate, as a user would:
# on the quarter-size vdi scan it reads 1.62 DN for these 1.5 DN (it once read ~15 DN, taking the
# uncompensated gamma's harmonics for noise; fixed in phase::EstimateNoise).
SENSOR_NOISE_DN = fringe.SensorOptions().read_noise_dn


def cli_path():
    path = os.environ.get("FRINGE_CLI")
    if not path or not os.path.exists(path):
        pytest.fail("FRINGE_CLI must name the fringe program (ctest sets it)")
    return path


def run_cli(*args):
    """Runs the fringe program; returns its stdout, fails the test with its stderr."""
    result = subprocess.run([cli_path(), *map(str, args)], capture_output=True, text=True)
    if result.returncode != 0:
        pytest.fail(f"fringe {' '.join(map(str, args))} exited {result.returncode}: {result.stderr}")
    return result.stdout


@pytest.fixture(scope="session")
def scan(tmp_path_factory):
    """A one-view simulated scan of the VDI artefacts with a few board poses, by the CLI."""
    out = tmp_path_factory.mktemp("scan") / "vdi"
    run_cli("simulate", "vdi", "--out", out, "--views", 1, "--rig-scale", RIG_SCALE,
            "--calibration-images", 0, "--seed", 7)
    return pathlib.Path(out)


@pytest.fixture(scope="session")
def rig(scan):
    return fringe.Rig.load(scan / "truth" / "rig.json")


@pytest.fixture(scope="session")
def scheme(scan):
    return fringe.Scheme.load(scan / "scheme.json")


@pytest.fixture(scope="session")
def stacks(scan, scheme):
    view = scan / "views" / "000"
    return fringe.read_stack(view / "left", scheme), fringe.read_stack(view / "right", scheme)
