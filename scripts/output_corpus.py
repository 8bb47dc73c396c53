#!/usr/bin/env python3
"""Every command's output bytes on a fixed corpus: each transfer kind through
each consumer (issue 46: "outputs unchanged").

    scripts/output_corpus.py --prt build/prt --record base.json   # before a change
    scripts/output_corpus.py --prt build/prt --check base.json    # after it

The corpus is made by the commands themselves from the repository's own files
(models/, envmaps/): one transfer file of each kind (SH interreflected, SH
glossy, compressed diffuse and glossy, wavelet, zonal harmonics, SH and
wavelet lightmaps, a probe volume), small enough that the whole run takes a
few minutes on 2 cores. Then every consumer (info, info --json, relight,
render, export .glb / --bake / --web, compress, compare, reference, Python's
info / read_transfer / relight) runs on every kind, works or is refused, and
the manifest records per step: the exit status, SHA-256 of stdout and of
every file the step wrote (paths inside the work directory and the
repository replaced by $WORK and $REPO first), and stderr's last line (the
refusal message; timings and progress are on stderr, so its bytes are not
compared).

--check reports three kinds of difference: BYTES (exit status, stdout, a
written file: must not differ in a refactor), MESSAGE (a refusal's wording)
and NEW/GONE (steps or files that appear or disappear). It exits 1 when any
BYTES difference (or NEW/GONE) is found, and lists the MESSAGE ones.

To keep a baseline while the tree changes, copy the build's prt, lib/, share/
and python/prt somewhere and run the copy with LD_LIBRARY_PATH=COPY/lib
(--prt COPY/prt --python-path COPY/python).

The bytes depend on the machine (Embree's traversal order is deterministic,
floating point is not across CPUs; llvmpipe's rasteriser across Mesa
versions): record and check on the same machine.
"""
import argparse
import hashlib
import json
import os
import shutil
import subprocess
import sys

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))

# Transfer files: name -> precompute/compress arguments (run in order).
MESH = "models/tube.obj"
SCENE = "models/room.gltf"
ENV = "envmaps/sunset.exr"
KINDS = [
    ("sh", ["precompute", MESH, "-o", "sh.prt", "--mode", "interreflected", "--bounces", "1", "--samples", "64"]),
    ("glossy", ["precompute", MESH, "-o", "glossy.prt", "--material", "glossy", "--bands", "4", "--samples", "64"]),
    ("compressed", ["compress", "sh.prt", "-o", "compressed.prt", "-k", "16", "-n", "4"]),
    ("glossy-compressed", ["compress", "glossy.prt", "-o", "glossy-compressed.prt", "-k", "16", "-n", "4",
                           "--glossy-clusters", "16", "--glossy-pca", "4"]),
    ("wavelet", ["precompute", MESH, "-o", "wavelet.prt", "--basis", "wavelet", "--cube-res", "8"]),
    ("zh", ["precompute", MESH, "-o", "zh.prt", "--basis", "zh", "--samples", "64", "--dynamic-ao"]),
    ("lightmap", ["precompute", SCENE, "-o", "lightmap.prt", "--lightmap", "32x32", "--mode", "interreflected",
                  "--samples", "64"]),
    ("wavelet-lightmap", ["precompute", SCENE, "-o", "wavelet-lightmap.prt", "--lightmap", "32x32", "--basis",
                          "wavelet", "--cube-res", "8"]),
    ("probes", ["precompute", SCENE, "-o", "probes.prt", "--probes", "3x3x3", "--probe-cube", "16", "--samples",
                "64"]),
]
SCENE_KINDS = {"lightmap", "wavelet-lightmap", "probes"}
ROOM_CAMERA = ["--camera", "1.8,1.6,1.8,-1,0.5,-1,0,1,0", "--fov", "70"]


