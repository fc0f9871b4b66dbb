"""decode, reconstruct and the simulator: the bindings' results equal the C++ program's on the
same input (bit-identical where the program writes full precision), and agree with the truth."""

import json
import os
import shutil
import subprocess
import sys

import numpy as np
import pytest

import fringe
from conftest import RIG_SCALE, SENSOR_NOISE_DN, run_cli


def test_simulator_renders_the_images_fringe_simulate_wrote(scan, rig, stacks):
    sim = fringe.Simulator(rig, scene="vdi", views=1, calibration_images=0, seed=7)
    written = fringe.Scheme.load(scan / "scheme.json")
    assert sim.scheme.image_names == written.image_names and sim.scheme.periods_px == written.periods_px
    view = sim.render_view(0)
    assert len(view.left) == len(stacks[0]) == sim.scheme.num_images
    for ours, theirs in zip(view.left + view.right, stacks[0] + stacks[1]):
        np.testing.assert_array_equal(ours, theirs)
    truth = view.left_truth
    assert truth["points"].shape == (rig.left.height, rig.left.width, 3)
    assert truth["valid"].dtype == np.bool_ and truth["valid"].any()
    with pytest.raises(IndexError):
        sim.render_view(1)


def test_decode_equals_fringe_decode(tmp_path, scan, scheme, stacks):
    out = tmp_path / "decoded"
    run_cli("decode", scan / "views" / "000" / "left", "--scheme", scan / "scheme.json", "--out", out)
    result = fringe.decode(stacks[0], scheme)
    for name in ("absolute_phase", "wrapped_phase", "modulation", "background"):
        ours = getattr(result, name)
        assert ours.dtype == np.float32
        np.testing.assert_array_equal(ours, fringe.read_image(out / f"{name}.tiff", float32=True))
    np.testing.assert_array_equal(result.mask, fringe.read_image(out / "mask.png") > 0)
    theirs = json.loads((out / "summary.json").read_text())
    ours = result.summary
    for key in ("time_ms",):  # timing differs between runs
        theirs.pop(key, None)
        ours.pop(key, None)
    assert ours == theirs


def test_decode_options_as_keywords_and_objects(scheme, stacks):
    noise = SENSOR_NOISE_DN
    a = fringe.decode(stacks[0], scheme, noise_sigma_dn=noise, min_modulation_dn=40.0)
    b = fringe.decode(stacks[0], scheme,
                      options=fringe.DecodeOptions(noise_sigma_dn=noise, min_modulation_dn=40.0))
    default = fringe.decode(stacks[0], scheme, noise_sigma_dn=noise)
    np.testing.assert_array_equal(a.mask, b.mask)
    assert a.summary["valid"] < default.summary["valid"]
    assert a.summary["min_modulation_dn"] == 40.0
    # One (N, H, W) array decodes like the list of its planes.
    np.testing.assert_array_equal(
        fringe.decode(np.stack(stacks[0]), scheme, noise_sigma_dn=noise).absolute_phase,
        default.absolute_phase)


def test_decode_phase_matches_truth(rig, scheme, stacks):
    sim = fringe.Simulator(rig, scene="vdi", views=1, calibration_images=0, seed=7)
    truth = sim.render_view(0).left_truth
    result = fringe.decode(stacks[0], scheme)  # the automatic noise estimate
    assert result.summary["noise_source"] == "estimated"
    both = result.mask & truth["valid"]
    assert both.sum() > 0.2 * both.size
    error_px = result.absolute_phase[both] - truth["projector"][..., 0][both]
    # Projector-pixel phase error at this scale and noise (decoder tests: ~0.02 px RMS).
    median_tolerance_px = 0.1
    assert np.median(np.abs(error_px)) < median_tolerance_px


def test_reconstruct_equals_fringe_reconstruct(tmp_path, scan, rig, scheme, stacks):
    out = tmp_path / "view.ply"
    run_cli("reconstruct", scan / "views" / "000", "--calib", scan / "truth" / "rig.json",
            "--scheme", scan / "scheme.json", "--out", out, "--no-markers")
    view = fringe.reconstruct(rig, scheme, *stacks)
    assert view.ok and view.summary["status"] == "ok"
    assert view.points.shape == (rig.left.height, rig.left.width, 3)
    assert np.isnan(view.points[~view.valid]).all() and np.isfinite(view.points[view.valid]).all()
    ply = fringe.read_ply(out)
    assert ply.grid_shape == (view.height, view.width)
    index = ply.grid_index.astype(np.int64)
    np.testing.assert_array_equal(np.flatnonzero(view.valid.ravel()), index)
    # The PLY stores float32: the same numbers rounded once.
    np.testing.assert_array_equal(view.points.reshape(-1, 3)[index].astype(np.float32),
                                  ply.cloud.points.astype(np.float32))
    np.testing.assert_array_equal(view.normals.reshape(-1, 3)[index].astype(np.float32),
                                  ply.cloud.normals.astype(np.float32))
    np.testing.assert_array_equal(view.quality.ravel()[index], ply.cloud.quality)
    assert view.summary["points"] == len(index)
    # The bindings write the same organized PLY.
    # The writer adds its own "written by fringe" and grid comments.
    comments = [c for c in ply.comments if not c.startswith(("fringe_grid", "written by fringe"))]
    fringe.write_ply(tmp_path / "ours.ply", view, comments=comments)
    assert (tmp_path / "ours.ply").read_bytes() == out.read_bytes()


