#!/usr/bin/python3
"""Depth picture of an organized cloud written by `fringe reconstruct` (binary PLY with the
`fringe_grid W H` comment and a grid_index property): depth z mapped to a colour ramp between
its 1st and 99th percentiles, shaded by the normals when present, black where no point.
Writes OUT as a binary PPM, or as JPEG/PNG (through Open3D's image writer, python3-open3d).

usage: depth_picture.py CLOUD.ply OUT.{ppm,jpg,png} [--scale S]   (output size factor, 0.5)
"""
import sys

import numpy as np

TYPES = {"float": "f4", "float32": "f4", "double": "f8", "uint": "u4", "uint32": "u4",
         "int": "i4", "uchar": "u1", "uint8": "u1"}


def read_organized_ply(path):
    with open(path, "rb") as f:
        header = []
        while True:
            line = f.readline().decode("ascii", "replace").strip()
            header.append(line)
            if line == "end_header":
                break
        grid, count, props = None, 0, []
        for line in header:
            words = line.split()
            if words[:2] == ["comment", "fringe_grid"]:
                grid = (int(words[2]), int(words[3]))
            elif words[:2] == ["element", "vertex"]:
                count = int(words[2])
            elif words[:1] == ["property"] and count:
                props.append((words[2], "<" + TYPES[words[1]]))
        if "format binary_little_endian 1.0" not in header or grid is None:
            sys.exit(f"{path}: not an organized binary fringe PLY")
        data = np.fromfile(f, dtype=np.dtype(props), count=count)
    if len(data) != count:
        sys.exit(f"{path}: {len(data)} of {count} vertices")
    return grid, data


def main():
    if len(sys.argv) < 3:
        sys.exit(__doc__)
    scale = float(sys.argv[sys.argv.index("--scale") + 1]) if "--scale" in sys.argv else 0.5
    (w, h), v = read_organized_ply(sys.argv[1])
    z = np.full(w * h, np.nan)
    z[v["grid_index"]] = v["z"]
    z = z.reshape(h, w)
    lo, hi = np.nanpercentile(z, [1, 99])
    t = np.clip((z - lo) / (hi - lo), 0, 1)
    # Near = warm, far = cool (a simple blue-cyan-yellow-red ramp).
    stops = np.array([[0.8, 0.1, 0.1], [1.0, 0.85, 0.2], [0.2, 0.8, 0.9], [0.1, 0.2, 0.7]])
    x = t * (len(stops) - 1)
    i = np.clip(np.floor(np.nan_to_num(x)).astype(int), 0, len(stops) - 2)
    f = (np.nan_to_num(x) - i)[..., None]
    rgb = stops[i] * (1 - f) + stops[i + 1] * f
    if "nz" in v.dtype.names:
        shade = np.full(w * h, 1.0)
        light = np.array([-0.4, -0.5, -0.77])
        light /= np.linalg.norm(light)
        n = np.stack([v["nx"], v["ny"], v["nz"]], axis=1)
        s = np.nan_to_num(n @ light, nan=0.8)
        shade[v["grid_index"]] = 0.35 + 0.65 * np.clip(s, 0, 1)
        rgb *= shade.reshape(h, w)[..., None]
    rgb[np.isnan(z)] = 0
    img = (rgb * 255).astype(np.uint8)
    step = max(1, int(round(1 / scale)))
    img = img[::step, ::step]
    out = sys.argv[2]
    if out.lower().endswith(".ppm"):
        with open(out, "wb") as f:
            f.write(b"P6\n%d %d\n255\n" % (img.shape[1], img.shape[0]))
            f.write(img.tobytes())
    else:
        import open3d as o3d
        if not o3d.io.write_image(out, o3d.geometry.Image(np.ascontiguousarray(img)),
                                   90 if out.lower().endswith((".jpg", ".jpeg")) else 6):
            sys.exit(f"{out}: cannot write")
    print(f"depth {lo:.1f} .. {hi:.1f} mm (1-99 %), {len(v)} points -> {sys.argv[2]}")


if __name__ == "__main__":
    main()
