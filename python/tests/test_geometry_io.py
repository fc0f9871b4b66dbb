"""Cameras, rigs, schemes, patterns, images and PLY files against the C++ program's files."""

import json

import numpy as np
import pytest

import fringe
from conftest import run_cli


def test_camera_project_matches_pinhole_model_without_distortion():
    cam = fringe.Camera(width=640, height=480, fx=800.0, fy=810.0, cx=320.5, cy=240.25)
    p = np.array([[10.0, -5.0, 500.0], [0.0, 0.0, 300.0], [-40.0, 25.0, 800.0]])
    expected = np.stack([cam.fx * p[:, 0] / p[:, 2] + cam.cx, cam.fy * p[:, 1] / p[:, 2] + cam.cy], 1)
    np.testing.assert_allclose(cam.project(p), expected, rtol=0, atol=1e-12)
    np.testing.assert_allclose(cam.K, [[800, 0, 320.5], [0, 810, 240.25], [0, 0, 1]])


def test_camera_unproject_inverts_project_with_distortion():
    cam = fringe.Camera.reference_camera()
    cam.k1, cam.k2, cam.p1, cam.p2 = -0.2, 0.05, 1e-3, -5e-4
    rng = np.random.default_rng(3)
    p = np.column_stack([rng.uniform(-60, 60, 50), rng.uniform(-50, 50, 50), rng.uniform(400, 600, 50)])
    xy = cam.unproject(cam.project(p))
    tolerance_normalized = 1e-10  # the C++ Newton undistortion converges to < 1e-12
    np.testing.assert_allclose(xy, p[:, :2] / p[:, 2:], rtol=0, atol=tolerance_normalized)
    rays = cam.ray(cam.project(p))
    np.testing.assert_allclose(np.linalg.norm(rays, axis=1), 1.0, atol=1e-12)


def test_rig_round_trip_and_json_equal_to_file(tmp_path, rig):
    path = tmp_path / "rig.json"
    rig.save(path)
    again = fringe.Rig.load(path)
    assert again.left == rig.left and again.right == rig.right
    np.testing.assert_array_equal(again.right_from_left, rig.right_from_left)
    assert json.loads(path.read_text())["cameras"] == rig.to_dict()["cameras"]
    assert rig.baseline_mm == pytest.approx(200.0, abs=1e-9)  # the reference rig's baseline


def test_rig_scaled_matches_cli_rig(rig):
    from conftest import RIG_SCALE
    scaled = fringe.Rig.reference().scaled(RIG_SCALE)
    assert scaled.left == rig.left and scaled.right == rig.right


def test_rig_load_error_names_the_file(tmp_path):
    bad = tmp_path / "bad.json"
    bad.write_text('{"format": "fringe-rig"}')
    with pytest.raises(fringe.Error, match="bad.json"):
        fringe.Rig.load(bad)
    with pytest.raises(fringe.Error, match="missing.json"):
        fringe.Rig.load(tmp_path / "missing.json")


def test_scheme_presets_and_manifest_round_trip(tmp_path):
    presets = fringe.Scheme.presets()
    assert "heterodyne-4x3" in presets
    # Other tools' codecs are presets too (docs/formats.md, "Other tools' codecs").
    for name in ("slstudio-phaseshift2x3", "slstudio-phaseshift2p1", "slstudio-phaseshiftnstep",
                 "opencv-graycode", "opencv-ftp", "opencv-faps", "slmaster-sinus-comple-gray",
                 "slmaster-three-frequency-heterodyne"):
        assert name in presets
    for name in presets:
        scheme = fringe.Scheme.preset(name, 1280, 800)
        assert scheme.num_images > 0 and scheme.projector_width == 1280
    ftp = fringe.Scheme.preset("opencv-ftp", 800, 600, counts=[20], markers=70)
    assert ftp.to_dict()["phase_retrieval"] == "ftp" and ftp.to_dict()["markers"]["spacing_px"] == 70
    assert fringe.Scheme.preset("slmaster-three-frequency-heterodyne", steps=3).num_images == 9
    assert fringe.Scheme.preset("opencv-graycode", image_names="cam2_%d.png").image_names[0] == "cam2_1.png"
    # The alias keeps its capture's parameters unless sizes are given.
    assert fringe.Scheme.preset("slsdk-phasegray").projector_width == 1920
    scheme = fringe.Scheme.preset("heterodyne-4x3", 640, 400)
    assert scheme.num_images == 12 and scheme.projector_width == 640
    scheme.save(tmp_path / "s.json")
    again = fringe.Scheme.load(tmp_path / "s.json")
    assert again.to_dict() == scheme.to_dict()
    assert fringe.Scheme.from_dict(scheme.to_dict()).to_dict() == scheme.to_dict()
    with pytest.raises(fringe.Error):
        fringe.Scheme.preset("no-such-preset")