def test_reconstruct_folder_is_fringe_reconstruct(tmp_path, scan):
    # The library call behind the command: the same files byte for byte and the same JSON,
    # the scheme and the bit depth found in the scan folder as the command finds them.
    view = scan / "views" / "000"
    cli_json = json.loads(run_cli("reconstruct", view, "--calib", scan / "truth" / "rig.json",
                                  "--out", tmp_path / "cli.ply", "--json"))
    result = fringe.reconstruct_folder(view, tmp_path / "py.ply",
                                       calib=scan / "truth" / "rig.json")
    assert (tmp_path / "py.ply").read_bytes() == (tmp_path / "cli.ply").read_bytes()
    assert ((tmp_path / "py.markers.json").read_bytes()
            == (tmp_path / "cli.markers.json").read_bytes())
    for key in ("view", "mode"):
        assert result[key] == cli_json[key]
    assert result["mode"] == "stereo"
    # Everything but the times (and the one-line reports, which print them).
    def untimed(d):
        return {k: untimed(v) if isinstance(v, dict) else v for k, v in d.items()
                if k not in ("seconds", "report") and not k.endswith(("_s", "_ms"))}
    assert untimed(result["summary"]) == untimed(cli_json["summary"])
    assert result["markers"]["count"] == cli_json["markers"]["count"]
    assert any(line.endswith("(left)") for line in result["report"])
    # Bad input: a clear error naming the problem, nothing written.
    with pytest.raises(fringe.Error, match="must contain left/"):
        fringe.reconstruct_folder(tmp_path, tmp_path / "none.ply", calib=scan / "truth" / "rig.json")
    with pytest.raises(fringe.Error, match="mode"):
        fringe.reconstruct_folder(view, tmp_path / "none.ply", mode="sideways")
    assert not (tmp_path / "none.ply").exists()


def test_camera_projector_equals_fringe_reconstruct(tmp_path, scan, rig, scheme, stacks):
    # Issue 14 through the bindings: right=None is the left camera against the projector.
    out = tmp_path / "cp.ply"
    run_cli("reconstruct", scan / "views" / "000", "--calib", scan / "truth" / "rig.json",
            "--scheme", scan / "scheme.json", "--mode", "camera-projector", "--out", out)
    view = fringe.reconstruct(rig, scheme, stacks[0])
    assert view.ok and view.summary["points"] > 1000
    ply = fringe.read_ply(out)
    index = ply.grid_index.astype(np.int64)
    np.testing.assert_array_equal(np.flatnonzero(view.valid.ravel()), index)
    np.testing.assert_array_equal(view.points.reshape(-1, 3)[index].astype(np.float32),
                                  ply.cloud.points.astype(np.float32))
    same = fringe.reconstruct_camera_projector(rig, [scheme], [stacks[0]])
    np.testing.assert_array_equal(same.valid, view.valid)
    # Against the truth: the camera-projector baseline is about half the stereo one.
    sim = fringe.Simulator(rig, scene="vdi", views=1, calibration_images=0, seed=7)
    truth = sim.render_view(0).left_truth["points"]
    both = view.valid & np.isfinite(truth).all(axis=2)
    median_tolerance_mm = 2 * 0.05 / RIG_SCALE
    assert np.median(np.linalg.norm(view.points[both] - truth[both], axis=1)) < median_tolerance_mm
    with pytest.raises(fringe.Error, match="stack"):
        fringe.reconstruct_camera_projector(rig, [scheme, scheme], [stacks[0]])


def test_reconstruct_against_truth(rig, scheme, stacks):
    sim = fringe.Simulator(rig, scene="vdi", views=1, calibration_images=0, seed=7)
    truth = sim.render_view(0).left_truth["points"]
    view = fringe.reconstruct(rig, scheme, *stacks)  # the automatic noise estimate
    both = view.valid & np.isfinite(truth).all(axis=2)
    assert both.sum() > 1000
    error_mm = np.linalg.norm(view.points[both] - truth[both], axis=1)
    median_tolerance_mm = 0.05 / RIG_SCALE  # the full-size rig's ~0.05 mm, scaled pixels 4x larger
    assert np.median(error_mm) < median_tolerance_mm


