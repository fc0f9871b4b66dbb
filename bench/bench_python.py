#!/usr/bin/env python3
"""Overhead of the Python bindings on one-view reconstruction (issue 16).

    PYTHONPATH=build/python python3 bench/bench_python.py [--json] [--repeats 7] [--rig-scale 1]

The same view (the simulator's demo part on the reference rig) is reconstructed through
fringe.Reconstructor in this process. Per call, the C++ reconstruction times itself
(summary timing_s.total, util::Timer around ViewReconstructor::Reconstruct); the Python wall
time around the call adds what the bindings cost: wrapping the numpy stacks as cv::Mat, the GIL
release, and wrapping the result (points, normals, quality, valid viewed without copying).
Overhead = median(python - C++) / median(C++). Prints one JSON object with --json.
"""

import argparse
import json
import statistics
import time

import numpy as np

import fringe


def main():
    parser = argparse.ArgumentParser(description="Python binding overhead on fringe.reconstruct")
    parser.add_argument("--json", action="store_true", help="print one JSON object")
    parser.add_argument("--repeats", type=int, default=7, help="timed calls (after one warm-up)")
    parser.add_argument("--rig-scale", type=float, default=1.0, help="camera resolution scale")
    parser.add_argument("--noise-sigma", type=float, default=fringe.SensorOptions().read_noise_dn,
                        help="camera noise given to the decoder, DN (default: the simulator's read "
                             "noise; 0 = estimate from the images)")
    args = parser.parse_args()

    rig = fringe.Rig.reference().scaled(args.rig_scale) if args.rig_scale != 1 else fringe.Rig.reference()
    sim = fringe.Simulator(rig, scene="demo", views=1, calibration_images=0, seed=1)
    view = sim.render_view(0)
    left, right = view.left, view.right
    reconstructor = fringe.Reconstructor(rig, sim.scheme, decode={"noise_sigma_dn": args.noise_sigma})
    reconstructor.reconstruct(left, right)  # warm-up (TBB threads, page faults)

    python_s, cpp_s, points = [], [], 0
    for _ in range(args.repeats):
        start = time.perf_counter()
        result = reconstructor.reconstruct(left, right)
        cloud = result.points  # the organized cloud as numpy (a view)
        elapsed = time.perf_counter() - start
        python_s.append(elapsed)
        cpp_s.append(result.summary["timing_s"]["total"])
        points = int(np.count_nonzero(result.valid))
        assert cloud.base is not None  # no copy was made
    py_med, cpp_med = statistics.median(python_s), statistics.median(cpp_s)
    overhead = statistics.median(p - c for p, c in zip(python_s, cpp_s)) / cpp_med
    out = {
        "benchmark": "bench_python",
        "image_size": [rig.left.width, rig.left.height],
        "images_per_camera": len(left),
        "points": points,
        "noise_sigma_dn": args.noise_sigma,
        "repeats": args.repeats,
        "python_s_median": py_med,
        "cpp_s_median": cpp_med,
        "python_over_cpp": py_med / cpp_med,
        "binding_overhead_s_median": py_med - cpp_med,
        "binding_overhead_fraction": overhead,
        "target_fraction": 0.05,
    }
    if args.json:
        print(json.dumps(out))
    else:
        print(f"{rig.left.width}x{rig.left.height}, {len(left)} images per camera, {points} points")
        print(f"reconstruct: Python {py_med * 1e3:.1f} ms, C++ {cpp_med * 1e3:.1f} ms (median of "
              f"{args.repeats}), ratio {py_med / cpp_med:.4f}; binding overhead {overhead * 100:.2f} % "
              f"(target <= 5 %)")


if __name__ == "__main__":
    main()
