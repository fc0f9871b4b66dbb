"""register, fuse and mesh: the bindings' results equal `fringe register` / `fringe fuse` on the
same view clouds (bit-identical poses, the same fused points and mesh), and agree with the
simulator's true poses."""

import json

import numpy as np
import pytest

import fringe
from conftest import RIG_SCALE, SENSOR_NOISE_DN, run_cli

TIMING_KEYS = {"seconds", "time_s", "poisson_s", "total_s", "prepare_s", "overlap_s", "candidates_s",
               "cluster_s", "output_s", "spacing_s", "trim_s", "check_s",
               "project_s"}
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
    assert ours_mesh.pop("surface_cells") == pytest.approx(theirs_mesh.pop("surface_cells"),
                                                           rel=1e-9)
    # The projection's RMS is summed over vertices whose moves carry that same last-bit difference.
    assert ours_mesh.pop("projection_rms_mm") == pytest.approx(
        theirs_mesh.pop("projection_rms_mm"), rel=1e-12)
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


def test_every_fusion_and_mesh_option_is_bound_and_takes_effect(views, cli_registration):
    _, _, clouds = views
    registration = fringe.register(clouds)
    # Every field round-trips through the bound options (values inside the C++ ranges, none a
    # default).
    fusion_fields = dict(spacing_factor=2.5, seed_factor=1.5, border_seed_factor=2.5,
                         border_seed_px=4, registration_rms_mm=0.03,
                         registration_factor=2.0, max_normal_angle_deg=40.0, lateral_sigma=0.75,
                         max_disagreement=5.0, max_iterations=7, convergence_mm=2e-3,
                         max_moving_fraction=0.01, modulation_half_dn=12.0, residual_half_px=0.6,
                         min_cos_view=0.2, border_ramp_px=4, border_trim_px=2,
                         one_view_cluster_border_px=5, smooth_radius_px=2, min_border_hole_px=20,
                         max_fit_error_px=3.0, max_spacing_ratio=10.0)
    options = fringe.FusionOptions(**fusion_fields)
    for name, value in fusion_fields.items():
        assert getattr(options, name) == value, name
    assert fringe.fuse(clouds, registration, options=options).ok

    base = fringe.fuse(clouds, registration).summary
    assert base["trimmed"] + base["absorbed"] > 0 and base["single_coverage_noise_mm"] > 0

    def fused(**fields):
        result = fringe.fuse(clouds, registration, **fields)
        assert result.ok
        return result.summary

    # No border trim: nothing trimmed or absorbed, more points pass through.
    no_trim = fused(border_trim_px=0)
    assert no_trim["trimmed"] == 0 and no_trim["absorbed"] == 0
    assert no_trim["passed_through"] > base["passed_through"]
    # No single-coverage smoothing: no noise estimate is made.
    assert fused(smooth_radius_px=0)["single_coverage_noise_mm"] == 0
    # Sparser seeds: fewer clusters; without the wider seed radius near borders: more.
    assert fused(seed_factor=2.0)["clusters"] < base["clusters"]
    assert fused(border_seed_px=0)["clusters"] > base["clusters"]
    assert fused(border_seed_factor=1.0)["clusters"] > base["clusters"]
    # A loose convergence threshold settles every centre after the first update.
    loose = fused(convergence_mm=10.0, max_moving_fraction=0.0)
    assert loose["iterations"] == 1 and loose["converged"] and loose["moving_centres"] == 0
    # Every centre must settle: at least as many iterations as the default's 0.1 % rule.
    assert fused(max_moving_fraction=0.0)["iterations"] >= base["iterations"]
    # Only outranked one-view clusters dropped: fewer absorbed clusters.
    assert (fused(one_view_cluster_border_px=0)["absorbed_clusters"]
            < base["absorbed_clusters"])
    # Larger holes only make a border: fewer points near one, fewer trimmed.
    assert fused(min_border_hole_px=100000)["trimmed"] < base["trimmed"]
    # The weights (border ramp) decide which view seeds: another set of centres.
    assert fused(border_ramp_px=0)["clusters"] != base["clusters"]

    fused_cloud = fringe.fuse(clouds, registration)
    coarse = fringe.mesh(fused_cloud, poisson_depth=POISSON_DEPTH).summary
    cell_mm = coarse["cell_mm"]
    # The automatic depth from a resolution / a cell size just above depth 6's cell is 6.
    by_resolution = fringe.mesh(fused_cloud, resolution_mm=1.01 * cell_mm).summary
    assert by_resolution["poisson_depth"] == POISSON_DEPTH
    by_spacing = fringe.mesh(fused_cloud,
                             cell_spacings=1.01 * cell_mm / coarse["spacing_mm"]).summary
    assert by_spacing["poisson_depth"] == POISSON_DEPTH
    assert fringe.mesh(fused_cloud, max_auto_depth=5).summary["poisson_depth"] == 5
    # Two Poisson pieces when asked (or for surfaces of 2 * min_cells_per_piece cells), joined.
    assert fringe.mesh(fused_cloud).summary["poisson_pieces"] == 1
    assert fringe.mesh(fused_cloud, poisson_pieces=1, min_cells_per_piece=1).summary[
        "poisson_pieces"] == 1
    two = fringe.mesh(fused_cloud, min_cells_per_piece=1, piece_margin_cells=8,
                      max_seam_unmatched=1.0).summary
    assert two["poisson_pieces"] == 2 and two["seam_vertices"] > 0
    assert fringe.mesh(fused_cloud, poisson_pieces=2,
                       max_seam_unmatched=1.0).summary["poisson_pieces"] == 2
    strict = fringe.mesh(fused_cloud, poisson_pieces=2, max_seam_unmatched=0.0).summary
    assert strict["seam_refused"] == (strict["seam_unmatched"] > 0)
    mesh_options = fringe.MeshOptions(library=fringe.MeshLibrary.cgal, resolution_mm=0.5,
                                      cell_spacings=3.0, max_auto_depth=9)
    assert mesh_options.library == fringe.MeshLibrary.cgal
    assert (mesh_options.resolution_mm, mesh_options.cell_spacings,
            mesh_options.max_auto_depth) == (0.5, 3.0, 9)
    # The library is CGAL's Poisson when asked (a small sphere: CGAL's Delaunay refinement is
    # slow on a scan-sized cloud).
    golden = np.pi * (3 - np.sqrt(5))
    k = np.arange(2000)
    z = 1 - 2 * (k + 0.5) / len(k)
    ring = np.sqrt(1 - z * z)
    normals = np.stack([ring * np.cos(golden * k), ring * np.sin(golden * k), z], axis=1)
    sphere = fringe.PointCloud(20.0 * normals, normals=normals)
    by_cgal = fringe.mesh(sphere, library=fringe.MeshLibrary.cgal)
    assert by_cgal.ok and by_cgal.summary["library"] == "cgal"
    assert fringe.mesh(sphere).summary["library"] == "open3d"