def consumer_steps(kind):
    """(name, argv) of every consumer for the transfer file of `kind`."""
    f = kind + ".prt"
    model = SCENE if kind in SCENE_KINDS else MESH
    look = ["--exposure", "0", "--width", "96", "--height", "64"] + (ROOM_CAMERA if kind in SCENE_KINDS else [])
    relight_out = kind + ".relit.exr" if kind in SCENE_KINDS - {"probes"} else kind + ".relit.csv"
    relight = ["relight", model, f, ENV, "-o", relight_out, "--rotate", "30,0,0"]
    if kind == "probes":
        relight += ["--at", "points.csv"]
    steps = [
        ("info", ["info", f]),
        ("info-json", ["info", "--json", f]),
        ("relight", relight),
        ("relight-ply", ["relight", model, f, ENV, "-o", kind + ".relit.ply"]),
        ("render", ["render", model, f, ENV, "-o", kind + ".png"] + look),
        ("render-ao", ["render", model, f, ENV, "-o", kind + ".ao.png", "--shading", "ao"] + look),
        ("export-glb", ["export", model, f, "-o", kind + ".glb"]),
        ("export-bake", ["export", model, f, "-o", kind + ".baked.glb", "--bake", ENV]),
        ("export-web", ["export", model, f, "--web", kind + "-web"]),
        ("compress", ["compress", f, "-o", kind + ".c.prt", "-k", "8", "-n", "2"]),
    ]
    if kind == "probes":
        steps.append(("export-probes", ["export", model, "--probes", f, "-o", "probes.json", "--bake", ENV,
                                        "--matrices", "probes.matrices.bin"]))
        steps.append(("render-object", ["render", model, "lightmap.prt", ENV, "-o", "probes.object.png", "--probes", f,
                                        "--object", MESH, "--object-at", "0,0.5,0"] + look))
    return steps


PY_CONSUMER = r"""
import json, sys, hashlib
import prt
kind, path, model, env = sys.argv[1:5]
def out(tag, value):
    print(tag, value)
try:
    out("info", json.dumps(prt.info(path), sort_keys=True, default=str))
except Exception as e:
    out("info-error", str(e))
try:
    t = prt.read_transfer(path)
    out("read_transfer", type(t).__name__ + " " + str(t))
except Exception as e:
    out("read_transfer-error", str(e))
    t = None
if t is not None:
    try:
        mesh = prt.load_mesh(model)
        light = prt.project(prt.load_envmap(env), bands=t.bands)
        rgb = t.relight(mesh, light)
        out("relight", hashlib.sha256(rgb.tobytes()).hexdigest())
    except Exception as e:
        out("relight-error", str(e))
"""


def sha(path):
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for chunk in iter(lambda: f.read(1 << 20), b""):
            h.update(chunk)
    return h.hexdigest()


def snapshot(work):
    s = {}
    for root, _, files in os.walk(work):
        for n in files:
            p = os.path.join(root, n)
            st = os.stat(p)
            s[os.path.relpath(p, work)] = (st.st_mtime_ns, st.st_size)
    return s


def normalise(text, work):
    return text.replace(work, "$WORK").replace(REPO, "$REPO")


def run_step(argv, work, env):
    before = snapshot(work)
    r = subprocess.run(argv, cwd=work, env=env, capture_output=True, text=True, errors="replace", timeout=900)
    after = snapshot(work)
    files = {p: sha(os.path.join(work, p)) for p in sorted(after) if before.get(p) != after[p]}
    err = normalise(r.stderr, work).strip().splitlines()
    return {
        "rc": r.returncode,
        "stdout": hashlib.sha256(normalise(r.stdout, work).encode()).hexdigest(),
        "message": err[-1] if err else "",
        "files": files,
    }


def make_corpus(prt, work, env):
    steps = {}
    with open(os.path.join(work, "points.csv"), "w") as f:
        f.write("x,y,z,nx,ny,nz\n0,0.2,0,0,1,0\n0.5,1,0.3,0,0,1\n-0.4,0.6,0.2,1,0,0\n")
    for kind, argv in KINDS:
        argv = [a if not a.startswith(("models/", "envmaps/")) else os.path.join(REPO, a) for a in argv]
        steps["make/" + kind] = run_step([prt] + argv + ["-q"], work, env)
        print(f"  make {kind}: exit {steps['make/' + kind]['rc']}", file=sys.stderr)
    return steps


