#!/usr/bin/env python3
"""prt precompute under mpirun (docs/PRECOMPUTE.md, "Many processes").

Usage: check_mpi.py PRT_EXE MPIRUN [--ranks 1,2,3]

Every mode (unshadowed, shadowed, interreflected with bounces, RGB albedo,
glossy shadowed and interreflected, translucent (--material subsurface)
shadowed and interreflected, per vertex and in a lightmap, a directional
lightmap, wavelet) run with
2 and 3 ranks (mpirun --oversubscribe: more ranks than the machine's cores),
and four of them with 1 rank too, writes a file byte-identical to one
process without mpirun. A rank
that fails (PRT_TEST_FAIL_RANK) or a job interrupted by Ctrl-C ends every rank
with its message and a non-zero status, leaves no output and no temporary, and
no rank hangs (each run is bounded in time). Exit 0 when all hold, 1
otherwise (the lines say which), 77 when mpirun is missing (ctest: skipped).
"""
import argparse
import math
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import time

TIMEOUT_S = 120  # a run of these meshes takes about a second; a hang is what this bounds


def write_scene(path):
    """A floor with a ball over it and a box wall (OFF): occluded vertices, front hits, bounces."""
    verts, faces = [], []

    def quad_grid(k, size, y):
        base = len(verts)
        for j in range(k + 1):
            for i in range(k + 1):
                verts.append((-size + 2 * size * i / k, y, -size + 2 * size * j / k))
        for j in range(k):
            for i in range(k):
                a = base + j * (k + 1) + i
                faces.append((a, a + k + 1, a + 1))
                faces.append((a + 1, a + k + 1, a + k + 2))

    def sphere(rings, segs, r, c):
        base = len(verts)
        verts.append((c[0], c[1] + r, c[2]))
        for i in range(1, rings):
            th = math.pi * i / rings
            for j in range(segs):
                ph = 2 * math.pi * j / segs
                verts.append((c[0] + r * math.sin(th) * math.cos(ph), c[1] + r * math.cos(th),
                              c[2] + r * math.sin(th) * math.sin(ph)))
        verts.append((c[0], c[1] - r, c[2]))
        last = len(verts) - 1
        ring = lambda i, j: base + 1 + (i - 1) * segs + (j % segs)
        for j in range(segs):
            faces.append((base, ring(1, j + 1), ring(1, j)))
            faces.append((last, ring(rings - 1, j), ring(rings - 1, j + 1)))
        for i in range(1, rings - 1):
            for j in range(segs):
                faces.append((ring(i, j), ring(i, j + 1), ring(i + 1, j)))
                faces.append((ring(i, j + 1), ring(i + 1, j + 1), ring(i + 1, j)))

    quad_grid(20, 1.0, 0.0)
    sphere(12, 24, 0.4, (0.0, 0.5, 0.0))
    with open(path, "w") as f:
        f.write("OFF\n%d %d 0\n" % (len(verts), len(faces)))
        for v in verts:
            f.write("%.7g %.7g %.7g\n" % v)
        for t in faces:
            f.write("3 %d %d %d\n" % t)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("prt")
    ap.add_argument("mpirun")
    ap.add_argument("--ranks", default="2,3")
    # One rank under mpirun runs the ranks' code with nothing to split: kept
    # for a few modes (ONE_RANK_MODES), not all (each launch of mpirun costs a
    # second or more on CI's 2 cores; --ranks 1,2,3 runs it for every mode).
    ap.add_argument("--one-rank-modes", default="interreflected-spilled,glossy-interreflected,lightmap-subsurface,wavelet")
    args = ap.parse_args()
    mpirun = shutil.which(args.mpirun) or (args.mpirun if os.path.exists(args.mpirun) else None)
    if not mpirun:
        print("mpirun not found: skipped")
        return 77
    env = dict(os.environ)
    # Open MPI as root (CI runs as root) and in containers (NOTES.md).
    env.update(OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1",
               OMPI_MCA_btl_vader_single_copy_mechanism="none", OMPI_MCA_rmaps_base_oversubscribe="1")
    failures = []
    work = tempfile.mkdtemp(prefix="prt_mpi_")
    try:
        mesh = os.path.join(work, "scene.off")
        write_scene(mesh)
        common = ["--samples", "64", "-q"]
        modes = {
            "unshadowed": ["--mode", "unshadowed", "--bands", "4"],
            "shadowed": ["--mode", "shadowed", "--bands", "4"],
            "interreflected": ["--mode", "interreflected", "--bounces", "3", "--bands", "4"],
            "interreflected-rgb": ["--mode", "interreflected", "--albedo", "0.9,0.6,0.3", "--bands", "4"],
            # records past the limit go to the temporary file on every rank
            "interreflected-spilled": ["--mode", "interreflected", "--bounces", "2", "--bands", "4"],
            "glossy": ["--material", "glossy", "--bands", "3"],
            "glossy-interreflected": ["--material", "glossy", "--mode", "interreflected", "--bands", "3",
                                      "--albedo", "0.9,0.6,0.3"],
            # translucent: every rank traces its share, the surface integral then runs over all of them
            "subsurface": ["--material", "subsurface", "--sss", "marble", "--length-scale", "25", "--bands", "4"],
            "subsurface-interreflected": ["--material", "subsurface", "--sss", "skin1", "--length-scale", "25",
                                          "--mode", "interreflected", "--bands", "4"],
            # adaptive sample points: every rank makes the same choices, each batch split over the ranks
            "adaptive": ["--bands", "4", "--adaptive"],
            "adaptive-glossy-interreflected": ["--material", "glossy", "--mode", "interreflected", "--bands", "3",
                                               "--albedo", "0.9,0.6,0.3", "--adaptive", "--verify-adaptive", "0.2"],
            # --subdivide: every rank makes the same splits; the refined mesh (OUT.ply) compared too
            "subdivide": ["--bands", "4", "--subdivide", "0.05"],
            "subdivide-interreflected-glossy": ["--material", "glossy", "--mode", "interreflected", "--bands", "3",
                                                "--subdivide", "0.05"],
            # a lightmap's texels chosen adaptively (the scene below): the same choices on every rank
            "lightmap-adaptive-interreflected": ["--lightmap", "48x48", "--mode", "interreflected", "--bands", "3",
                                                 "--adaptive", "--verify-adaptive", "0.2"],
            # a translucent lightmap (the room below): the surface integral runs over every rank's texels
            "lightmap-subsurface": ["--lightmap", "24x24", "--material", "subsurface", "--sss", "ketchup",
                                    "--length-scale", "40", "--bands", "3"],
            "lightmap-subsurface-interreflected": ["--lightmap", "24x24", "--material", "subsurface", "--sss", "skin1",
                                                   "--length-scale", "40", "--mode", "interreflected", "--bands", "3"],
            # a directional lightmap's rows, its texels' glossy bounce records spilled past 20 kB
            "lightmap-directional-spilled": ["--lightmap", "24x24", "--directional", "--mode", "interreflected",
                                             "--bands", "3"],
        }
        # Runs on another input than the mesh above.
        models = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "models")
        inputs = {"lightmap-adaptive-interreflected": os.path.join(models, "wall-on-floor.gltf"),
                  "lightmap-subsurface": os.path.join(models, "room.gltf"),
                  "lightmap-subsurface-interreflected": os.path.join(models, "room.gltf"),
                  "lightmap-directional-spilled": os.path.join(models, "room.gltf")}
        for name, opts in list(modes.items()) + [("wavelet", ["--basis", "wavelet", "--cube-res", "8"])]:
            o = (common if name != "wavelet" else ["-q"]) + opts
            one = os.path.join(work, name + ".single.prt")
            # "spilled": the ranks keep 20 kB of records in memory and write
            # the rest to their temporary files (the single process keeps all).
            spill = {"PRT_TEST_RECORDS_IN_MEMORY": "20000"} if name.endswith("spilled") else {}
            src = inputs.get(name, mesh)
            r = subprocess.run([args.prt, "precompute", src, "-o", one] + o, env=os.environ.copy(),
                               capture_output=True, text=True, timeout=TIMEOUT_S)
            if r.returncode != 0:
                failures.append("%s: the single process failed: %s" % (name, r.stderr.strip()))
                continue
            reference = open(one, "rb").read()
            ranks = [int(x) for x in args.ranks.split(",")]
            if name in args.one_rank_modes.split(",") and 1 not in ranks:
                ranks = [1] + ranks
            for n in ranks:
                out = os.path.join(work, "%s.%d.prt" % (name, n))
                t0 = time.time()
                r = subprocess.run([mpirun, "--oversubscribe", "-np", str(n), args.prt, "precompute", src, "-o", out]
                                   + o, env=dict(env, **spill), capture_output=True, text=True, timeout=TIMEOUT_S)
                if r.returncode != 0:
                    failures.append("%s, %d ranks: exit %d: %s" % (name, n, r.returncode, r.stderr.strip()[-600:]))
                    continue
                same = os.path.exists(out) and open(out, "rb").read() == reference
                if "--subdivide" in opts:  # and the refined mesh written beside it
                    mesh_out, mesh_one = out[:-len(".prt")] + ".ply", one[:-len(".prt")] + ".ply"
                    same = same and os.path.exists(mesh_out) and open(mesh_out, "rb").read() == open(mesh_one, "rb").read()
                print("%-24s %d rank%s: %s (%.2f s)" % (name, n, "" if n == 1 else "s",
                                                     "byte-identical" if same else "DIFFERENT", time.time() - t0))
                if not same:
                    failures.append("%s, %d ranks: the file differs from the single process's" % (name, n))

        # A failing rank ends the job: its message, a non-zero status, no file, no hang.
        for fail_rank, n in [(1, 3), (0, 2)]:
            out = os.path.join(work, "failed.prt")
            e = dict(env, PRT_TEST_FAIL_RANK=str(fail_rank))
            try:
                r = subprocess.run([mpirun, "--oversubscribe", "-np", str(n), args.prt, "precompute", mesh, "-o", out,
                                    "--mode", "interreflected", "--bands", "4"] + common, env=e, capture_output=True, text=True,
                                   timeout=TIMEOUT_S)
            except subprocess.TimeoutExpired:
                failures.append("rank %d of %d failing: the job hung (over %d s)" % (fail_rank, n, TIMEOUT_S))
                continue
            want = "rank %d of %d fails (PRT_TEST_FAIL_RANK)" % (fail_rank, n)
            print("rank %d of %d failing: exit %d, message %s" % (fail_rank, n, r.returncode,
                                                                "found" if want in r.stderr else "MISSING"))
            if r.returncode == 0:
                failures.append("rank %d of %d failing: exit 0" % (fail_rank, n))
            if want not in r.stderr:
                failures.append("rank %d of %d failing: no message %r in: %s" % (fail_rank, n, want, r.stderr[-600:]))
            left = [f for f in os.listdir(work) if f.startswith("failed")]
            if left:
                failures.append("rank %d of %d failing: left %s" % (fail_rank, n, left))

        # Ctrl-C (SIGINT to mpirun, which forwards it): every rank stops, nothing is written.
        out = os.path.join(work, "interrupted.prt")
        p = subprocess.Popen([mpirun, "--oversubscribe", "-np", "2", args.prt, "precompute", mesh, "-o", out,
                              "--mode", "interreflected", "--samples", "200000", "--bands", "4"],
                             env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        time.sleep(3)
        p.send_signal(signal.SIGINT)
        try:
            _, err = p.communicate(timeout=TIMEOUT_S)
            print("Ctrl-C: exit %d" % p.returncode)
            if p.returncode == 0:
                failures.append("Ctrl-C: exit 0")
            left = [f for f in os.listdir(work) if f.startswith("interrupted")]
            if left:
                failures.append("Ctrl-C: left %s" % left)
        except subprocess.TimeoutExpired:
            p.kill()
            failures.append("Ctrl-C: the job did not end within %d s" % TIMEOUT_S)
    finally:
        shutil.rmtree(work, ignore_errors=True)
    for f in failures:
        print("FAIL:", f)
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
