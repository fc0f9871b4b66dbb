#!/usr/bin/env python3
"""Hostile-input sweep of the fringe CLI (issue 15): hundreds of broken, hostile or absurd inputs,
each run through the command that reads it, each judged by the same rules:

  * the exit code is 1 (error, no result) or 2 (usage), never 0 and never a signal;
  * the message names the offending file (or flag) and is fringe's own (no "internal error", no
    escaped C++ exception, no sanitizer or abort text);
  * nothing is left in the output folder (no result, no temporary), and the inputs are unchanged;
  * the run ends within a time limit under a memory limit (no unbounded allocation).

Valid inputs come from the CLI itself (a tiny simulated scan, its reconstruction); every case
mutates one of them. Usage:
  hostile_sweep.py --fringe build/fringe [--work DIR] [--table] [--only CLASS]
Prints one line per failing case and, with --table, a Markdown table per class (docs/benchmarks.md).
Exit status 0 when every case is handled cleanly.
"""

import argparse
import hashlib
import json
import os
import resource
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

TIME_LIMIT_S = 60
MEMORY_LIMIT_BYTES = 3 << 30  # far above what these tiny inputs need; catches runaway allocation
BAD_TEXT = ("internal error", "terminate called", "AddressSanitizer", "runtime error:",
            "Segmentation", "std::", "what():", "Aborted", "basic_string", "nlohmann")


def tree_digest(path):
    """Digest of every file (names, sizes, contents) under path, or of the file itself."""
    h = hashlib.sha256()
    p = Path(path)
    if p.is_symlink():
        h.update(b"link:" + os.readlink(p).encode(errors="surrogateescape"))
        return h.hexdigest()
    if p.is_file():
        h.update(p.read_bytes())
        return h.hexdigest()
    if p.is_dir():
        for q in sorted(p.rglob("*")):
            h.update(str(q.relative_to(p)).encode(errors="surrogateescape"))
            if q.is_symlink():
                h.update(b"link:" + os.readlink(q).encode(errors="surrogateescape"))
            elif q.is_file():
                h.update(q.read_bytes())
    return h.hexdigest()


def limit_memory():
    # AddressSanitizer reserves terabytes of address space up front: under it (scripts/
    # sanitize.sh sets ASAN_OPTIONS) the sanitizer's own allocation checks stand in for the limit.
    if "ASAN_OPTIONS" not in os.environ:
        resource.setrlimit(resource.RLIMIT_AS, (MEMORY_LIMIT_BYTES, MEMORY_LIMIT_BYTES))


class Sweep:
    def __init__(self, fringe, work):
        self.fringe = str(Path(fringe).resolve())
        self.work = Path(work)
        self.results = []  # (class, name, ok, why)
        self.counter = 0

    # ---- valid inputs ----------------------------------------------------------------------
    def run_ok(self, *args, cwd=None):
        r = subprocess.run([self.fringe, "--quiet", *map(str, args)], cwd=cwd, capture_output=True,
                           text=True, errors="replace")
        if r.returncode != 0:
            raise RuntimeError(f"setup failed: fringe {' '.join(map(str, args))}\n{r.stderr}")

    def make_valid_inputs(self):
        v = self.work / "valid"
        if (v / "done").exists():
            self.valid = v
            return
        shutil.rmtree(v, ignore_errors=True)
        v.mkdir(parents=True)
        self.run_ok("simulate", "sphere", "--out", v / "scan", "--views", "2", "--rig-scale", "0.25",
                    "--supersampling", "1", "--calibration-images", "0", "--no-truth-maps")
        for k in ("000", "001"):
            self.run_ok("reconstruct", v / "scan/views" / k, "--calib", v / "scan/truth/rig.json",
                        "--scheme", v / "scan/scheme.json", "--out", v / f"{k}.ply")
        self.run_ok("simulate", "sphere", "--out", v / "scan1", "--views", "1", "--rig-scale",
                    "0.25", "--supersampling", "1", "--calibration-images", "0", "--no-truth-maps")
        self.run_ok("simulate", "board", "--out", v / "board", "--views", "0", "--rig-scale",
                    "0.25", "--supersampling", "1", "--calibration-images", "3")
        # Camera + projector: a one-camera scan with both fringe directions and its board pose
        # folders (calibration/KKK/{board.png,vertical/,horizontal/}).
        self.run_ok("simulate", "sphere", "--out", v / "cp", "--cameras", "1", "--both-directions",
                    "--views", "1", "--rig-scale", "0.25", "--supersampling", "1",
                    "--calibration-images", "4", "--no-truth-maps")
        (v / "done").write_text("")
        self.valid = v

    # ---- one case ----------------------------------------------------------------------------
    def case(self, cls, name, args, inputs, names=(), expect_codes=(1, 2), prepare=None,
             may_succeed=False):
        """Runs `fringe ARGS` in a fresh case folder. `args` may contain '{case}' and '{out}'
        (the case folder, an empty output folder inside it); `inputs` are paths (relative to the
        case folder) that must be unchanged; `names` are strings one of which the message must
        contain (default: the basename of the first input). `may_succeed`: the mutation may leave
        a valid input (an optional key removed, a value of the right type), so a clean success
        counts as handled; exit 3 (partial result) is accepted where `expect_codes` has it."""
        self.counter += 1
        case_dir = self.work / "cases" / f"{self.counter:04d}"
        shutil.rmtree(case_dir, ignore_errors=True)
        case_dir.mkdir(parents=True)
        out = case_dir / "out"
        out.mkdir()
        if prepare:
            prepare(case_dir)
        subst = lambda a: str(a).replace("{case}", str(case_dir)).replace("{out}", str(out))
        argv = [self.fringe] + [subst(a) for a in args]
        digests = {p: tree_digest(case_dir / p) for p in inputs}
        before_case = sorted(x.name for x in case_dir.iterdir())
        t0 = time.monotonic()
        c0 = resource.getrusage(resource.RUSAGE_CHILDREN)
        try:
            r = subprocess.run(argv, cwd=case_dir, capture_output=True, timeout=TIME_LIMIT_S,
                               preexec_fn=limit_memory)
            code, err = r.returncode, (r.stderr + r.stdout).decode(errors="replace")
        except subprocess.TimeoutExpired:
            code, err = None, ""
        dt = time.monotonic() - t0
        c1 = resource.getrusage(resource.RUSAGE_CHILDREN)
        cpu = c1.ru_utime + c1.ru_stime - c0.ru_utime - c0.ru_stime
        why = []
        if code is None:
            why.append(f"no end within {TIME_LIMIT_S} s")
        elif code < 0:
            why.append(f"killed by signal {-code}")
        elif code not in expect_codes and not (code == 0 and may_succeed):
            why.append(f"exit {code}")
        produced = code in (0, 3)  # a (partial) result was written: the output folder holds it
        for bad in BAD_TEXT:
            if bad in err:
                why.append(f"message contains {bad!r}")
        wanted = list(names) or ([Path(subst(inputs[0])).name] if inputs else [])
        if code not in (None, 0, 3) and wanted and not any(n in err for n in wanted):
            why.append(f"message names none of {wanted}")
        left = sorted(x.name for x in out.iterdir())
        if left and not produced:
            why.append(f"left in the output folder: {left[:4]}")
        after_case = sorted(x.name for x in case_dir.iterdir())
        extra = [x for x in after_case if x not in before_case]
        if extra:
            why.append(f"new files beside the inputs: {extra[:4]}")
        for p, d in digests.items():
            if tree_digest(case_dir / p) != d:
                why.append(f"input {p} changed")
        msg = err.strip().splitlines()[-1][:160] if err.strip() else ""
        self.results.append((cls, name, not why, "; ".join(why), msg, dt, cpu))
        if why:
            print(f"FAIL [{cls}] {name}: {'; '.join(why)}\n     $ {' '.join(argv)}\n     > {msg}",
                  flush=True)
        shutil.rmtree(case_dir, ignore_errors=True)

    def copy(self, src, dst_rel):
        """A prepare step copying a valid input into the case folder."""
        def prep(case_dir):
            s = self.valid / src
            d = case_dir / dst_rel
            d.parent.mkdir(parents=True, exist_ok=True)
            if s.is_dir():
                shutil.copytree(s, d, symlinks=True)
            else:
                shutil.copy(s, d)
        return prep


