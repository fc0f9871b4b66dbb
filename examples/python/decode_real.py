#!/usr/bin/env python3
"""Decode a real capture (../shared/data/slsdk-stereo-phasegray, left camera) and show the
absolute phase with matplotlib when it is installed (otherwise print the figures only).

    PYTHONPATH=build/python python3 examples/python/decode_real.py [--data DIR] [--save phase.png]
"""

import argparse
import os
import pathlib

import numpy as np

import fringe

# ../shared/data beside the source tree, or FRINGE_SHARED_DATA (as the tests read it).
SHARED_DATA = pathlib.Path(os.environ.get("FRINGE_SHARED_DATA",
                                          pathlib.Path(__file__).resolve().parents[2] / ".." / "shared" / "data"))
DEFAULT_DATA = SHARED_DATA / "slsdk-stereo-phasegray"


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", type=pathlib.Path, default=DEFAULT_DATA, help="the capture folder")
    parser.add_argument("--camera", default="L", choices=["L", "R"])
    parser.add_argument("--save", help="write the figure to this file instead of showing it")
    args = parser.parse_args()

    stack_dir = args.data / args.camera
    if not stack_dir.is_dir():
        raise SystemExit(f"{stack_dir}: no such folder (the real data lives in ../shared/data)")
    # The capture's scheme is a preset (4-step period 60 px with offset -pi, 5 Gray bits +
    # complementary, images 0.png ... 9.png).
    scheme = fringe.Scheme.preset("slsdk-phasegray")
    images = fringe.read_stack(stack_dir, scheme)
    result = fringe.decode(images, scheme)
    print(result.brief_report())
    phase = result.absolute_phase
    valid = result.mask
    print(f"absolute phase over {valid.sum()} valid pixels: "
          f"{np.nanmin(phase):.1f} .. {np.nanmax(phase):.1f} projector columns")

    try:
        import matplotlib
        if args.save:
            matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        print("matplotlib is not installed: no figure (apt-get install python3-matplotlib)")
        return
    fig, axes = plt.subplots(1, 2, figsize=(12, 4.5))
    shown = axes[0].imshow(phase, cmap="viridis")
    axes[0].set_title("absolute phase (projector column)")
    fig.colorbar(shown, ax=axes[0])
    axes[1].imshow(result.modulation, cmap="gray")
    axes[1].set_title("modulation (DN)")
    fig.tight_layout()
    if args.save:
        fig.savefig(args.save, dpi=100)
        print(f"wrote {args.save}")
    else:
        plt.show()


if __name__ == "__main__":
    main()