def test_reconstructor_reuse_and_nested_options(rig, scheme, stacks):
    r = fringe.Reconstructor(rig, scheme, remove_outliers=False, decode={"noise_sigma_dn": 2.0})
    a = r.reconstruct(*stacks)
    b = fringe.reconstruct(rig, scheme, *stacks, options=fringe.ReconstructionOptions(
        remove_outliers=False, decode=fringe.DecodeOptions(noise_sigma_dn=2.0)))
    np.testing.assert_array_equal(a.points, b.points)
    assert a.summary["points"] >= fringe.reconstruct(
        rig, scheme, *stacks, decode={"noise_sigma_dn": 2.0}).summary["points"]
    cloud = a.cloud()
    assert len(cloud) == a.summary["points"]
    np.testing.assert_array_equal(cloud.points, a.points[a.valid])


def test_scan_equals_fringe_scan(tmp_path, scan):
    rig_json = scan / "truth" / "rig.json"
    theirs = json.loads(run_cli("scan", scan, "--out", tmp_path / "cli", "--calib", rig_json, "--json"))
    ours = fringe.scan(scan, tmp_path / "py", calib=rig_json)
    assert ours["status"] == theirs["status"] == "ok"
    assert ours["points"] == theirs["points"] > 0
    assert [v["points"] for v in ours["view_results"]] == [v["points"] for v in theirs["view_results"]]
    for ply in (tmp_path / "cli" / "views").glob("*.ply"):
        assert (tmp_path / "py" / "views" / ply.name).read_bytes() == ply.read_bytes()
    with pytest.raises(fringe.Error, match="no-such-folder"):
        fringe.scan(tmp_path / "no-such-folder", tmp_path / "out2", calib=rig_json)


def test_scan_takes_every_stage_option(tmp_path, scan):
    # The scanner's stage options reach their stages: the mesh depth, the fusion's overlap
    # radius, the truth comparison, the report and the projector-column fit.
    rig_json = scan / "truth" / "rig.json"
    options = fringe.ScannerOptions(calib=rig_json, fit_projector_columns=False,
                                    evaluate_truth=False, write_report=False)
    options.mesh.poisson_depth = 5
    options.fusion.spacing_factor = 2.0
    options.registration.refine_icp = False
    assert options.mesh.poisson_depth == 5 and not options.fit_projector_columns
    s = fringe.scan(scan, tmp_path / "o", options)
    assert s["status"] == "ok"
    assert s["mesh"]["poisson_depth"] == 5
    assert s["has_truth"] is False
    assert not (tmp_path / "o" / "report.html").exists()
    default = fringe.scan(scan, tmp_path / "d", calib=rig_json, write_report=False)
    assert default["has_truth"] is True
    assert default["mesh"]["poisson_depth"] > 5


def test_scan_resume_reuses_the_views_of_a_killed_run(tmp_path, scan):
    # fringe.scan(resume=True) after a run killed once its views were finished (as `fringe scan
    # --resume`): every view is reused when the options are the same, none when one changed.
    rig_json = scan / "truth" / "rig.json"
    out = tmp_path / "out"
    script = ("import sys, fringe; fringe.scan(sys.argv[1], sys.argv[2], calib=sys.argv[3], "
              "write_report=False)")

    def run_killed(env_extra):
        env = dict(os.environ, **env_extra)
        return subprocess.run([sys.executable, "-c", script, scan, out, rig_json], env=env,
                              capture_output=True, text=True)

    log = tmp_path / "checkpoints.txt"
    assert run_killed({"FRINGE_TEST_CHECKPOINTS": str(log)}).returncode == 0
    reference = json.loads((out / "summary.json").read_text())
    steps = log.read_text().splitlines()
    # Killed after the last file (the summary) was written, before the folder was committed: the
    # views' checkpoints still exist (as tests/hostile/kill_outputs.py).
    kill_at = len(steps) - 2
    changed = {"fusion": {"spacing_factor": 2.0}}
    for options, want_resumed in (({}, reference["views_ok"]), (changed, 0)):
        shutil.rmtree(out)
        assert run_killed({"FRINGE_TEST_KILL_AT": str(kill_at)}).returncode == -9
        s = fringe.scan(scan, out, calib=rig_json, write_report=False, resume=True, **options)
        assert s["status"] == "ok"
        assert s["views_resumed"] == want_resumed
        if not options:
            assert s["points"] == reference["points"]
