"""VDI/VDE 2634-2 figures and mesh deviation: equal to `fringe evaluate --json` on the same
file, and to the known geometry."""

import json

import numpy as np
import pytest

import fringe
from conftest import run_cli


def sphere_points(diameter_mm, n, seed):
    rng = np.random.default_rng(seed)
    d = rng.normal(size=(n, 3))
    d[:, 2] = -np.abs(d[:, 2])  # the half facing a sensor at the origin
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    return np.array([10.0, -20.0, 500.0]) + 0.5 * diameter_mm * d + rng.normal(0, 0.005, size=(n, 3))


def evaluate_cli(path, *args):
    return json.loads(run_cli("evaluate", path, "--json", *args))


def test_sphere_equals_cli_and_truth(tmp_path):
    diameter_mm = 30.0
    path = tmp_path / "sphere.ply"
    fringe.write_ply(path, sphere_points(diameter_mm, 5000, 1))
    cloud = fringe.read_ply(path).cloud  # the same float-rounded points the CLI reads
    ours = fringe.evaluate.sphere(cloud, diameter_mm)
    theirs = evaluate_cli(path, "--artefact", "sphere", "--diameter", diameter_mm)["sphere"]
    for key, value in theirs.items():
        assert ours[key] == value, key
    noise_tolerance_mm = 0.01  # 5 um point noise over 5000 points
    assert abs(ours["diameter_mm"] - diameter_mm) < noise_tolerance_mm
    np.testing.assert_allclose(ours["centre_mm"], [10.0, -20.0, 500.0], atol=noise_tolerance_mm)


def test_ballbar_and_plane_equal_cli(tmp_path):
    a = sphere_points(25.0, 3000, 2)
    b = sphere_points(25.0, 3000, 3) + np.array([150.0, 0.0, 0.0])
    path = tmp_path / "bar.ply"
    fringe.write_ply(path, np.vstack([a, b]))
    cloud = fringe.read_ply(path).cloud
    ours = fringe.evaluate.ballbar(cloud, 25.0, 150.0)
    theirs = evaluate_cli(path, "--artefact", "ballbar", "--diameter", 25.0, "--distance", 150.0)["ballbar"]
    assert ours["status"] == theirs["status"] == "ok"
    assert ours["SD_mm"] == theirs["SD_mm"] and ours["distance_mm"] == theirs["distance_mm"]
    assert abs(ours["SD_mm"]) < 0.01

    rng = np.random.default_rng(4)
    plane = np.column_stack([rng.uniform(-50, 50, 4000), rng.uniform(-50, 50, 4000),
                             500.0 + rng.normal(0, 0.002, 4000)])
    fringe.write_ply(tmp_path / "plane.ply", plane)
    ours = fringe.evaluate.plane(fringe.read_ply(tmp_path / "plane.ply").cloud)
    theirs = evaluate_cli(tmp_path / "plane.ply", "--artefact", "plane")["plane"]
    for key, value in theirs.items():
        assert ours[key] == value, key
    np.testing.assert_allclose(np.abs(ours["normal"]), [0, 0, 1], atol=1e-3)


def test_organized_points_with_nan_are_accepted():
    pts = sphere_points(30.0, 4000, 5).reshape(40, 100, 3)
    pts[::3, ::7] = np.nan
    assert fringe.evaluate.sphere(pts, 30.0)["status"] == "ok"
    with pytest.raises(ValueError, match=r"\(N, 3\)"):
        fringe.evaluate.sphere(np.zeros((10, 2)), 30.0)


def test_deviation_equals_cli_and_known_offsets(tmp_path):
    vertices = np.array([[-100.0, -100.0, 0.0], [100.0, -100.0, 0.0], [100.0, 100.0, 0.0], [-100.0, 100.0, 0.0]])
    triangles = np.array([[0, 1, 2], [0, 2, 3]], dtype=np.int32)
    fringe.write_ply(tmp_path / "mesh.ply", vertices, triangles=triangles)
    offsets = np.array([-0.5, -0.25, 0.0, 0.125, 0.5, 3.0])  # 3 mm: beyond max_distance_mm
    points = np.column_stack([np.linspace(-50, 50, 6), np.zeros(6), offsets])
    fringe.write_ply(tmp_path / "cloud.ply", points)
    stats, distances = fringe.deviation(points, fringe.read_ply(tmp_path / "mesh.ply"))
    np.testing.assert_allclose(np.abs(distances[:5]), np.abs(offsets[:5]), atol=1e-12)
    assert np.isnan(distances[5]) and stats["unmatched"] == 1 and stats["points"] == 5
    theirs = evaluate_cli(tmp_path / "cloud.ply", "--truth", tmp_path / "mesh.ply")["deviation"]
    for key, value in theirs.items():
        assert stats[key] == pytest.approx(value, abs=1e-12), key
    stats2, d2 = fringe.deviation(points.reshape(2, 3, 3), (vertices, triangles))
    assert d2.shape == (2, 3)
    np.testing.assert_array_equal(d2.ravel(), distances)