def consumers(prt, work, env, python):
    steps = {}
    absolute = lambda argv: [os.path.join(REPO, a) if a.startswith(("models/", "envmaps/")) else a for a in argv]
    for kind, _ in KINDS:
        for name, argv in consumer_steps(kind):
            steps[f"{kind}/{name}"] = run_step([prt] + absolute(argv), work, env)
        model = SCENE if kind in SCENE_KINDS else MESH
        steps[f"{kind}/python"] = run_step(
            [python, "-c", PY_CONSUMER, kind, kind + ".prt", os.path.join(REPO, model), os.path.join(REPO, ENV)],
            work, env)
        print(f"  {kind}: " + " ".join(f"{n.split('/')[1]}={s['rc']}" for n, s in steps.items()
                                        if n.startswith(kind + "/")), file=sys.stderr)
    # Kind-independent: the Monte Carlo reference and the comparison.
    steps["reference/vertices"] = run_step(
        [prt, "reference", os.path.join(REPO, MESH), os.path.join(REPO, ENV), "-o", "ref.csv", "--samples", "64",
         "--rotate", "30,0,0", "-q"], work, env)
    steps["reference/lightmap"] = run_step(
        [prt, "reference", os.path.join(REPO, SCENE), os.path.join(REPO, ENV), "--lightmap", "32x32", "-o",
         "ref.exr", "--samples", "16", "--mode", "interreflected", "-q"], work, env)
    steps["reference/at"] = run_step(
        [prt, "reference", os.path.join(REPO, SCENE), os.path.join(REPO, ENV), "--at", "points.csv", "-o",
         "ref.at.csv", "--samples", "64", "-q"], work, env)
    steps["compare/vertices"] = run_step([prt, "compare", "sh.relit.csv", "ref.csv", "--json"], work, env)
    steps["compare/lightmap"] = run_step([prt, "compare", "lightmap.relit.exr", "ref.exr", "--json"], work, env)
    return steps


def check(base, now):
    bytes_diff, message_diff = [], []
    for name in sorted(set(base) | set(now)):
        if name not in now:
            bytes_diff.append(f"GONE    {name}")
            continue
        if name not in base:
            bytes_diff.append(f"NEW     {name}")
            continue
        a, b = base[name], now[name]
        if a["rc"] != b["rc"]:
            bytes_diff.append(f"BYTES   {name}: exit {a['rc']} -> {b['rc']} ({b['message']})")
        if a["stdout"] != b["stdout"]:
            bytes_diff.append(f"BYTES   {name}: stdout differs")
        for f in sorted(set(a["files"]) | set(b["files"])):
            if a["files"].get(f) != b["files"].get(f):
                what = "gone" if f not in b["files"] else "new" if f not in a["files"] else "differs"
                bytes_diff.append(f"BYTES   {name}: {f} {what}")
        if a["message"] != b["message"]:
            message_diff.append(f"MESSAGE {name}:\n    was: {a['message']}\n    now: {b['message']}")
    return bytes_diff, message_diff


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--prt", default=os.path.join(REPO, "build", "prt"))
    ap.add_argument("--python", default="/usr/bin/python3", help="interpreter the module was built for")
    ap.add_argument("--python-path", default=os.path.join(REPO, "build", "python"))
    ap.add_argument("--work", default="/tmp/prt-output-corpus", help="work directory (emptied first)")
    g = ap.add_mutually_exclusive_group(required=True)
    g.add_argument("--record", metavar="MANIFEST")
    g.add_argument("--check", metavar="MANIFEST")
    a = ap.parse_args()
    prt = os.path.abspath(a.prt)
    work = os.path.abspath(a.work)
    shutil.rmtree(work, ignore_errors=True)
    os.makedirs(work)
    env = dict(os.environ, PYTHONPATH=a.python_path, PRT_EXE=prt, OMP_NUM_THREADS="1")
    env.pop("DISPLAY", None)  # prt view is not in the corpus; nothing opens a window
    steps = make_corpus(prt, work, env)
    steps.update(consumers(prt, work, env, a.python))
    if a.record:
        with open(a.record, "w") as f:
            json.dump(steps, f, indent=1, sort_keys=True)
        print(f"recorded {len(steps)} steps into {a.record}")
        return 0
    with open(a.check) as f:
        base = json.load(f)
    bytes_diff, message_diff = check(base, steps)
    for line in message_diff + bytes_diff:
        print(line)
    print(f"{len(steps)} steps: {len(bytes_diff)} byte differences, {len(message_diff)} message differences")
    return 1 if bytes_diff else 0


if __name__ == "__main__":
    sys.exit(main())
