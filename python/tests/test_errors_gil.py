"""Bad input raises with fringe's message; long calls release the GIL."""

import threading
import time

import numpy as np
import pytest

import fringe


def test_wrong_image_type_and_shape(scheme, stacks):
    floats = [s.astype(np.float32) for s in stacks[0]]
    with pytest.raises(TypeError, match=r"images\[0\]: expected a uint8 or uint16 image"):
        fringe.decode(floats, scheme)
    with pytest.raises(ValueError, match=r"images\[1\]: expected a 2-D image"):
        fringe.decode([stacks[0][0], np.zeros((2, 2, 2), np.uint8)], scheme)
    with pytest.raises(TypeError, match="expected a list"):
        fringe.decode(42, scheme)


def test_wrong_number_of_images_is_fringe_error(rig, scheme, stacks):
    with pytest.raises(fringe.Error) as error:
        fringe.decode(stacks[0][:-1], scheme)
    assert str(error.value)  # the library's message is carried
    with pytest.raises(fringe.Error):
        fringe.reconstruct(rig, scheme, stacks[0][:-1], stacks[1])


def test_options_are_checked_and_named(scheme, stacks):
    with pytest.raises(TypeError, match="DecodeOptions has no option 'noise'"):
        fringe.decode(stacks[0], scheme, noise=2.0)
    with pytest.raises(fringe.Error, match="noise_sigma_dn"):
        fringe.decode(stacks[0], scheme, noise_sigma_dn=-1.0)
    with pytest.raises(TypeError, match="ReconstructionOptions.matching has no option 'x'"):
        fringe.ReconstructionOptions(matching={"x": 1})
    with pytest.raises(TypeError, match="DecodeOptions.repair_orders"):
        fringe.DecodeOptions(repair_orders="yes")


def test_non_contiguous_images_are_accepted(scheme, stacks):
    # A Fortran-ordered copy holds the same pixels in another layout.
    fortran = [np.asfortranarray(s) for s in stacks[0]]
    np.testing.assert_array_equal(fringe.decode(fortran, scheme).absolute_phase,
                                  fringe.decode(stacks[0], scheme).absolute_phase)


def test_read_ply_error_names_the_file(tmp_path):
    bad = tmp_path / "truncated.ply"
    bad.write_bytes(b"ply\nformat binary_little_endian 1.0\nelement vertex 10\nproperty float x\n"
                    b"property float y\nproperty float z\nend_header\n\x00\x00")
    with pytest.raises(fringe.Error, match="truncated.ply"):
        fringe.read_ply(bad)


def _ticks_while(target):
    """Pure-Python loop iterations of this thread while `target` runs in another thread: they
    advance only while this thread holds the GIL."""
    worker = threading.Thread(target=target)
    ticks = 0
    worker.start()
    while worker.is_alive():
        ticks += 1
    worker.join()
    return ticks


def test_long_call_releases_the_gil(rig, scheme, stacks):
    reconstructor = fringe.Reconstructor(rig, scheme)
    start = time.perf_counter()
    reconstructor.reconstruct(*stacks)
    calls = max(3, int(0.5 / max(time.perf_counter() - start, 1e-3)))  # about half a second
    start = time.perf_counter()
    ticks = _ticks_while(lambda: [reconstructor.reconstruct(*stacks) for _ in range(calls)])
    busy_s = time.perf_counter() - start
    # The same duration in a call known to release the GIL.
    reference = _ticks_while(lambda: time.sleep(busy_s))
    # Released, this thread keeps a good share of its sleeping-call rate (the reconstruction's
    # TBB threads compete for the cores); held, it would run only between calls (a few %).
    min_share = 0.1
    assert ticks > min_share * reference, (ticks, reference)
