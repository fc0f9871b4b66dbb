"""calibrate, Rig.from_opencv and simulate_scan: equal to `fringe calibrate`, `fringe
convert-calib` and `fringe simulate` on the same input, and calibration close to the true rig."""

import json
import os
import pathlib

import numpy as np
import pytest

import fringe
from conftest import run_cli

# Board images at half resolution: enough pixels per ring for the detector at every pose.
BOARD_RIG_SCALE = 0.5
BOARD_IMAGES = 8
SOURCE = pathlib.Path(os.environ.get("FRINGE_SOURCE_DIR", pathlib.Path(__file__).resolve().parents[2]))
SHARED = pathlib.Path(os.environ.get("FRINGE_SHARED_DATA", SOURCE / ".." / "shared" / "data"))


@pytest.fixture(scope="session")
def boards(tmp_path_factory):
    out = tmp_path_factory.mktemp("boards") / "scan"
    run_cli("simulate", "vdi", "--out", out, "--views", 0, "--rig-scale", BOARD_RIG_SCALE,
            "--calibration-images", BOARD_IMAGES, "--seed", 5, "--no-truth-maps")
    return out


@pytest.fixture(scope="session")
def folder_calibration(boards):
    cal = boards / "calibration"
    return fringe.calibrate(cal, fringe.Target.load(cal / "target.json"))


def assert_same_figures(ours, theirs, rel, where="calibration"):
    """Nested dicts/lists equal; floats to a relative tolerance, everything else exactly."""
    assert type(ours) is type(theirs) or {type(ours), type(theirs)} <= {int, float}, where
    if isinstance(ours, dict):
        assert ours.keys() == theirs.keys(), where
        for k in ours:
            assert_same_figures(ours[k], theirs[k], rel, f"{where}.{k}")
    elif isinstance(ours, list):
        assert len(ours) == len(theirs), where
        for i, (a, b) in enumerate(zip(ours, theirs)):
            assert_same_figures(a, b, rel, f"{where}[{i}]")
    elif isinstance(ours, float):
        assert ours == pytest.approx(theirs, rel=rel, abs=0), where
    else:
        assert ours == theirs, where


def test_calibrate_folder_equals_fringe_calibrate(tmp_path, boards, folder_calibration):
    cal = boards / "calibration"
    run_cli("calibrate", cal, "--target", cal / "target.json", "--out", tmp_path / "rig.json")
    written = json.loads((tmp_path / "rig.json").read_text())
    rig, summary = folder_calibration
    assert isinstance(rig, fringe.Rig) and summary["stereo"] and summary["success"]
    assert rig.to_dict()["cameras"] == written["cameras"]
    # The standard deviations come from Ceres' covariance, whose dense linear algebra may sum in
    # another order from run to run (1e-15 relative, seen in CI): equal to 1e-9, all else exact.
    assert_same_figures({k: v for k, v in summary.items() if k in written["calibration"]},
                        written["calibration"], rel=1e-9)

    # Against the true rig the simulator used (scaled reference rig).
    truth = fringe.Rig.load(boards / "truth" / "rig.json")
    focal_tolerance_px = 0.5  # 8 noisy half-resolution board poses
    assert abs(rig.left.fx - truth.left.fx) < focal_tolerance_px
    assert abs(rig.right.fy - truth.right.fy) < focal_tolerance_px
    baseline_tolerance_mm = 0.2
    assert abs(rig.baseline_mm - truth.baseline_mm) < baseline_tolerance_mm


def test_calibrate_in_memory_equals_folder(boards, folder_calibration):
    cal = boards / "calibration"
    target = fringe.Target.load(cal / "target.json")
    left = [fringe.read_image(p) for p in sorted((cal / "left").glob("*.png"))]
    right = [fringe.read_image(p) for p in sorted((cal / "right").glob("*.png"))]
    assert len(left) == len(right) == BOARD_IMAGES
    from_folder, _ = folder_calibration
    in_memory, summary = fringe.calibrate((left, right), target)
    assert in_memory.to_dict() == from_folder.to_dict()
    camera, mono = fringe.calibrate(left, target)
    assert isinstance(camera, fringe.Camera) and not mono["stereo"]
    truth = fringe.Rig.load(boards / "truth" / "rig.json")
    focal_tolerance_px = 0.5  # 8 noisy half-resolution board poses, one camera
    assert abs(camera.fx - truth.left.fx) < focal_tolerance_px
    with pytest.raises(ValueError, match="same number of images"):
        fringe.calibrate((left, right[:-1]), target)
    with pytest.raises(TypeError, match="DetectionOptions has no option 'x'"):
        fringe.calibrate(left, target, detection={"x": 1})


