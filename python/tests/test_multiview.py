"""register, fuse and mesh: the bindings' results equal `fringe register` / `fringe fuse` on the
same view clouds (bit-identical poses, the same fused points and mesh), and agree with the
simulator's true poses."""

import json

import numpy as np
import pytest

import fringe
from conftest import RIG_SCALE, SENSOR_NOISE_DN, run_cli

TIMING_KEYS = {"seconds", "time_s", "poisson_s", "total_s", "prepare_s", "overlap_s", "candidates_s",
               "cluster_s", "output_s", "spacing_s", "trim_s", "check_s"}
# A coarse Poisson octree keeps the meshing to about a second (depth 10, the default, takes
# ~35 s on these views on the 2-core CI machine).
POISSON_DEPTH = 6


def without_timings(value):
    if isinstance(value, dict):
        return {k: without_timings(v) for k, v in value.items() if k not in TIMING_KEYS}
    if isinstance(value, list):
        return [without_timings(v) for v in value]
    return value


def matrix_of(pose_json):
    m = np.eye(4)
    m[:3, :3] = pose_json["rotation"]
    m[:3, 3] = pose_json["translation_mm"]
    return m


@pytest.fixture(scope="session")
def views(tmp_path_factory):
    """Two overlapping views of the demo part (with sticky markers) reconstructed by the CLI."""
    root = tmp_path_factory.mktemp("multiview")
    scan = root / "scan"
    run_cli("simulate", "demo", "--out", scan, "--views", 2, "--rig-scale", RIG_SCALE,
            "--calibration-images", 0, "--seed", 3, "--no-truth-maps")
    clouds = []
    for name in ("000", "001"):
        out = root / f"{name}.ply"
        run_cli("reconstruct", scan / "views" / name, "--calib", scan / "truth" / "rig.json",
                "--scheme", scan / "scheme.json", "--out", out, "--noise-sigma", SENSOR_NOISE_DN)
        clouds.append(out)
    return root, scan, clouds


@pytest.fixture(scope="session")
def cli_registration(views):
    root, _, clouds = views
    summary = json.loads(run_cli("register", *clouds, "--out", root / "reg", "--json"))
    return summary, root / "reg" / "poses.json"


def test_register_equals_fringe_register(views, cli_registration):
    _, _, clouds = views
    theirs, poses_path = cli_registration
    result = fringe.register(clouds)
    assert result.names == ["000", "001"]
    assert without_timings(result.summary) == without_timings(theirs)
    poses = {v["view"]: matrix_of(v["world_from_sensor"])
             for v in json.loads(poses_path.read_text())["views"]}
    for name, ours in zip(result.names, result.world_from_sensor):
        np.testing.assert_array_equal(ours, poses[name])


def test_register_against_true_poses(views):
    _, scan, clouds = views
    result = fringe.register(clouds)
    assert result.ok and all(result.placed)
    truth = {v["view"]: matrix_of(v["world_from_sensor"])
             for v in json.loads((scan / "truth" / "poses.json").read_text())["views"]}
    # World = the first view's sensor frame: compare view 1 relative to view 0.
    expected = np.linalg.inv(truth["000"]) @ truth["001"]
    ours = result.world_from_sensor[1]
    rotation_error_deg = np.degrees(np.arccos(np.clip(
        (np.trace(expected[:3, :3].T @ ours[:3, :3]) - 1) / 2, -1, 1)))
    translation_error_mm = np.linalg.norm(expected[:3, 3] - ours[:3, 3])
    # Quarter-resolution cameras (4x larger pixels than the full rig's ~0.01 deg / 0.05 mm).
    rotation_tolerance_deg, translation_tolerance_mm = 0.1, 0.5
    assert rotation_error_deg < rotation_tolerance_deg
    assert translation_error_mm < translation_tolerance_mm


def test_register_inputs_in_memory(views, cli_registration):
    _, _, clouds = views
    plys = [fringe.read_ply(c) for c in clouds]
    markers = [fringe.read_markers(c.with_suffix(".markers.json")) for c in clouds]
    assert all(len(m) > 0 for m in markers)
    from_files = fringe.register(clouds)
    in_memory = fringe.register([p.cloud for p in plys], names=["000", "001"], markers=markers)
    np.testing.assert_array_equal(in_memory.world_from_sensor[1], from_files.world_from_sensor[1])
    with pytest.raises(ValueError, match="one name per view"):
        fringe.register(clouds, names=["a"])
    with pytest.raises(TypeError, match=r"views\[0\]"):
        fringe.register([42])
    with pytest.raises(TypeError, match="RegistrationOptions has no option 'icp_rounds'"):
        fringe.register(clouds, icp_rounds=3)


def test_fuse_and_mesh_equal_fringe_fuse(tmp_path, views, cli_registration):
    _, _, clouds = views
    _, poses_path = cli_registration
    theirs = json.loads(run_cli("fuse", *clouds, "--poses", poses_path, "--out", tmp_path / "f.ply",
                                "--mesh", tmp_path / "m.ply", "--poisson-depth", POISSON_DEPTH,
                                "--json"))
    registration = fringe.register(clouds)
    fused = fringe.fuse(clouds, registration)
    assert fused.ok and fused.summary["status"] == "ok"
    assert without_timings(fused.summary) == without_timings(theirs["fusion"])
    # The PLY stores float32: the same numbers rounded once.
    written = fringe.read_ply(tmp_path / "f.ply").cloud
    np.testing.assert_array_equal(fused.cloud.points.astype(np.float32),
                                  written.points.astype(np.float32))
    assert fused.support.shape == (len(fused.cloud),) and fused.support.max() >= 2

    surface = fringe.mesh(fused, poisson_depth=POISSON_DEPTH)
    assert surface.ok
    ours_mesh, theirs_mesh = without_timings(surface.summary), without_timings(theirs["mesh"])
    # The Poisson cell follows the fused cloud's bounding box, which carries the last-bit
    # difference of the poses' rotation round trip (registration in memory here, poses.json there).
    assert ours_mesh.pop("cell_mm") == pytest.approx(theirs_mesh.pop("cell_mm"), rel=1e-12)
    assert ours_mesh == theirs_mesh
    mesh_file = fringe.Mesh.load(tmp_path / "m.ply")
    np.testing.assert_array_equal(surface.mesh.triangles, mesh_file.triangles)
    np.testing.assert_array_equal(surface.mesh.vertices.astype(np.float32),
                                  mesh_file.vertices.astype(np.float32))
    surface.mesh.save(tmp_path / "ours.stl")
    assert fringe.Mesh.load(tmp_path / "ours.stl").triangles.shape == surface.mesh.triangles.shape

    # Poses as a list of 4x4 matrices: the same fusion up to the matrix -> rotation round trip.
    again = fringe.fuse(clouds, registration.world_from_sensor)
    round_trip_tolerance_mm = 1e-9
    np.testing.assert_allclose(again.cloud.points, fused.cloud.points, rtol=0,
                               atol=round_trip_tolerance_mm)
    with pytest.raises(ValueError, match="one pose per view"):
        fringe.fuse(clouds, registration.world_from_sensor[:1])
    with pytest.raises(TypeError, match="MeshOptions has no option 'depth'"):
        fringe.mesh(fused, depth=8)