def test_patterns_equal_the_cli_pattern_images(tmp_path):
    out = tmp_path / "patterns"
    run_cli("patterns", "--scheme", "gray+4", "--width", 320, "--height", 200, "--gamma", 2.2, "--out", out)
    scheme = fringe.Scheme.load(out / "manifest.json")
    ours = fringe.patterns(fringe.Scheme.preset("gray+4", 320, 200), precompensate_gamma=2.2)
    theirs = fringe.read_stack(out, scheme)
    assert len(ours) == len(theirs) == scheme.num_images
    for a, b in zip(ours, theirs):
        assert a.dtype == np.uint8 and a.shape == (200, 320)
        np.testing.assert_array_equal(a, b)
    # The scheme states its pre-compensation; patterns() follows it without a second knob.
    assert scheme.gamma_precompensation == 2.2
    for a, b in zip(fringe.patterns(scheme), theirs):
        np.testing.assert_array_equal(a, b)


def test_image_round_trip(tmp_path):
    image = (np.arange(48 * 64, dtype=np.uint32) % 4096).astype(np.uint16).reshape(48, 64)
    fringe.write_image(tmp_path / "a.png", image)
    np.testing.assert_array_equal(fringe.read_image(tmp_path / "a.png"), image)
    with pytest.raises(fringe.Error, match="nothing.png"):
        fringe.read_image(tmp_path / "nothing.png")


def test_ply_round_trip_keeps_attributes(tmp_path):
    rng = np.random.default_rng(1)
    n = 100
    points = rng.normal(size=(n, 3)) * 100
    normals = rng.normal(size=(n, 3))
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    colors = rng.integers(0, 256, size=(n, 3), dtype=np.uint8)
    quality = rng.uniform(0, 50, n).astype(np.float32)
    triangles = np.array([[0, 1, 2], [2, 3, 4]], dtype=np.int32)
    for ascii in (False, True):
        path = tmp_path / f"c{int(ascii)}.ply"
        fringe.write_ply(path, points, normals=normals, colors=colors, quality=quality, ascii=ascii)
        ply = fringe.read_ply(path)
        cloud = ply.cloud
        assert len(cloud) == n and cloud.intensity is None
        # Positions and normals are stored as float (docs/formats.md); ASCII prints each float
        # with 9 significant digits (read back within 5e-9 relative), binary stores it exactly.
        rtol = 5e-9 if ascii else 0
        np.testing.assert_allclose(cloud.points, points.astype(np.float32), rtol=rtol, atol=0)
        np.testing.assert_allclose(cloud.normals, normals.astype(np.float32), rtol=rtol, atol=0)
        np.testing.assert_array_equal(cloud.colors, colors)
        np.testing.assert_array_equal(cloud.quality, quality)
        assert ply.triangles.shape == (0, 3) and ply.grid_shape is None
    # With triangles the file is a mesh (io::WritePly of a TriangleMesh): normals and colours kept.
    fringe.write_ply(tmp_path / "m.ply", points, normals=normals, colors=colors, triangles=triangles)
    ply = fringe.read_ply(tmp_path / "m.ply")
    np.testing.assert_array_equal(ply.triangles, triangles)
    np.testing.assert_array_equal(ply.cloud.colors, colors)
    mesh = fringe.Mesh.load(tmp_path / "m.ply")
    np.testing.assert_array_equal(mesh.triangles, triangles)
    np.testing.assert_array_equal(mesh.vertices, points.astype(np.float32).astype(np.float64))
    with pytest.raises(ValueError, match="leave out"):
        fringe.write_ply(tmp_path / "q.ply", points, quality=quality, triangles=triangles)
    with pytest.raises(fringe.Error, match="out of range|index"):
        fringe.Mesh(points, np.array([[0, 1, n]], dtype=np.int32))


def test_point_cloud_arrays_are_views_of_the_cloud():
    cloud = fringe.PointCloud(np.zeros((5, 3)))
    view = cloud.points
    view[2] = [1.0, 2.0, 3.0]
    np.testing.assert_array_equal(cloud.points[2], [1.0, 2.0, 3.0])
    assert cloud.normals is None
    with pytest.raises(ValueError, match="one normal per point"):
        cloud.normals = np.zeros((4, 3))