def test_rig_from_opencv_equals_convert_calib(tmp_path):
    data = SHARED / "slsdk-stereo-phasegray"
    if not data.is_dir():
        if os.environ.get("FRINGE_REQUIRE_SHARED_DATA") == "1":
            pytest.fail(f"{data} is missing and FRINGE_REQUIRE_SHARED_DATA=1")
        pytest.skip(f"real data not present: {data}")
    files = [data / "intrinsic.yml", data / "extrinsic.yml"]
    run_cli("convert-calib", *files, "--out", tmp_path / "rig.json", "--width", 2048, "--height", 1536)
    written = json.loads((tmp_path / "rig.json").read_text())
    rig = fringe.Rig.from_opencv(files, 2048, 1536)
    assert rig.to_dict()["cameras"] == written["cameras"]
    with pytest.raises(fringe.Error, match="extrinsic.yml|right"):
        fringe.Rig.from_opencv(data / "intrinsic.yml", 2048, 1536)  # no right_from_left


def test_simulate_scan_equals_fringe_simulate(tmp_path, scan, scheme, stacks):
    from conftest import RIG_SCALE
    rig = fringe.Rig.reference().scaled(RIG_SCALE)
    summary = fringe.simulate_scan(tmp_path / "sim", rig, scene="vdi", views=1, calibration_images=0,
                                   seed=7)
    assert summary["views"] == 1 and summary["fringe_images"] == scheme.num_images
    view = tmp_path / "sim" / "views" / "000"
    for ours, theirs in zip(fringe.read_stack(view / "left", scheme) + fringe.read_stack(view / "right", scheme),
                            stacks[0] + stacks[1]):
        np.testing.assert_array_equal(ours, theirs)
    with pytest.raises(fringe.Error, match="scene"):
        fringe.simulate_scan(tmp_path / "bad", rig, scene="no-such-scene", views=1)


# ---- Camera + projector (issue 14) ----

# Half resolution and five poses: the figures of `fringe calibrate`'s C++ test
# (tests/integration/slmaster_camproj_test.cc) at the same scale.
PROJECTOR_FOCAL_TOL_PCT = 0.1
PROJECTOR_PRINCIPAL_TOL_PX = 1.0
PROJECTOR_TRANSLATION_TOL_MM = 0.3


def test_calibrate_projector_equals_fringe_calibrate(tmp_path):
    truth = fringe.Rig.reference().scaled(BOARD_RIG_SCALE)
    folder = tmp_path / "projector"
    poses = fringe.simulate_projector_calibration(folder, truth, fringe.Target(),
                                                  poses=5, seed=9)
    assert len(poses) == 5 and poses[0].shape == (4, 4)
    target = fringe.Target.load(folder / "target.json")
    rig, summary = fringe.calibrate_projector(folder, target)
    assert summary["success"], summary["message"]
    assert summary["layout"] == "camera-projector"
    assert summary["names"] == ["000", "001", "002", "003", "004"]
    run_cli("calibrate", folder, "--target", folder / "target.json", "--out", tmp_path / "rig.json")
    written = json.loads((tmp_path / "rig.json").read_text())
    assert rig.to_dict()["cameras"] == written["cameras"]
    assert rig.to_dict()["projector_from_left"] == written["projector_from_left"]
    ours = {k: v for k, v in summary.items() if k not in ("layout", "success", "message", "report", "names")}
    # Standard deviations from Ceres' covariance: equal to 1e-9 (see the folder test above).
    assert_same_figures(ours, written["calibration"], rel=1e-9)
    # Against the true projector.
    d, t = rig.to_dict(), truth.to_dict()
    p, q = d["cameras"]["projector"], t["cameras"]["projector"]
    assert abs(p["fx"] - q["fx"]) / q["fx"] * 100 < PROJECTOR_FOCAL_TOL_PCT
    assert np.hypot(p["cx"] - q["cx"], p["cy"] - q["cy"]) < PROJECTOR_PRINCIPAL_TOL_PX
    est = np.asarray(d["projector_from_left"]["translation_mm"])
    true = np.asarray(t["projector_from_left"]["translation_mm"])
    assert np.linalg.norm(est - true) < PROJECTOR_TRANSLATION_TOL_MM
    # A folder without fringe stacks is refused with the folder's name.
    with pytest.raises(fringe.Error, match="no board pose folder"):
        fringe.calibrate_projector(tmp_path, target)


def test_simulate_equals_fringe_simulate_in_memory(scan, scheme, stacks):
    from conftest import RIG_SCALE
    rig = fringe.Rig.reference().scaled(RIG_SCALE)
    views = fringe.simulate(rig, scene="vdi", views=1, seed=7)
    assert len(views) == 1
    view = views[0]
    # The images `fringe simulate` wrote (the conftest scan), and the truth of the same view.
    assert len(view.left) == len(view.right) == scheme.num_images
    for ours, theirs in zip(view.left + view.right, stacks[0] + stacks[1]):
        np.testing.assert_array_equal(ours, theirs)
    truth = fringe.Simulator(rig, scene="vdi", views=1, calibration_images=0, seed=7).render_view(0)
    np.testing.assert_array_equal(view.left_truth["projector"], truth.left_truth["projector"])
    np.testing.assert_array_equal(view.world_from_sensor, truth.world_from_sensor)
    with pytest.raises(fringe.Error, match="scene"):
        fringe.simulate(rig, scene="no-such-scene", views=1)