def chain(*steps):
    def run(case_dir):
        for s in steps:
            s(case_dir)
    return run


def write(rel, data):
    def prep(case_dir):
        p = case_dir / rel
        p.parent.mkdir(parents=True, exist_ok=True)
        p.write_bytes(data if isinstance(data, bytes) else data.encode())
    return prep


def edit_json(rel, fn):
    def prep(case_dir):
        p = case_dir / rel
        j = json.loads(p.read_text())
        j = fn(j)
        text = j if isinstance(j, str) else json.dumps(j)
        p.write_bytes(text.encode("utf-8", errors="surrogateescape"))
    return prep


def edit_bytes(rel, fn):
    def prep(case_dir):
        p = case_dir / rel
        p.write_bytes(fn(p.read_bytes()))
    return prep


def json_mutations(doc):
    """(name, transform, may_succeed) triples breaking a JSON document one way each. Removing a
    key may leave a valid document (optional keys have defaults); a value of the key's own type
    may be valid; numbers that are negative, 1e300 or beyond 32 bits never are for these files'
    top-level fields, nor is a value of another type."""
    muts = [
        ("empty file", lambda j: "", False),
        ("truncated", lambda j: json.dumps(j)[: len(json.dumps(j)) // 2], False),
        ("not JSON", lambda j: "this is not json {", False),
        ("array instead of object", lambda j: "[1, 2, 3]", False),
        ("number instead of object", lambda j: "42", False),
        ("nested 100000 deep", lambda j: "[" * 100000 + "]" * 100000, False),
        ("1e999 literal", lambda j: json.dumps(j).replace("{", '{"x_huge": 1e999, ', 1), False),
        ("trailing garbage", lambda j: json.dumps(j) + " }}}", False),
        ("NUL byte", lambda j: json.dumps(j)[:10] + "\0" + json.dumps(j)[10:], False),
        ("invalid UTF-8", lambda j: json.dumps(j).replace('"', '"\udcff', 1), False),
        ("unknown key", lambda j: {**j, "bogus_key": 1}, False),
    ]
    for key in list(doc.keys()):
        if key in ("format",):
            continue
        muts.append((f"'{key}' removed", lambda j, key=key: {k: v for k, v in j.items() if k != key},
                     True))
        orig = doc[key]
        for label, val in (("a string", "abc"), ("-1", -1), ("1e300", 1e300), ("null", None),
                           ("an empty list", []), ("an object", {"a": 1}), ("4294967936", 4294967936),
                           ("4.5", 4.5), ("true", True)):
            if val == orig and type(val) == type(orig):
                continue
            same_type = (isinstance(orig, str) and isinstance(val, str)) or \
                        (isinstance(orig, bool) and isinstance(val, bool)) or \
                        (isinstance(orig, float) and val == 4.5) or \
                        (isinstance(orig, list) and isinstance(val, list)) or val is None
            muts.append((f"'{key}' = {label}", lambda j, key=key, val=val: {**j, key: val},
                         same_type))
    return muts


def build_cases(s):
    v = s.valid
    scan = v / "scan"
    # -------- 1 data loss: outputs that would replace or delete inputs -------------------------
    s.case("1 data loss", "decode --out its own stack",
           ["decode", "view/left", "--scheme", "scheme.json", "--out", "view/left"],
           ["view", "scheme.json"], names=["view/left"],
           prepare=chain(s.copy("scan/views/000", "view"), s.copy("scan/scheme.json", "scheme.json")))
    s.case("1 data loss", "reconstruct --out the rig",
           ["reconstruct", "view", "--calib", "rig.json", "--scheme", "scheme.json", "--out", "rig.json"],
           ["view", "rig.json", "scheme.json"], names=["rig.json"],
           prepare=chain(s.copy("scan/views/000", "view"), s.copy("scan/truth/rig.json", "rig.json"),
                         s.copy("scan/scheme.json", "scheme.json")))
    s.case("1 data loss", "reconstruct --out into the view folder as a folder output",
           ["reconstruct", "view", "--calib", "rig.json", "--scheme", "scheme.json", "--out", "view/left/00.png"],
           ["view", "rig.json"], names=["00.png"],
           prepare=chain(s.copy("scan/views/000", "view"), s.copy("scan/truth/rig.json", "rig.json"),
                         s.copy("scan/scheme.json", "scheme.json")))
    # A view assembled from links to the capture's own folders: the capture is an input too.
    s.case("1 data loss", "reconstruct --out an image of a view whose left/ is a link",
           ["reconstruct", "view", "--calib", "rig.json", "--scheme", "scheme.json", "--out",
            "view/left/00.png"],
           ["capture", "rig.json"], names=["00.png"],
           prepare=chain(s.copy("scan/views/000", "capture"), s.copy("scan/truth/rig.json", "rig.json"),
                         s.copy("scan/scheme.json", "scheme.json"),
                         lambda d: ((d / "view").mkdir(),
                                    os.symlink("../capture/left", d / "view/left"),
                                    os.symlink("../capture/right", d / "view/right"))))
    s.case("1 data loss", "patterns --out a folder the user made",
           ["patterns", "--out", "mine"], ["mine"], names=["mine"],
           prepare=write("mine/notes.txt", "my notes"))
    s.case("1 data loss", "simulate --out a folder the user made",
           ["simulate", "sphere", "--views", "1", "--rig-scale", "0.1", "--out", "mine"], ["mine"],
           names=["mine"], prepare=write("mine/notes.txt", "my notes"))
    s.case("1 data loss", "scan --out its own project",
           ["scan", "proj", "--calib", "proj/truth/rig.json", "--out", "proj"], ["proj"], names=["proj"], prepare=s.copy("scan", "proj"))
    s.case("1 data loss", "scan --out a folder inside its project",
           ["scan", "proj", "--calib", "proj/truth/rig.json", "--out", "proj/views"], ["proj"], names=["proj"], prepare=s.copy("scan", "proj"))
    s.case("1 data loss", "register --out the folder holding its clouds",
           ["register", "c/000.ply", "c/001.ply", "--out", "c"], ["c"], names=["c"],
           prepare=chain(s.copy("000.ply", "c/000.ply"), s.copy("001.ply", "c/001.ply")))
    s.case("1 data loss", "fuse --out one of its clouds",
           ["fuse", "000.ply", "001.ply", "--poses", "poses.json", "--out", "000.ply"],
           ["000.ply", "001.ply"], names=["000.ply"],
           prepare=chain(s.copy("000.ply", "000.ply"), s.copy("001.ply", "001.ply"),
                         s.copy("scan/truth/poses.json", "poses.json")))
    # An earlier scan's output folder (fringe wrote it: it holds the marker, so it may be
    # replaced) given as --out while its own view clouds or poses are the inputs (issue 30).
    earlier_output = chain(write("o/.fringe-output", "written by fringe\n"),
                           s.copy("000.ply", "o/views/000.ply"), s.copy("001.ply", "o/views/001.ply"),
                           s.copy("scan/truth/poses.json", "o/poses.json"))
    s.case("1 data loss", "register --out an earlier output folder holding its clouds",
           ["register", "o/views/000.ply", "o/views/001.ply", "--out", "o"], ["o"], names=["o"],
           prepare=earlier_output)
    s.case("1 data loss", "register --out the folder of its --initial poses",
           ["register", "000.ply", "001.ply", "--initial", "o/poses.json", "--out", "o"], ["o"],
           names=["o"], prepare=chain(earlier_output, s.copy("000.ply", "000.ply"),
                                      s.copy("001.ply", "001.ply")))
    s.case("1 data loss", "scan --out a new folder inside its project",
           ["scan", "proj", "--calib", "proj/truth/rig.json", "--out", "proj/views/002"], ["proj"],
           names=["proj"], prepare=s.copy("scan", "proj"))
    s.case("1 data loss", "fuse --out into the registration folder it reads",
           ["fuse", "r", "--out", "r/fused.ply"], ["r"], names=["r"],
           prepare=chain(s.copy("000.ply", "r/registered/000.ply"),
                         s.copy("001.ply", "r/registered/001.ply"),
                         s.copy("scan/truth/poses.json", "r/poses.json")))
    s.case("1 data loss", "fuse --mesh the poses file",
           ["fuse", "000.ply", "001.ply", "--poses", "poses.json", "--out", "{out}/f.ply",
            "--mesh", "poses.json"], ["000.ply", "001.ply", "poses.json"], names=["poses.json"],
           prepare=chain(s.copy("000.ply", "000.ply"), s.copy("001.ply", "001.ply"),
                         s.copy("scan/truth/poses.json", "poses.json")))
    s.case("1 data loss", "calibrate --out the target",
           ["calibrate", "board/calibration", "--target", "board/calibration/target.json", "--out",
            "board/calibration/target.json"], ["board"], names=["target.json"],
           prepare=s.copy("board", "board"))
    s.case("1 data loss", "convert-calib --out its input",
           ["convert-calib", "cal.yml", "--out", "cal.yml"], ["cal.yml"], names=["cal.yml"],
           prepare=write("cal.yml", OPENCV_STEREO))

    # -------- 2 path escape through names in data files ----------------------------------------
    for label, image in (("'..' component", "../escape.png"), ("absolute path", "/tmp/escape.png"),
                         ("empty name", ""), ("'.'", "."), ("backslash", "a\\b.png"),
                         ("control character", "a\nb.png"), ("unknown extension", "a.exe"),
                         ("nested '..'", "sub/../../x.png")):
        def bad_names(j, image=image):
            j["images"][0] = image
            return j
        s.case("2 path escape", f"scheme image name: {label}",
               ["decode", "view/left", "--scheme", "scheme.json", "--out", "{out}/d"],
               ["view", "scheme.json"], names=["scheme.json"],
               prepare=chain(s.copy("scan/views/000", "view"), s.copy("scan/scheme.json", "scheme.json"),
                             edit_json("scheme.json", bad_names)))
        s.case("2 path escape", f"patterns from a manifest with image name: {label}",
               ["patterns", "--scheme", "scheme.json", "--out", "{out}/p"], ["scheme.json"],
               names=["scheme.json"],
               prepare=chain(s.copy("scan/scheme.json", "scheme.json"), edit_json("scheme.json", bad_names)))
    for label, name in (("'..'", "../../outside.json"), ("absolute", "/etc/passwd")):
        s.case("2 path escape", f"scan.json scheme path {label}",
               ["scan", "proj", "--calib", "proj/truth/rig.json", "--out", "{out}/o"], ["proj"], names=["scan.json"],
               prepare=chain(s.copy("scan", "proj"),
                             edit_json("proj/scan.json", lambda j, name=name: {**j, "scheme": name})))
    s.case("2 path escape", "duplicate image names",
           ["patterns", "--scheme", "scheme.json", "--out", "{out}/p"], ["scheme.json"],
           names=["scheme.json"],
           prepare=chain(s.copy("scan/scheme.json", "scheme.json"),
                         edit_json("scheme.json", lambda j: {**j, "images": [j["images"][0]] * len(j["images"])})))

    # -------- 3 crashes: deep nesting ------------------------------------------------------------
    s.case("3 crashes", "OpenCV YAML nested 40000 deep",
           ["reconstruct", "view", "--opencv", "cal.yml", "--scheme", "scheme.json", "--out", "{out}/r.ply"],
           ["cal.yml"], prepare=chain(s.copy("scan/views/000", "view"), s.copy("scan/scheme.json", "scheme.json"),
                                      write("cal.yml", "%YAML:1.0\n---\na: " + "[" * 40000 + "]" * 40000 + "\n")))
    s.case("3 crashes", "OpenCV YAML maps nested 20000 deep",
           ["convert-calib", "cal.yml", "--out", "{out}/rig.json"], ["cal.yml"],
           prepare=write("cal.yml", "%YAML:1.0\n---\n" + "".join(" " * i + f"k{i}:\n" for i in range(2000)) + " " * 2000 + "v: 1\n"))
    s.case("3 crashes", "OpenCV XML nested 40000 deep",
           ["convert-calib", "cal.xml", "--out", "{out}/rig.json"], ["cal.xml"],
           prepare=write("cal.xml", '<?xml version="1.0"?>\n<opencv_storage>' + "<a>" * 40000 + "</a>" * 40000 + "</opencv_storage>\n"))
    s.case("3 crashes", "scheme 'format' nested 100000 deep",
           ["decode", "view/left", "--scheme", "scheme.json", "--out", "{out}/d"], ["scheme.json"],
           prepare=chain(s.copy("scan/views/000", "view"),
                         write("scheme.json", '{"format": ' + "[" * 100000 + "]" * 100000 + "}")))

    # -------- 4 unbounded allocation from small files and flags --------------------------------
    for label, header in (
            ("10^8 vertices in 300 bytes", "ply\nformat binary_little_endian 1.0\nelement vertex 100000000\nproperty float x\nproperty float y\nproperty float z\nproperty float nx\nproperty float ny\nproperty float nz\nproperty uchar red\nend_header\n"),
            ("10^18 vertices", "ply\nformat ascii 1.0\nelement vertex 1000000000000000000\nproperty float x\nproperty float y\nproperty float z\nend_header\n0 0 0\n"),
            ("grid comment 15000x15000", "ply\nformat ascii 1.0\ncomment fringe_grid 15000 15000\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\nend_header\n0 0 1\n"),
            ("10^9 faces", "ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 1000000000\nproperty list uchar int vertex_indices\nend_header\n" + "\0" * 36),
            ("list length 255 of int in a tiny file", "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n255 0 1 2\n")):
        for cmd in (["info", "c.ply"], ["evaluate", "c.ply", "--artefact", "plane"],
                    ["evaluate", "c.ply", "--truth", "c.ply", "--map", "{out}/m.png"]):
            s.case("4 unbounded allocation", f"PLY {label}: {cmd[0]}", cmd, ["c.ply"],
                   prepare=write("c.ply", header))
    s.case("4 unbounded allocation", "manifest with 10^6 steps",
           ["decode", "view/left", "--scheme", "scheme.json", "--out", "{out}/d"], ["scheme.json"],
           prepare=chain(s.copy("scan/views/000", "view"), s.copy("scan/scheme.json", "scheme.json"),
                         edit_json("scheme.json", lambda j: {**j, "phase_sets": [{**j["phase_sets"][0], "steps": 1000000}] + j["phase_sets"][1:]})))
    s.case("4 unbounded allocation", "OpenCV matrix rows 300000",
           ["convert-calib", "cal.yml", "--out", "{out}/rig.json"], ["cal.yml"],
           prepare=write("cal.yml", OPENCV_STEREO.replace("rows: 3\n   cols: 3", "rows: 300000\n   cols: 3", 1)))
    for flag, val in (("--width", "2147483647"), ("--width", "1000000"), ("--height", "1000000")):
        s.case("4 unbounded allocation", f"patterns {flag} {val}",
               ["patterns", flag, val, "--out", "{out}/p"], [], names=[flag.strip("-")])
    s.case("4 unbounded allocation", "simulate --rig-scale 100",
           ["simulate", "sphere", "--views", "1", "--rig-scale", "100", "--out", "{out}/s"], [],
           names=["rig-scale"])
    s.case("4 unbounded allocation", "simulate --views 100000",
           ["simulate", "sphere", "--views", "100000", "--rig-scale", "1", "--out", "{out}/s"], [],
           names=["views"])
    s.case("4 unbounded allocation", "scan.json image size 10^6 x 10^6",
           ["scan", "proj", "--calib", "proj/truth/rig.json", "--out", "{out}/o"], ["proj"], names=["scan.json"],
           prepare=chain(s.copy("scan", "proj"),
                         edit_json("proj/scan.json", lambda j: {**j, "image_width": 1000000, "image_height": 1000000})))

    # -------- 5 failures that would exit 0 -----------------------------------------------------
    def black(case_dir, size=None):
        import struct
        for p in list((case_dir / "view/left").glob("*.png")) + list((case_dir / "view/right").glob("*.png")):
            w, h = size or struct.unpack(">II", p.read_bytes()[16:24])
            p.write_bytes(png_bytes(w, h, 0))
    s.case("5 exit codes", "reconstruct a view of images smaller than the rig's",
           ["reconstruct", "view", "--calib", "rig.json", "--scheme", "scheme.json", "--out", "{out}/r.ply"],
           ["view"], names=["view"],
           prepare=chain(s.copy("scan/views/000", "view"), s.copy("scan/truth/rig.json", "rig.json"),
                         s.copy("scan/scheme.json", "scheme.json"), lambda d: black(d, (16, 16))))
    s.case("5 exit codes", "decode an all-black stack",
           ["decode", "view/left", "--scheme", "scheme.json", "--out", "{out}/d"], ["view"],
           names=["view/left"],
           prepare=chain(s.copy("scan/views/000", "view"), s.copy("scan/scheme.json", "scheme.json"), black))
    s.case("5 exit codes", "reconstruct an all-black view",
           ["reconstruct", "view", "--calib", "rig.json", "--scheme", "scheme.json", "--out", "{out}/r.ply"],
           ["view"], names=["view"],
           prepare=chain(s.copy("scan/views/000", "view"), s.copy("scan/truth/rig.json", "rig.json"),
                         s.copy("scan/scheme.json", "scheme.json"), black))
    empty_ply = "ply\nformat ascii 1.0\nelement vertex 0\nproperty float x\nproperty float y\nproperty float z\nend_header\n"
    for cmd in (["evaluate", "c.ply", "--artefact", "sphere", "--diameter", "25"],
                ["evaluate", "c.ply", "--artefact", "plane"],
                ["evaluate", "c.ply", "--artefact", "ballbar", "--diameter", "25", "--distance", "100"],
                ["register", "c.ply", "001.ply", "--out", "{out}/r"],
                ["fuse", "c.ply", "001.ply", "--poses", "poses.json", "--out", "{out}/f.ply"]):
        # One empty view among good ones: a partial result (exit 3) is the right answer there.
        s.case("5 exit codes", f"empty cloud: {' '.join(cmd[:4])}", cmd, ["c.ply"],
               expect_codes=(1, 2, 3) if cmd[0] in ("register", "fuse") else (1, 2),
               prepare=chain(write("c.ply", empty_ply), s.copy("001.ply", "001.ply"),
                             write("poses.json", poses_for(json.loads((scan / "truth/poses.json").read_text()), ["c", "001"]))))

    # -------- 6 wrong success: every JSON file, values that would wrap or be truncated --------
    for name, fn, ok in json_mutations(json.loads((scan / "scheme.json").read_text())):
        s.case("6 scheme JSON", f"scheme: {name}",
               ["decode", "view/left", "--scheme", "scheme.json", "--out", "{out}/d"], ["scheme.json"],
               may_succeed=ok,
               prepare=chain(s.copy("scan/views/000", "view"), s.copy("scan/scheme.json", "scheme.json"),
                             edit_json("scheme.json", fn)))
    rig = json.loads((scan / "truth/rig.json").read_text())
    for name, fn, ok in json_mutations(rig):
        s.case("6 rig JSON", f"rig: {name}",
               ["reconstruct", "view", "--calib", "rig.json", "--scheme", "scheme.json", "--out", "{out}/r.ply"],
               ["rig.json"], may_succeed=ok,
               prepare=chain(s.copy("scan/views/000", "view"), s.copy("scan/truth/rig.json", "rig.json"),
                             s.copy("scan/scheme.json", "scheme.json"), edit_json("rig.json", fn)))
    for key in rig["cameras"]["left"]:
        for label, val in (("1e300", 1e300), ("NaN string", "nan"), ("-1", -1), ("[]", [])):
            if key == "distortion_model" and isinstance(val, str):
                continue
            def f(j, key=key, val=val):
                j["cameras"]["left"][key] = val
                return j
            s.case("6 rig JSON", f"rig camera '{key}' = {label}",
                   ["reconstruct", "view", "--calib", "rig.json", "--scheme", "scheme.json", "--out", "{out}/r.ply"],
                   ["rig.json"],
                   prepare=chain(s.copy("scan/views/000", "view"), s.copy("scan/truth/rig.json", "rig.json"),
                                 s.copy("scan/scheme.json", "scheme.json"), edit_json("rig.json", f)))
    for label, fn in (("rotation scaled by 2", lambda j: scale_matrix(j, "right_from_left", 2.0)),
                      ("rotation all zero", lambda j: scale_matrix(j, "right_from_left", 0.0)),
                      ("translation 1e300", lambda j: {**j, "right_from_left": {**j["right_from_left"], "translation_mm": [1e300, 0, 0]}})):
        s.case("6 rig JSON", f"rig right_from_left {label}",
               ["reconstruct", "view", "--calib", "rig.json", "--scheme", "scheme.json", "--out", "{out}/r.ply"],
               ["rig.json"],
               prepare=chain(s.copy("scan/views/000", "view"), s.copy("scan/truth/rig.json", "rig.json"),
                             s.copy("scan/scheme.json", "scheme.json"), edit_json("rig.json", fn)))
    scanj = json.loads((scan / "scan.json").read_text())
    for name, fn, ok in json_mutations(scanj):
        # A random seed is a 64-bit integer: 4294967936 is a valid one.
        ok = ok or name == "'seed' = 4294967936"
        # `info` opens the folder through the same reader as `scan` (scan::ScanFolder), without
        # minutes of scanning when the mutation leaves a valid manifest.
        s.case("6 scan folder", f"scan.json: {name}", ["info", "proj"], ["proj"],
               names=["scan.json"], may_succeed=ok,
               prepare=chain(s.copy("scan1", "proj"), s.copy("scan1/truth/rig.json", "rig.json"),
                             edit_json("proj/scan.json", fn)))
    poses = json.loads((scan / "truth/poses.json").read_text())
    for name, fn, ok in json_mutations(poses) + [
            ("rotation scaled by 2", lambda j: scale_rotation(j, 2.0), False),
            ("rotation all zero", lambda j: scale_rotation(j, 0.0), False),
            ("translation NaN string", lambda j: set_translation(j, "nan"), False),
            ("translation 1e300", lambda j: set_translation(j, 1e300), False),
            ("view name with '../'", lambda j: set_view_name(j, "../001"), False),
            ("a view twice", lambda j: {**j, "views": j["views"] + j["views"][-1:]}, False)]:
        s.case("6 poses", f"fuse --poses: {name}",
               ["fuse", "000.ply", "001.ply", "--poses", "poses.json", "--out", "{out}/f.ply"],
               ["poses.json"], may_succeed=ok,
               prepare=chain(s.copy("000.ply", "000.ply"), s.copy("001.ply", "001.ply"),
                             s.copy("scan/truth/poses.json", "poses.json"), edit_json("poses.json", fn)))
        # Registration may place one view only (exit 3, a partial result) whatever the poses.
        s.case("6 poses", f"register --initial: {name}",
               ["register", "000.ply", "001.ply", "--initial", "poses.json", "--out", "{out}/r"],
               ["poses.json"], may_succeed=ok, expect_codes=(1, 2, 3) if ok else (1, 2),
               prepare=chain(s.copy("000.ply", "000.ply"), s.copy("001.ply", "001.ply"),
                             s.copy("scan/truth/poses.json", "poses.json"), edit_json("poses.json", fn)))
    markers = json.loads((v / "000.markers.json").read_text())
    for name, fn, ok in json_mutations(markers) + [
            ("marker normal not unit", lambda j: set_marker(j, "normal_in_sensor", [0, 0, 2]), False),
            ("marker centre behind the sensor", lambda j: set_marker(j, "centre_in_sensor", [0, 0, -5]), False),
            ("marker id -3", lambda j: set_marker(j, "id", -3), False),
            ("marker sigma NaN string", lambda j: set_marker(j, "sigma_mm", "nan"), False),
            ("marker left_px three numbers", lambda j: set_marker(j, "left_px", [1, 2, 3]), False),
            ("200000 markers", lambda j: {**j, "markers": j["markers"][:1] * 200000}, False)]:
        s.case("6 markers file", f"000.markers.json: {name}",
               ["register", "000.ply", "001.ply", "--out", "{out}/r"], ["000.markers.json"],
               may_succeed=ok, expect_codes=(1, 2, 3) if ok else (1, 2),
               prepare=chain(s.copy("000.ply", "000.ply"), s.copy("001.ply", "001.ply"),
                             s.copy("000.markers.json", "000.markers.json"),
                             s.copy("001.markers.json", "001.markers.json"),
                             edit_json("000.markers.json", fn)))
    target = json.loads((v / "board/calibration/target.json").read_text())
    for name, fn, ok in json_mutations(target):
        s.case("6 target JSON", f"target: {name}",
               ["calibrate", "board/calibration", "--target", "t.json", "--out", "{out}/rig.json"],
               ["t.json"], may_succeed=ok,
               prepare=chain(s.copy("board", "board"), s.copy("board/calibration/target.json", "t.json"),
                             edit_json("t.json", fn)))

    # -------- PLY bytes ----------------------------------------------------------------------
    good_ply = (v / "000.ply").read_bytes()
    hdr_end = good_ply.index(b"end_header\n") + len(b"end_header\n")
    ply_muts = [
        ("empty file", lambda b: b""),
        ("header only", lambda b: b[:hdr_end]),
        ("body truncated by half", lambda b: b[: hdr_end + (len(b) - hdr_end) // 2]),
        ("body truncated by one byte", lambda b: b[:-1]),
        ("no end_header", lambda b: b[: hdr_end - 11]),
        ("vertex count abc", lambda b: replace_count(b, b"abc")),
        ("vertex count -5", lambda b: replace_count(b, b"-5")),
        ("vertex count 1e3", lambda b: replace_count(b, b"1e3")),
        ("vertex count 2^64", lambda b: replace_count(b, b"18446744073709551616")),
        ("format big endian 9.9", lambda b: b.replace(b"format binary_little_endian 1.0", b"format binary_big_endian 9.9", 1)),
        ("unknown property type", lambda b: b.replace(b"property float x", b"property quad x", 1)),
        ("x property missing", lambda b: b.replace(b"property float x\n", b"", 1)),
        ("grid comment 0x0", lambda b: grid_comment(b, b"0 0")),
        ("grid comment -3 7", lambda b: grid_comment(b, b"-3 7")),
        ("grid comment abc", lambda b: grid_comment(b, b"abc def")),
        ("grid comment too small for the vertices", lambda b: grid_comment(b, b"2 2")),
        ("garbage body", lambda b: b[:hdr_end] + os.urandom(len(b) - hdr_end)),
        ("NaN coordinates", lambda b: b[:hdr_end] + b"\x00\x00\xc0\x7f" * ((len(b) - hdr_end) // 4)),
        ("not a PLY", lambda b: b"solid x\nendsolid x\n"),
    ]
    for name, fn in ply_muts:
        for cmd in (["info", "c.ply"], ["evaluate", "c.ply", "--artefact", "sphere"],
                    ["register", "c.ply", "001.ply", "--out", "{out}/r"],
                    ["fuse", "c.ply", "001.ply", "--poses", "poses.json", "--out", "{out}/f.ply"]):
            # A garbage or NaN body is still a well-formed PLY (PCL writes NaN points for the
            # empty cells of organized clouds): `info` may describe it; the readers that use the
            # points must still fail or succeed cleanly.
            describable = cmd[0] == "info" and name in ("garbage body", "NaN coordinates")
            s.case("PLY", f"{name}: {cmd[0]}", cmd, ["c.ply"], may_succeed=describable,
                   prepare=chain(s.copy("000.ply", "c.ply"), s.copy("001.ply", "001.ply"),
                                 write("poses.json", poses_for(poses, ["c", "001"])), edit_bytes("c.ply", fn)))

    # -------- images ---------------------------------------------------------------------------
    img_muts = [
        ("empty PNG", lambda case_dir, p: p.write_bytes(b"")),
        ("truncated PNG", lambda case_dir, p: p.write_bytes(p.read_bytes()[: len(p.read_bytes()) // 3])),
        ("random bytes as PNG", lambda case_dir, p: p.write_bytes(os.urandom(2000))),
        ("PNG of another size", lambda case_dir, p: p.write_bytes(png_bytes(17, 9, 100))),
        ("PNG declaring 60000x60000", lambda case_dir, p: p.write_bytes(png_header_only(60000, 60000))),
        ("image replaced by a folder", lambda case_dir, p: (p.unlink(), p.mkdir())),
        ("image removed", lambda case_dir, p: p.unlink()),
        ("symlink loop", lambda case_dir, p: (p.unlink(), os.symlink(p.name, p))),
        ("dangling symlink", lambda case_dir, p: (p.unlink(), os.symlink("nowhere.png", p))),
    ]
    for name, fn in img_muts:
        def prep_img(case_dir, fn=fn):
            fn(case_dir, case_dir / "view/left/03.png")
        s.case("images", f"{name}: decode", ["decode", "view/left", "--scheme", "scheme.json", "--out", "{out}/d"],
               ["view"], names=["03.png", "view/left"],
               prepare=chain(s.copy("scan/views/000", "view"), s.copy("scan/scheme.json", "scheme.json"), prep_img))
        s.case("images", f"{name}: reconstruct",
               ["reconstruct", "view", "--calib", "rig.json", "--scheme", "scheme.json", "--out", "{out}/r.ply"],
               ["view"], names=["03.png", "view/left"],
               prepare=chain(s.copy("scan/views/000", "view"), s.copy("scan/truth/rig.json", "rig.json"),
                             s.copy("scan/scheme.json", "scheme.json"), prep_img))
        def prep_scan_img(case_dir, fn=fn):
            fn(case_dir, case_dir / "proj/views/001/right/05.png")
        s.case("images", f"{name}: scan", ["scan", "proj", "--calib", "proj/truth/rig.json", "--out", "{out}/o"], ["proj"],
               names=["05.png", "001"],
               prepare=chain(s.copy("scan", "proj"), prep_scan_img))

    # -------- OpenCV calibration files -----------------------------------------------------------
    cv_muts = [
        ("empty file", ""),
        ("header only", "%YAML:1.0\n---\n"),
        ("matrix as a string", OPENCV_STEREO.replace("M1: !!opencv-matrix", "M1: \"a string\"\nX: !!opencv-matrix", 1)),
        ("data count short", OPENCV_STEREO.replace("1000., 0., 320.,", "1000.,", 1)),
        ("fx 1e300", OPENCV_STEREO.replace("1000., 0., 320.,", "1e300, 0., 320.,", 1)),
        ("fx nan", OPENCV_STEREO.replace("1000., 0., 320.,", ".nan, 0., 320.,", 1)),
        ("R all zero", OPENCV_STEREO.replace("data: [ 1., 0., 0., 0., 1., 0., 0., 0., 1. ]", "data: [ 0., 0., 0., 0., 0., 0., 0., 0., 0. ]", 1)),
        ("R scaled by 2", OPENCV_STEREO.replace("data: [ 1., 0., 0., 0., 1., 0., 0., 0., 1. ]", "data: [ 2., 0., 0., 0., 2., 0., 0., 0., 2. ]", 1)),
        ("14 distortion coefficients", OPENCV_STEREO.replace("rows: 1\n   cols: 5\n   dt: d\n   data: [ 0., 0., 0., 0., 0. ]", "rows: 1\n   cols: 14\n   dt: d\n   data: [ 0., 0., 0., 0., 0., 0.01, 0.02, 0., 0., 0., 0., 0., 0.003, 0. ]", 1)),
        ("dt: u (unsigned char)", OPENCV_STEREO.replace("dt: d", "dt: u", 1)),
        ("key present twice", OPENCV_STEREO + "M1: !!opencv-matrix\n   rows: 3\n   cols: 3\n   dt: d\n   data: [ 1., 0., 0., 0., 1., 0., 0., 0., 1. ]\n"),
        ("empty nested key", "%YAML:1.0\n---\na:\n  :\n"),
        ("tab indentation", OPENCV_STEREO.replace("   rows", "\trows", 1)),
        ("binary garbage", "%YAML:1.0\n---\n" + "\x01\x02\xff\xfe" * 100),
        ("XML garbage", '<?xml version="1.0"?>\n<opencv_storage><M1 type_id="opencv-matrix"><rows>3</rows></opencv_storage>'),
        ("YAML alias bomb", "%YAML:1.0\n---\na: &a [1,1,1,1,1,1,1,1,1]\nb: &b [*a,*a,*a,*a,*a,*a,*a,*a,*a]\nc: [*b,*b,*b,*b,*b,*b,*b,*b,*b]\n"),
    ]
    for name, text in cv_muts:
        s.case("OpenCV file", f"{name}: convert-calib", ["convert-calib", "cal.yml", "--out", "{out}/rig.json"],
               ["cal.yml"], prepare=write("cal.yml", text))
        s.case("OpenCV file", f"{name}: info", ["info", "cal.yml"], ["cal.yml"], prepare=write("cal.yml", text))

    # -------- camera + projector: one-camera scans, projector calibration folders, rigs -------
    cp_rig = json.loads((v / "cp/truth/rig.json").read_text())
    cp_view = ["reconstruct", "proj/views/000", "--calib", "rig.json", "--out", "{out}/r.ply"]
    cp_calib = ["calibrate", "proj/calibration", "--target", "proj/calibration/target.json",
                "--out", "{out}/rig.json"]
    # The scheme's and the rig's projector sizes disagree (a rig calibrated for another
    # projector): refused naming both, not reconstructed with wrong geometry (issue 30).
    def double_projector(j):
        j["cameras"]["projector"]["width"] *= 2
        j["cameras"]["projector"]["height"] *= 2
        return j
    s.case("camera + projector", "reconstruct: the rig's projector is another size than the scheme's",
           ["reconstruct", "proj/views/000", "--mode", "camera-projector", "--calib", "rig.json",
            "--out", "{out}/r.ply"], ["proj", "rig.json"], names=["rig.json"],
           prepare=chain(s.copy("cp", "proj"), s.copy("cp/truth/rig.json", "rig.json"),
                         edit_json("rig.json", double_projector)))
    for label, val, ok in (("0", 0, False), ("3", 3, False), ("-1", -1, False),
                           ("4294967297", 4294967297, False), ("1.5", 1.5, False),
                           ("a string", "1", False), ("null", None, False), ("2", 2, False)):
        # "cameras": 2 on a folder without right/ images is a wrong claim the reader must name.
        s.case("camera + projector", f"scan.json 'cameras' = {label}", ["info", "proj"], ["proj"],
               names=["scan.json", "right"], may_succeed=ok,
               prepare=chain(s.copy("cp", "proj"),
                             edit_json("proj/scan.json", lambda j, val=val: {**j, "cameras": val})))
    for label, name in (("'..'", "../outside.json"), ("absolute", "/etc/passwd"), ("empty", ""),
                        ("missing file", "nothere.json"), ("a number", 5),
                        ("the vertical scheme's file", "scheme.json")):
        # The same scheme for both directions cannot decode the horizontal stacks: an error, or
        # (for "scheme.json") a clean refusal naming the direction.
        s.case("camera + projector", f"scan.json 'scheme_horizontal' {label}",
               ["scan", "proj", "--calib", "rig.json", "--out", "{out}/o", "--no-report"], ["proj"],
               names=["scan.json", "scheme", "horizontal", "nothere.json"],
               prepare=chain(s.copy("cp", "proj"), s.copy("cp/truth/rig.json", "rig.json"),
                             edit_json("proj/scan.json",
                                       lambda j, name=name: {**j, "scheme_horizontal": name})))
    for name, fn, ok in json_mutations(json.loads((v / "cp/scheme_horizontal.json").read_text())):
        s.case("camera + projector", f"scheme_horizontal.json: {name}", cp_view,
               ["proj", "rig.json"], names=["scheme_horizontal.json"], may_succeed=ok,
               prepare=chain(s.copy("cp", "proj"), s.copy("cp/truth/rig.json", "rig.json"),
                             edit_json("proj/scheme_horizontal.json", fn)))
    pose_manifest = "proj/calibration/001/vertical/manifest.json"
    for label, image in (("'..' component", "../../000/board.png"), ("absolute path", "/tmp/x.png"),
                         ("empty name", ""), ("unknown extension", "a.exe"),
                         ("duplicate", "01.png")):
        def bad_image(j, image=image):
            j["images"][0] = image
            return j
        s.case("camera + projector", f"board pose manifest image name: {label}", cp_calib,
               ["proj"], names=["manifest.json"],
               prepare=chain(s.copy("cp", "proj"), edit_json(pose_manifest, bad_image)))
    for name, fn, ok in json_mutations(json.loads((v / "cp" / pose_manifest[5:]).read_text())):
        s.case("camera + projector", f"board pose manifest: {name}", cp_calib, ["proj"],
               names=["manifest.json", "001"], may_succeed=ok,
               prepare=chain(s.copy("cp", "proj"), edit_json(pose_manifest, fn)))
    for name, fn in img_muts:
        for rel in ("calibration/001/vertical/03.png", "calibration/002/board.png"):
            def prep_pose_img(case_dir, fn=fn, rel=rel):
                fn(case_dir, case_dir / "proj" / rel)
            # Losing one pose of four may still calibrate (the pose is left out and named).
            s.case("camera + projector", f"{name}: {rel}", cp_calib, ["proj"],
                   names=[Path(rel).name, Path(rel).parent.name, "002", "001"], may_succeed=True,
                   prepare=chain(s.copy("cp", "proj"), prep_pose_img))
        def prep_view_img(case_dir, fn=fn):
            fn(case_dir, case_dir / "proj/views/000/left/horizontal/05.png")
        s.case("camera + projector", f"{name}: a view's horizontal stack", cp_view, ["proj"],
               names=["05.png", "horizontal"],
               prepare=chain(s.copy("cp", "proj"), s.copy("cp/truth/rig.json", "rig.json"),
                             prep_view_img))
    for label, fn in (("projector_from_left rotation scaled by 2",
                       lambda j: scale_matrix(j, "projector_from_left", 2.0)),
                      ("projector_from_left rotation all zero",
                       lambda j: scale_matrix(j, "projector_from_left", 0.0)),
                      ("projector_from_left translation 1e300",
                       lambda j: {**j, "projector_from_left": {**j["projector_from_left"],
                                                               "translation_mm": [1e300, 0, 0]}}),
                      ("projector_from_left removed",
                       lambda j: {k: x for k, x in j.items() if k != "projector_from_left"})):
        s.case("camera + projector", f"rig: {label}", cp_view, ["rig.json"],
               prepare=chain(s.copy("cp", "proj"), s.copy("cp/truth/rig.json", "rig.json"),
                             edit_json("rig.json", fn)))
    for key in cp_rig["cameras"]["projector"]:
        for label, val in (("1e300", 1e300), ("-1", -1), ("[]", []), ("0", 0)):
            if key == "distortion" and val == 0:
                continue
            def set_projector(j, key=key, val=val):
                j["cameras"]["projector"][key] = val
                return j
            s.case("camera + projector", f"rig projector '{key}' = {label}", cp_view, ["rig.json"],
                   prepare=chain(s.copy("cp", "proj"), s.copy("cp/truth/rig.json", "rig.json"),
                                 edit_json("rig.json", set_projector)))

    # -------- paths and flags ------------------------------------------------------------------
    s.case("paths", "missing --scheme file", ["decode", "view/left", "--scheme", "nothere.json", "--out", "{out}/d"],
           ["view"], names=["nothere.json"], prepare=s.copy("scan/views/000", "view"))
    s.case("paths", "--calib is a folder", ["reconstruct", "view", "--calib", "view", "--scheme", "scheme.json", "--out", "{out}/r.ply"],
           ["view"], names=["view"],
           prepare=chain(s.copy("scan/views/000", "view"), s.copy("scan/scheme.json", "scheme.json")))
    s.case("paths", "view folder missing", ["reconstruct", "noview", "--calib", "rig.json", "--out", "{out}/r.ply"],
           ["rig.json"], names=["noview"], prepare=s.copy("scan/truth/rig.json", "rig.json"))
    s.case("paths", "output folder missing", ["reconstruct", "view", "--calib", "rig.json", "--scheme", "scheme.json", "--out", "{out}/no/dir/r.ply"],
           ["view"], names=["no/dir"],
           prepare=chain(s.copy("scan/views/000", "view"), s.copy("scan/truth/rig.json", "rig.json"),
                         s.copy("scan/scheme.json", "scheme.json")))
    s.case("paths", "residuals into a missing folder",
           ["reconstruct", "view", "--calib", "rig.json", "--scheme", "scheme.json", "--out", "{out}/r.ply", "--residuals", "{out}/no/res.tiff"],
           ["view"], names=["no/res.tiff"],
           prepare=chain(s.copy("scan/views/000", "view"), s.copy("scan/truth/rig.json", "rig.json"),
                         s.copy("scan/scheme.json", "scheme.json")))
    s.case("paths", "residuals as 8-bit PNG",
           ["reconstruct", "view", "--calib", "rig.json", "--scheme", "scheme.json", "--out", "{out}/r.ply", "--residuals", "{out}/res.png"],
           ["view"], names=["res.png"],
           prepare=chain(s.copy("scan/views/000", "view"), s.copy("scan/truth/rig.json", "rig.json"),
                         s.copy("scan/scheme.json", "scheme.json")))
    s.case("paths", "non-UTF-8 file name", ["info", b"c\xff.ply".decode(errors="surrogateescape")], [],
           names=["c"], prepare=lambda d: (d / b"c\xff.ply".decode(errors="surrogateescape")).write_bytes(b"ply\nformat ascii 1.0\nend_header\n"))
    s.case("paths", "symlink loop as the view", ["reconstruct", "loop", "--calib", "rig.json", "--out", "{out}/r.ply"],
           ["rig.json"], names=["loop"],
           prepare=chain(s.copy("scan/truth/rig.json", "rig.json"), lambda d: os.symlink("loop", d / "loop")))
    # Without scan.json the manifest is inferred from the folder (issue 27); without scheme.json
    # too there is nothing to infer it from.
    s.case("paths", "scan of a folder without scan.json or scheme.json", ["scan", "proj", "--calib", "proj/truth/rig.json", "--out", "{out}/o"], ["proj"],
           names=["scan.json", "proj"],
           prepare=chain(s.copy("scan", "proj"), lambda d: (d / "proj/scan.json").unlink(),
                         lambda d: (d / "proj/scheme.json").unlink()))
    s.case("paths", "fuse with poses naming a missing view",
           ["fuse", "000.ply", "001.ply", "--poses", "poses.json", "--out", "{out}/f.ply"], ["poses.json"],
           names=["poses.json", "001"],
           prepare=chain(s.copy("000.ply", "000.ply"), s.copy("001.ply", "001.ply"),
                         write("poses.json", poses_for(poses, ["000", "zzz"]))))


# ---- helpers building files -------------------------------------------------------------------
OPENCV_STEREO = """%YAML:1.0
---
M1: !!opencv-matrix
   rows: 3
   cols: 3
   dt: d
   data: [ 1000., 0., 320., 0., 1000., 240., 0., 0., 1. ]
D1: !!opencv-matrix
   rows: 1
   cols: 5
   dt: d
   data: [ 0., 0., 0., 0., 0. ]
M2: !!opencv-matrix
   rows: 3
   cols: 3
   dt: d
   data: [ 1000., 0., 320., 0., 1000., 240., 0., 0., 1. ]
D2: !!opencv-matrix
   rows: 1
   cols: 5
   dt: d
   data: [ 0., 0., 0., 0., 0. ]
R: !!opencv-matrix
   rows: 3
   cols: 3
   dt: d
   data: [ 1., 0., 0., 0., 1., 0., 0., 0., 1. ]
T: !!opencv-matrix
   rows: 3
   cols: 1
   dt: d
   data: [ -100., 0., 0. ]
"""


def png_of(w, h, raw):
    """An 8-bit grey PNG declaring w x h whose image data is `raw` (filter bytes included)."""
    import struct, zlib
    def chunk(t, d):
        return struct.pack(">I", len(d)) + t + d + struct.pack(">I", zlib.crc32(t + d) & 0xffffffff)
    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 0, 0, 0, 0)) +
            chunk(b"IDAT", zlib.compress(raw)) + chunk(b"IEND", b""))


def png_bytes(w, h, value):
    return png_of(w, h, b"".join(b"\0" + bytes([value]) * w for _ in range(h)))


def png_header_only(w, h):
    """Declares w x h but holds only 100 bytes of data (a decompression bomb's header)."""
    return png_of(w, h, b"\0" * 100)


def replace_count(b, new):
    import re
    return re.sub(rb"element vertex \d+", b"element vertex " + new, b, count=1)


def grid_comment(b, dims):
    import re
    if re.search(rb"comment fringe_grid [^\n]*", b):
        return re.sub(rb"comment fringe_grid [^\n]*", b"comment fringe_grid " + dims, b, count=1)
    return b.replace(b"format", b"comment fringe_grid " + dims + b"\nformat", 1)


def scale_rotation(j, f):
    views = j["views"] if isinstance(j, dict) else j
    r = views[-1]["world_from_sensor"]["rotation"]
    views[-1]["world_from_sensor"]["rotation"] = [[x * f for x in row] for row in r]
    return j


def set_translation(j, val):
    views = j["views"] if isinstance(j, dict) else j
    views[-1]["world_from_sensor"]["translation_mm"] = [val, 0, 0]
    return j


def scale_matrix(j, key, f):
    j[key]["rotation"] = [[x * f for x in row] for row in j[key]["rotation"]]
    return j


def set_view_name(j, name):
    j["views"][-1]["view"] = name
    return j


def set_marker(j, key, val):
    j["markers"][0][key] = val
    return j


def poses_for(poses, names):
    views = poses["views"] if isinstance(poses, dict) else poses
    out = [dict(v, view=n) for v, n in zip(views, names)]
    return json.dumps({**poses, "views": out} if isinstance(poses, dict) else out)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--fringe", required=True)
    ap.add_argument("--work", default=None)
    ap.add_argument("--table", action="store_true")
    ap.add_argument("--only", default=None, help="run only the classes whose name contains this")
    ap.add_argument("--every", type=int, default=1,
                    help="run every K-th case only (the test suite's quick sample; 1: all)")
    a = ap.parse_args()
    # Every case is a fresh `fringe` process; re-executing each with huge pages (util/memory.h)
    # would load the ~330 shared libraries twice for inputs of a few kilobytes. Results do not
    # depend on it, and the rest of the suite runs with it.
    os.environ.setdefault("FRINGE_HUGE_PAGES", "0")
    work = Path(a.work) if a.work else Path(tempfile.mkdtemp(prefix="fringe-hostile-"))
    s = Sweep(a.fringe, work)
    s.make_valid_inputs()
    orig = s.case
    seen = [0]
    def filtered(cls, *args, **kw):
        if a.only and a.only not in cls:
            return
        seen[0] += 1
        if (seen[0] - 1) % a.every == 0:
            orig(cls, *args, **kw)
    s.case = filtered
    build_cases(s)
    classes = {}
    for cls, name, ok, why, msg, dt, cpu in s.results:
        c = classes.setdefault(cls, [0, 0])
        c[0] += 1
        c[1] += ok
    total = len(s.results)
    clean = sum(r[2] for r in s.results)
    if a.table:
        print("| class | cases | handled cleanly |\n|---|---|---|")
        for cls, (n, ok) in classes.items():
            print(f"| {cls} | {n} | {ok} |")
        print(f"| **all** | **{total}** | **{clean}** |")
    print(f"hostile sweep: {clean} of {total} cases handled cleanly")
    # The costliest cases (CPU time of the command, which a loaded machine does not inflate as it
    # does the wall time), so that the suite's share of the CI budget has a visible cause.
    print(f"CPU of all cases {sum(r[6] for r in s.results):.0f} s; the costliest:")
    for cls, name, ok, why, msg, dt, cpu in sorted(s.results, key=lambda r: -r[6])[:8]:
        print(f"  {cpu:6.1f} s CPU ({dt:.1f} s wall)  [{cls}] {name}")
    if not a.work:
        shutil.rmtree(work, ignore_errors=True)
    return 0 if clean == total else 1


if __name__ == "__main__":
    sys.exit(main())
