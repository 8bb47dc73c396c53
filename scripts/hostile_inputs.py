#!/usr/bin/env python3
"""Hostile inputs against the built `prt` command and Python module (issue 45).

    scripts/hostile_inputs.py [--prt PATH] [--class NAME]... [--limit N] [--jobs N]
                              [--out DIR] [--timeout S] [--memory-cap GIB]
                              [--python PATH] [--list] [--quiet]

Generates malformed, extreme and valid-but-unusual inputs systematically
(every property of a small base input x every bad value of its kind), runs
each against `prt` (the python class: the prt module) with a per-case
timeout (20 s) and an address-space cap (4 GiB, RLIMIT_AS), records its peak
RSS (wait4's ru_maxrss) and classifies what happened:

  refused    exit 1 or 2 with a line of stderr that starts "prt CMD: error: "
             and names the file or option (python: prt.Error, ValueError,
             TypeError or OverflowError whose message names the argument)
  unclear    exit 1 or 2 without such a line
  accepted   exit 0
  crash      a signal, exit 3 (prt's internal error; python: an exception
             other than those above), or any other status
  hang       still running after the timeout (killed)
  memory     a refusal that peaked over 500 MB (REFUSAL_RSS_MB); a case of
             class gltf-cost, a "many points" or a 16k lightmap case over
             500 MB whatever its outcome (COST_RSS_MB); or out of memory
             (bad_alloc, MemoryError, killed)

Each case says what it expects: invalid (prt must refuse it), valid (prt
must accept it) or either (only crash, hang and memory count). A finding is
a crash, hang or memory outcome, an invalid case accepted
(accepted-invalid), a valid case not accepted (valid-refused), or an unclear
refusal. The script exits 1 when there is any finding, else 0 (2: it could
not run).

Classes (--class, repeatable; about 4,700 cases, 9 minutes on 2 cores):
  gltf-invalid  every property of a base scene (a textured floor, an
                occluder with a morph target, nodes, camera, animation,
                sampler, image, buffer views, accessors) x the bad values of
                its kind (JSON types, array lengths, ranges, enums, indices
                and what they index, texCoord sets), removed where required;
                node graphs, KHR_texture_transform, JSON syntax, the GLB
                container. Each value goes to one of the two glTF readers in
                turn: `prt precompute --lightmap` (the scene reader) and
                `prt precompute` per vertex (the mesh reader).
  gltf-cost     deep and wide node graphs (to 1e6 nodes), deep JSON, images
                and buffers that are directories, FIFOs, /dev/zero, links;
                PNG bombs (16k x 16k and more in a few KB).
  gltf-valid    what the specification allows: percent-encoded URIs, data
                URIs, GLB, extras, byte/short/int indices, normalised UVs,
                interleaved views, missing optional parts, PNG kinds.
  probe-damage  a probe volume's header fields, array counts, visibility
                quadtree node ids, offsets, partial texels, flags, states,
                positions (checksum recomputed), truncation; through prt
                info, prt relight --at and prt export --probes.
  options       every option of precompute, relight, reference and export
                (read from --help) x the bad values of its type; empty,
                directory, FIFO and missing paths; one path for two outputs;
                outputs over inputs; the issue's --lightmap/--memory-limit
                combinations.
  points        prt relight --at and prt reference --at: every field x NaN,
                inf, past 1e12, text; zero normals; the CSV's structure.
  python        precompute, precompute_lightmap, precompute_probes,
                Scene.lightmap_uv_set, ProbeVolume.at, export_probes,
                compress and the SH core with out-of-range arguments. Each
                case is a standalone DIR/work/c/ID/case.py, run in a child
                forked from an interpreter with numpy and prt imported.
                Skipped, with a note, when the module cannot be imported.

The base inputs (DIR/work/base) are made here and by the prt under test (a
lightmap, probe volumes, vertex transfers, with few samples). Every case's
command, outcome, peak RSS and message goes to DIR/cases.csv (--out;
default a new temporary directory, kept), every case's inputs stay in
DIR/work/c/ID, and each finding is printed with a command line to paste.

Python 3 standard library only (the checksum of damaged probe files is
XXH3-64: libxxhash through ctypes when installed, else a Python version).
"""
import argparse
import base64
import collections
import concurrent.futures
import copy
import csv
import ctypes
import ctypes.util
import itertools
import json
import math
import os
import pathlib
import re
import shlex
import shutil
import signal
import struct
import subprocess
import sys
import tempfile
import threading
import time
import zlib

REPO = pathlib.Path(__file__).resolve().parents[1]
REFUSAL_RSS_MB = 500      # a refusal of a small input may hold at most this
COST_RSS_MB = 500         # the gltf-cost class: at most this whatever the outcome
DEFAULT_TIMEOUT = 20.0
DEFAULT_CAP_GB = 4.0
CLASSES = ["gltf-invalid", "gltf-cost", "gltf-valid", "probe-damage", "options", "points", "python"]
OUTCOMES = ["refused", "accepted", "unclear", "crash", "hang", "memory"]

# ----------------------------------------------------------------------------
# XXH3-64 (seed 0), the checksum of prt's files: libxxhash through ctypes when
# it is installed, else this pure-Python version of the reference algorithm.

_M64 = (1 << 64) - 1
_P32_1, _P32_2, _P32_3 = 0x9E3779B1, 0x85EBCA77, 0xC2B2AE3D
_P64_1, _P64_2, _P64_3, _P64_4, _P64_5 = (0x9E3779B185EBCA87, 0xC2B2AE3D27D4EB4F, 0x165667B19E3779F9,
                                         0x85EBCA77C2B2AE63, 0x27D4EB2F165667C5)
_SECRET = bytes.fromhex(
    "b8fe6c3923a44bbe7c01812cf721ad1cded46de9839097db7240a4a4b7b3671f"
    "cb79e64eccc0e578825ad07dccff7221b8084674f743248ee03590e6813a264c"
    "3c2852bb91c300cb88d0658b1b532ea371644897a20df94e3819ef46a9deacd8"
    "a8fa763fe39c343ff9dcbbc7c70b4f1d8a51e04bcdb45931c89f7ec9d9787364"
    "eac5ac8334d3ebc3c581a0fffa1363eb170ddd51b7f0da49d316552629d4689e"
    "2b16be587d47a1fc8ff8b8d17ad031ce45cb3a8f95160428afd7fbcabb4b407e")


def _r64(b, i):
    return struct.unpack_from("<Q", b, i)[0]


def _r32(b, i):
    return struct.unpack_from("<I", b, i)[0]


def _fold(a, b):
    p = a * b
    return (p & _M64) ^ (p >> 64)


def _avalanche(h):
    h ^= h >> 37
    h = (h * 0x165667919E3779F9) & _M64
    return h ^ (h >> 32)


def _xxh64_avalanche(h):
    h ^= h >> 33
    h = (h * _P64_2) & _M64
    h ^= h >> 29
    h = (h * _P64_3) & _M64
    return h ^ (h >> 32)


def _mix16(b, i, s):
    return _fold(_r64(b, i) ^ _r64(_SECRET, s), _r64(b, i + 8) ^ _r64(_SECRET, s + 8))


def xxh3_64_python(b):
    n = len(b)
    if n == 0:
        return _xxh64_avalanche(_r64(_SECRET, 56) ^ _r64(_SECRET, 64))
    if n <= 3:
        combined = (b[0] << 16) | (b[n >> 1] << 24) | b[n - 1] | (n << 8)
        return _xxh64_avalanche(combined ^ (_r32(_SECRET, 0) ^ _r32(_SECRET, 4)))
    if n <= 8:
        keyed = (_r32(b, n - 4) + (_r32(b, 0) << 32)) ^ (_r64(_SECRET, 8) ^ _r64(_SECRET, 16))
        rot = lambda x, r: ((x << r) | (x >> (64 - r))) & _M64  # noqa: E731
        h = keyed ^ rot(keyed, 49) ^ rot(keyed, 24)
        h = (h * 0x9FB21C651E98DF25) & _M64
        h ^= (h >> 35) + n
        h = (h * 0x9FB21C651E98DF25) & _M64
        return h ^ (h >> 28)
    if n <= 16:
        lo = _r64(b, 0) ^ (_r64(_SECRET, 24) ^ _r64(_SECRET, 32))
        hi = _r64(b, n - 8) ^ (_r64(_SECRET, 40) ^ _r64(_SECRET, 48))
        swapped = int.from_bytes(lo.to_bytes(8, "little"), "big")
        return _avalanche((n + swapped + hi + _fold(lo, hi)) & _M64)
    if n <= 128:
        acc = (n * _P64_1) & _M64
        if n > 32:
            if n > 64:
                if n > 96:
                    acc += _mix16(b, 48, 96) + _mix16(b, n - 64, 112)
                acc += _mix16(b, 32, 64) + _mix16(b, n - 48, 80)
            acc += _mix16(b, 16, 32) + _mix16(b, n - 32, 48)
        acc += _mix16(b, 0, 0) + _mix16(b, n - 16, 16)
        return _avalanche(acc & _M64)
    if n <= 240:
        acc = (n * _P64_1) & _M64
        for i in range(8):
            acc += _mix16(b, 16 * i, 16 * i)
        acc = _avalanche(acc & _M64)
        for i in range(8, n // 16):
            acc += _mix16(b, 16 * i, 16 * (i - 8) + 3)
        acc += _mix16(b, n - 16, 136 - 17)
        return _avalanche(acc & _M64)
    acc = [_P32_3, _P64_1, _P64_2, _P64_3, _P64_4, _P32_2, _P64_5, _P32_1]
    secret_keys = [[_r64(_SECRET, 8 * s + 8 * i) for i in range(8)] for s in range(17)]
    last_keys = [_r64(_SECRET, 192 - 64 - 7 + 8 * i) for i in range(8)]
    scramble_keys = [_r64(_SECRET, 192 - 64 + 8 * i) for i in range(8)]

    def stripe(off, keys):
        d = struct.unpack_from("<8Q", b, off)
        for i in range(8):
            k = d[i] ^ keys[i]
            acc[i ^ 1] = (acc[i ^ 1] + d[i]) & _M64
            acc[i] = (acc[i] + (k & 0xFFFFFFFF) * (k >> 32)) & _M64

    block = 64 * 16
    blocks = (n - 1) // block
    for blk in range(blocks):
        for s in range(16):
            stripe(blk * block + 64 * s, secret_keys[s])
        for i in range(8):
            a = acc[i]
            a ^= a >> 47
            a ^= scramble_keys[i]
            acc[i] = (a * _P32_1) & _M64
    for s in range(((n - 1) - block * blocks) // 64):
        stripe(blocks * block + 64 * s, secret_keys[s])
    stripe(n - 64, last_keys)
    result = (n * _P64_1) & _M64
    for i in range(4):
        result += _fold(acc[2 * i] ^ _r64(_SECRET, 11 + 16 * i), acc[2 * i + 1] ^ _r64(_SECRET, 11 + 16 * i + 8))
    return _avalanche(result & _M64)


def _libxxhash():
    for name in ("libxxhash.so.0", ctypes.util.find_library("xxhash")):
        if not name:
            continue
        try:
            lib = ctypes.CDLL(name)
            lib.XXH3_64bits.restype = ctypes.c_uint64
            lib.XXH3_64bits.argtypes = [ctypes.c_char_p, ctypes.c_size_t]
            return lib
        except (OSError, AttributeError):
            pass
    return None


_LIBXXH = _libxxhash()


def xxh3_64(b):
    b = bytes(b)
    return _LIBXXH.XXH3_64bits(b, len(b)) if _LIBXXH else xxh3_64_python(b)


def with_checksum(body):
    """A prt file from everything before its trailer: + XXH3-64 + PRTE."""
    return bytes(body) + struct.pack("<Q", xxh3_64(body)) + b"PRTE"


# ----------------------------------------------------------------------------
# JSON with raw tokens (1e999, NaN, -0: what json.dumps cannot write).

class Raw:
    """A JSON token written as is (1e999, NaN, -0, a lone surrogate escape)."""
    __slots__ = ("token",)

    def __init__(self, token):
        self.token = token

    def __repr__(self):
        return self.token

    def __deepcopy__(self, memo):
        return self


def dump_json(v):
    """Compact JSON of v, Raw tokens written as they are."""
    raws = []

    def placeholder(o):
        if isinstance(o, Raw):
            raws.append(o.token)
            return "\0RAW%d\0" % (len(raws) - 1)
        raise TypeError(type(o))
    text = json.dumps(v, separators=(",", ":"), default=placeholder)
    for i, tok in enumerate(raws):
        text = text.replace('"\\u0000RAW%d\\u0000"' % i, tok, 1)
    return text


MISSING = object()


def get_path(doc, path):
    for k in path:
        if isinstance(doc, dict):
            if k not in doc:
                return MISSING
            doc = doc[k]
        elif isinstance(doc, list) and isinstance(k, int) and 0 <= k < len(doc):
            doc = doc[k]
        else:
            return MISSING
    return doc


def set_path(doc, path, value):
    """Sets doc[path] = value, making the objects on the way."""
    for k in path[:-1]:
        if isinstance(doc, dict):
            doc = doc.setdefault(k, {})
        else:
            doc = doc[k]
    doc[path[-1]] = value


def del_path(doc, path):
    parent = get_path(doc, path[:-1])
    if isinstance(parent, dict):
        parent.pop(path[-1], None)
    elif isinstance(parent, list):
        del parent[path[-1]]


def path_text(path):
    return "".join(f"[{k}]" if isinstance(k, int) else (f".{k}" if i else k) for i, k in enumerate(path))


# ----------------------------------------------------------------------------
# Small image and map writers.

def png_bytes(width, height, rows=None, bit_depth=8, color_type=2, chunk_rows=256, ihdr=None, idat=None):
    """A PNG (filter 0 rows); `rows(y)` gives a row's bytes (default zeros).
    `ihdr`/`idat` override the header fields / the compressed data."""
    def chunk(kind, data):
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF)

    channels = {0: 1, 2: 3, 3: 1, 4: 2, 6: 4}[color_type]
    row_bytes = (width * channels * bit_depth + 7) // 8
    header = struct.pack(">IIBBBBB", width, height, bit_depth, color_type, 0, 0, 0) if ihdr is None else ihdr
    if idat is None:
        comp = zlib.compressobj(9)
        parts = []
        zero_row = b"\0" * (row_bytes + 1)
        for y0 in range(0, height, chunk_rows):
            n = min(chunk_rows, height - y0)
            if rows is None:
                parts.append(comp.compress(zero_row * n))
            else:
                parts.append(comp.compress(b"".join(b"\0" + rows(y) for y in range(y0, y0 + n))))
        parts.append(comp.flush())
        idat = b"".join(parts)
    return b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", header) + chunk(b"IDAT", idat) + chunk(b"IEND", b"")


def hdr_bytes(width, height, rgb=(1.0, 0.8, 0.6)):
    """A Radiance RGBE map (flat scanlines), every pixel `rgb`."""
    m = max(rgb)
    e = math.frexp(m)[1] if m > 0 else -128
    px = bytes(int(c / math.ldexp(1.0, e) * 256) & 0xFF for c in rgb) + bytes([(e + 128) & 0xFF])
    head = b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y %d +X %d\n" % (height, width)
    return head + px * (width * height)


# ----------------------------------------------------------------------------
# Cases and their outcomes.

# The spawn server: reads one JSON request a line, runs it (own session,
# address-space cap, no core file, stdout/stderr to files), answers with its
# wait status, peak RSS (kB), wall time and whether it was killed at the timeout.
SPAWN_SERVER = r"""
import json, os, resource, signal, sys, time, traceback
if sys.argv[1:] == ["--preload"]:  # python cases: numpy and prt imported once, each case a forked child
    import numpy, prt
for line in sys.stdin:
    q = json.loads(line)
    t0 = time.monotonic()
    pid = os.fork()
    if pid == 0:
        code = 127
        try:
            os.setsid()
            resource.setrlimit(resource.RLIMIT_AS, (q["cap"], q["cap"]))
            resource.setrlimit(resource.RLIMIT_CORE, (0, 0))
            fd = os.open(os.devnull, os.O_RDONLY); os.dup2(fd, 0)
            fd = os.open(q["out"], os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o644); os.dup2(fd, 1)
            fd = os.open(q["err"], os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o644); os.dup2(fd, 2)
            os.chdir(q["cwd"])
            if "script" not in q:
                os.execve(q["argv"][0], q["argv"], q["env"])
            sys.argv = [q["script"]]
            try:
                exec(compile(open(q["script"]).read(), q["script"], "exec"), {"__name__": "__main__"})
                code = 0
            except SystemExit as e:
                code = e.code if isinstance(e.code, int) else (0 if e.code is None else 1)
            except BaseException:
                traceback.print_exc()
                code = 3
            sys.stdout.flush()
            sys.stderr.flush()
        except BaseException as e:
            os.write(2, ("HOSTILE-EXEC-FAILED: %r\n" % (e,)).encode())
        os._exit(code)
    deadline, pause, killed = t0 + q["timeout"], 0.002, False
    while True:
        got, status, ru = os.wait4(pid, os.WNOHANG)
        if got:
            break
        if time.monotonic() > deadline:
            killed = True
            try:
                os.killpg(pid, signal.SIGKILL)
            except ProcessLookupError:
                pass
            got, status, ru = os.wait4(pid, 0)
            break
        time.sleep(pause)
        pause = min(pause * 1.5, 0.05)
    sys.stdout.write(json.dumps({"status": status, "maxrss": ru.ru_maxrss, "wall": time.monotonic() - t0,
                                 "timed_out": killed}) + "\n")
    sys.stdout.flush()
"""


class Case:
    """One input. `make(d)` writes its files into the directory d (a Path)
    and returns the command (a list; for the python class the code to run).
    `tokens`: what a clean refusal must name (any one of them: a file's
    name, an option); empty: any clean refusal line will do."""
    __slots__ = ("cls", "name", "make", "expect", "tokens", "timeout", "rss_mb", "kind", "note", "id")

    def __init__(self, cls, name, make, expect, tokens=(), timeout=None, rss_mb=None, kind="prt", note=""):
        assert expect in ("invalid", "valid", "either"), expect
        self.cls, self.name, self.make, self.expect = cls, name, make, expect
        self.tokens, self.timeout, self.rss_mb, self.kind, self.note = tokens, timeout, rss_mb, kind, note
        self.id = None


GENERATORS = {}  # class name: function (base, python settings) -> cases, or a reason to skip


class Result:
    __slots__ = ("case", "argv", "env", "cwd", "rc", "sig", "wall", "rss_mb", "outcome", "message", "finding", "stderr")


class Runner:
    def __init__(self, prt, work, timeout, cap_bytes, python=None, pythonpath=None):
        self.prt, self.work, self.timeout, self.cap = prt, pathlib.Path(work), timeout, cap_bytes
        self.python, self.pythonpath = python, pythonpath
        self._local, self._servers, self._servers_lock = threading.local(), [], threading.Lock()

    def _server(self, python_case=False):
        """This thread's spawn server (started small, so that what a child
        inherits of its parent's resident set at fork, which Linux counts in
        the child's ru_maxrss, is a few MB and not this script's). Python
        cases fork from a server with numpy and prt imported (about 45 MB
        counted in each case's peak)."""
        key = "pyserver" if python_case else "server"
        srv = getattr(self._local, key, None)
        if srv is None or srv.poll() is not None:
            if python_case:
                env = dict(os.environ)
                env["PYTHONPATH"] = self.pythonpath + (os.pathsep + env["PYTHONPATH"] if env.get("PYTHONPATH") else "")
                argv = [self.python, "-c", SPAWN_SERVER, "--preload"]
            else:
                env, argv = None, [sys.executable, "-S", "-c", SPAWN_SERVER]
            srv = subprocess.Popen(argv, stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True, bufsize=1, env=env)
            setattr(self._local, key, srv)
            with self._servers_lock:
                self._servers.append(srv)
        return srv

    def close(self):
        for srv in self._servers:
            try:
                srv.stdin.close()
                srv.wait(timeout=30)
            except (OSError, subprocess.TimeoutExpired):
                pass

    def _spawn(self, argv, env, d, timeout, script=None):
        """Runs argv in d (or, for a python case, the script in a child of the
        preloaded server); returns (status, maxrss_kb, wall, timed_out, stderr bytes)."""
        srv = self._server(script is not None)
        req = {"argv": argv, "env": env, "cwd": str(d), "timeout": timeout, "cap": self.cap,
               "out": str(d / ".stdout"), "err": str(d / ".stderr")}
        if script is not None:
            req["script"] = str(script)
        srv.stdin.write(json.dumps(req) + "\n")
        srv.stdin.flush()
        line = srv.stdout.readline()
        if not line:
            raise RuntimeError("the spawn server died (python: cannot import prt?)")
        rep = json.loads(line)
        return rep["status"], rep["maxrss"], rep["wall"], rep["timed_out"], (d / ".stderr").read_bytes()

    def run(self, case):
        d = self.work / "c" / case.id
        if d.exists():
            shutil.rmtree(d, ignore_errors=True)
        d.mkdir(parents=True)
        made = case.make(d)
        r = Result()
        r.case, r.cwd = case, d
        env = dict(os.environ)
        script = None
        if case.kind == "python":
            script = d / "case.py"
            script.write_text(made)
            r.argv = [self.python, str(script)]
            env["PYTHONPATH"] = self.pythonpath + (os.pathsep + env["PYTHONPATH"] if env.get("PYTHONPATH") else "")
            r.env = {"PYTHONPATH": self.pythonpath}
        else:
            r.argv = [self.prt] + [str(a) for a in made]
            r.env = {}
        timeout = case.timeout or self.timeout
        for attempt in range(6):  # the shared build may be mid-rebuild: wait and retry
            status, maxrss, wall, timed_out, err = self._spawn(r.argv, env, d, timeout, script)
            text = err.decode("utf-8", "replace")
            if not timed_out and os.WIFEXITED(status) and os.WEXITSTATUS(status) == 127 and \
                    ("error while loading shared libraries" in text or "HOSTILE-EXEC-FAILED" in text):
                if attempt == 5:
                    raise RuntimeError(f"cannot run {r.argv[0]}: {text.strip()[:200]}")
                time.sleep(30)  # missing or half-written: the shared build is being rebuilt
                continue
            break
        r.wall = wall
        r.rss_mb = maxrss / 1024.0
        r.rc = os.WEXITSTATUS(status) if os.WIFEXITED(status) else None
        r.sig = os.WTERMSIG(status) if os.WIFSIGNALED(status) else None
        r.stderr = text
        classify(r, timed_out, self.cap)
        return r


def classify(r, timed_out, cap):
    case = r.case
    lines = [ln.strip() for ln in r.stderr.splitlines() if ln.strip()]
    r.message = ""
    if case.kind == "python":
        prefixes = ("PYREFUSED: ",)
    else:
        sub = r.argv[1] if len(r.argv) > 1 else ""
        prefixes = (f"prt {sub}: error: ",)
    clean = next((ln for ln in lines if ln.startswith(prefixes)), None)
    r.message = (clean or (lines[-1] if lines else ""))[:400]
    mem_words = ("bad_alloc", "out of memory", "Cannot allocate memory", "MemoryError", "std::length_error")
    oom = any(w in r.stderr for w in mem_words)
    if timed_out:
        outcome = "hang"
    elif r.sig is not None:
        outcome = "memory" if (r.sig == signal.SIGKILL or oom) else "crash"
    elif r.rc == 0:
        outcome = "accepted"
    elif r.rc in (1, 2):
        if clean is None:
            outcome = "unclear"
        else:
            outcome = "refused"
            if case.tokens and not any(str(n) in clean for n in case.tokens):
                outcome = "unclear"  # refused, but the message names neither the file nor the option
        if oom:
            outcome = "memory"
    elif case.kind == "python" and r.rc == 4:
        outcome = "memory"
    else:
        outcome = "memory" if oom else "crash"
    bound = case.rss_mb if case.rss_mb is not None else (REFUSAL_RSS_MB if outcome in ("refused", "unclear") else None)
    if outcome not in ("hang", "crash") and bound is not None and r.rss_mb > bound:
        outcome = "memory"
    r.outcome = outcome
    if outcome in ("crash", "hang", "memory"):
        r.finding = outcome
    elif case.expect == "valid" and outcome != "accepted":
        r.finding = "valid-refused"
    elif case.expect == "invalid" and outcome == "accepted":
        r.finding = "accepted-invalid"
    elif outcome == "unclear":
        r.finding = "unclear-refusal"
    else:
        r.finding = ""


# ----------------------------------------------------------------------------
# The valid base inputs every case starts from.

# A floor quad (its texture through TEXCOORD_0, its lightmap chart in the left
# half of TEXCOORD_1) and a smaller occluder quad above it facing down (a
# morph target, its chart in the right half), a root node with both as
# children, a camera node, an animation of the occluder, two materials, one
# texture/sampler/image (a PNG file), one external buffer.
FLOOR = [(-1, 0, -1), (1, 0, -1), (1, 0, 1), (-1, 0, 1)]
OCC = [(-0.4, 0.6, -0.4), (0.4, 0.6, -0.4), (0.4, 0.6, 0.4), (-0.4, 0.6, 0.4)]
UV0 = [(0, 0), (1, 0), (1, 1), (0, 1)]
UV1_FLOOR = [(0.03, 0.03), (0.47, 0.03), (0.47, 0.97), (0.03, 0.97)]
UV1_OCC = [(0.53, 0.03), (0.97, 0.03), (0.97, 0.97), (0.53, 0.97)]
IDX_FLOOR = [0, 2, 1, 0, 3, 2]      # counter-clockwise seen from +y
IDX_OCC = [0, 1, 2, 0, 2, 3]        # seen from -y


def base_gltf():
    """(doc, bin): the base scene's JSON and buffer."""
    f = lambda fmt, vals: b"".join(struct.pack(fmt, *v) for v in vals)  # noqa: E731
    pos = f("<3f", FLOOR + OCC)                                  # view 0: 96 bytes
    nrm = f("<3f", [(0, 1, 0)] * 4 + [(0, -1, 0)] * 4)           # view 1: 96
    uv0 = f("<2f", UV0 + UV0)                                    # view 2: 64
    uv1 = f("<2f", UV1_FLOOR + UV1_OCC)                          # view 3: 64
    idx = struct.pack("<12H", *(IDX_FLOOR + IDX_OCC))            # view 4: 24
    morph = f("<3f", [(0, 0.1, 0)] * 4)                          # view 5: 48
    anim = struct.pack("<2f", 0, 1) + f("<3f", [(0, 0, 0), (0, 0.2, 0)])  # view 6: 8 + 24
    parts = [pos, nrm, uv0, uv1, idx, morph, anim]
    views, buf = [], b""
    targets = [34962, 34962, 34962, 34962, 34963, 34962, None]
    for p, t in zip(parts, targets):
        v = {"buffer": 0, "byteOffset": len(buf), "byteLength": len(p)}
        if t:
            v["target"] = t
        views.append(v)
        buf += p + b"\0" * (-len(p) % 4)
    acc = lambda view, off, ct, n, typ, **kw: dict({"bufferView": view, "byteOffset": off, "componentType": ct,  # noqa
                                                    "count": n, "type": typ}, **kw)
    mn = lambda pts: [min(p[k] for p in pts) for k in range(3)]  # noqa: E731
    mx = lambda pts: [max(p[k] for p in pts) for k in range(3)]  # noqa: E731
    accessors = [
        acc(0, 0, 5126, 4, "VEC3", min=mn(FLOOR), max=mx(FLOOR)),   # 0 floor POSITION
        acc(1, 0, 5126, 4, "VEC3"),                                 # 1 floor NORMAL
        acc(2, 0, 5126, 4, "VEC2"),                                 # 2 floor TEXCOORD_0
        acc(3, 0, 5126, 4, "VEC2"),                                 # 3 floor TEXCOORD_1
        acc(4, 0, 5123, 6, "SCALAR"),                               # 4 floor indices
        acc(0, 48, 5126, 4, "VEC3", min=mn(OCC), max=mx(OCC)),      # 5 occluder POSITION
        acc(1, 48, 5126, 4, "VEC3"),                                # 6 occluder NORMAL
        acc(2, 32, 5126, 4, "VEC2"),                                # 7 occluder TEXCOORD_0
        acc(3, 32, 5126, 4, "VEC2"),                                # 8 occluder TEXCOORD_1
        acc(4, 12, 5123, 6, "SCALAR"),                              # 9 occluder indices
        acc(5, 0, 5126, 4, "VEC3", min=[0, 0.1, 0], max=[0, 0.1, 0]),  # 10 morph target POSITION
        acc(6, 0, 5126, 2, "SCALAR", min=[0], max=[1]),             # 11 animation input
        acc(6, 8, 5126, 2, "VEC3"),                                 # 12 animation output
    ]
    doc = {
        "asset": {"version": "2.0", "minVersion": "2.0", "generator": "scripts/hostile_inputs.py"},
        "extensionsUsed": ["KHR_materials_emissive_strength"],
        "scene": 0,
        "scenes": [{"name": "base", "nodes": [0, 3]}],
        "nodes": [
            {"name": "root", "children": [1, 2], "translation": [0, 0, 0]},
            {"name": "floor", "mesh": 0},
            {"name": "occluder", "mesh": 1, "translation": [0, 0.2, 0], "rotation": [0, 0, 0, 1], "scale": [1, 1, 1],
             "weights": [0]},
            {"name": "camera", "camera": 0, "matrix": [1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 1, 3, 1]},
        ],
        "meshes": [
            {"name": "floor", "primitives": [{"attributes": {"POSITION": 0, "NORMAL": 1, "TEXCOORD_0": 2, "TEXCOORD_1": 3},
                                              "indices": 4, "material": 0, "mode": 4}]},
            {"name": "occluder", "primitives": [{"attributes": {"POSITION": 5, "NORMAL": 6, "TEXCOORD_0": 7, "TEXCOORD_1": 8},
                                                 "indices": 9, "material": 1, "targets": [{"POSITION": 10}]}],
             "weights": [0]},
        ],
        "materials": [
            {"name": "tiles", "pbrMetallicRoughness": {"baseColorFactor": [1, 1, 1, 1], "metallicFactor": 0,
                                                       "roughnessFactor": 1,
                                                       "baseColorTexture": {"index": 0, "texCoord": 0}},
             "occlusionTexture": {"index": 0, "texCoord": 1, "strength": 1},
             "emissiveFactor": [0, 0, 0], "alphaMode": "OPAQUE", "alphaCutoff": 0.5, "doubleSided": False,
             "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": 1}}},
            {"name": "paint", "pbrMetallicRoughness": {"baseColorFactor": [0.8, 0.5, 0.3, 1]},
             "normalTexture": {"index": 0, "scale": 1}},
        ],
        "textures": [{"sampler": 0, "source": 0}],
        "samplers": [{"magFilter": 9729, "minFilter": 9987, "wrapS": 10497, "wrapT": 10497}],
        "images": [{"uri": "tex.png", "mimeType": "image/png"}],
        "cameras": [{"type": "perspective", "perspective": {"yfov": 0.8, "znear": 0.1, "zfar": 100, "aspectRatio": 1.5}}],
        "animations": [{"channels": [{"sampler": 0, "target": {"node": 2, "path": "translation"}}],
                        "samplers": [{"input": 11, "output": 12, "interpolation": "LINEAR"}]}],
        "buffers": [{"uri": "scene.bin", "byteLength": len(buf)}],
        "bufferViews": views,
        "accessors": accessors,
    }
    return doc, buf


def glb_bytes(doc, buf):
    """The GLB of doc (its buffer 0 becoming the BIN chunk) and buf."""
    doc = copy.deepcopy(doc)
    doc["buffers"][0].pop("uri", None)
    js = dump_json(doc).encode()
    js += b" " * (-len(js) % 4)
    b = buf + b"\0" * (-len(buf) % 4)
    body = struct.pack("<I4s", len(js), b"JSON") + js + struct.pack("<I4s", len(b), b"BIN\0") + b
    return struct.pack("<4sII", b"glTF", 2, 12 + len(body)) + body


def checker_png():
    return png_bytes(4, 4, rows=lambda y: bytes(((x + y) % 2) * 200 + 30 for x in range(4) for _ in range(3)))


class Base:
    """The base inputs (in WORK/base) and the prt files made from them."""

    def __init__(self, work, prt):
        self.dir = pathlib.Path(work) / "base"
        self.prt = prt
        self.doc, self.bin = base_gltf()
        self.png = checker_png()

    def path(self, name):
        return self.dir / name

    def write_scene(self, d, doc=None, name="scene.gltf", bin_name="scene.bin", png_name="tex.png", raw=None):
        """Writes a glTF (doc, or the raw bytes) into d with the base buffer
        and texture beside it (hard links); returns its path."""
        d = pathlib.Path(d)
        for src, dst in (("scene.bin", bin_name), ("tex.png", png_name)):
            if dst and not (d / dst).exists():
                try:
                    os.link(self.path(src), d / dst)
                except OSError:
                    shutil.copyfile(self.path(src), d / dst)
        data = raw if raw is not None else dump_json(self.doc if doc is None else doc).encode()
        (d / name).write_bytes(data)
        return d / name

    def setup(self):
        self.dir.mkdir(parents=True, exist_ok=True)
        (self.dir / "scene.bin").write_bytes(self.bin)
        (self.dir / "tex.png").write_bytes(self.png)
        (self.dir / "scene.gltf").write_text(dump_json(self.doc))
        (self.dir / "scene.glb").write_bytes(glb_bytes(self.doc, self.bin))
        (self.dir / "env.hdr").write_bytes(hdr_bytes(32, 16))
        # A small closed-ish mesh for the vertex and subdivision paths: a box of 12 triangles on the floor quad.
        v = FLOOR + [(x, y, z) for y in (0.1, 0.5) for x, z in ((-0.3, -0.3), (0.3, -0.3), (0.3, 0.3), (-0.3, 0.3))]
        faces = [(1, 3, 2), (1, 4, 3), (9, 10, 11), (9, 11, 12), (5, 6, 10), (5, 10, 9), (6, 7, 11), (6, 11, 10),
                 (7, 8, 12), (7, 12, 11), (8, 5, 9), (8, 9, 12)]
        (self.dir / "mesh.obj").write_text("".join("v %g %g %g\n" % p for p in v) +
                                           "".join("f %d %d %d\n" % f for f in faces))
        (self.dir / "pts.csv").write_text("x,y,z,nx,ny,nz\n0,0.3,0,0,1,0\n0.5,0.1,0.5,0,1,0\n-0.5,1,0,1,0,0\n")
        scene, env = self.path("scene.gltf"), self.path("env.hdr")
        runs = {
            "lm.prt": ["precompute", scene, "--lightmap", "8x8", "--samples", "8", "--bands", "2", "-q"],
            "probes.prt": ["precompute", scene, "--probes", "3x2x3", "--probe-cube", "8", "--samples", "32", "-q"],
            "probes-ir.prt": ["precompute", scene, "--probes", "2x2x2", "--probe-cube", "4", "--samples", "16",
                              "--mode", "interreflected", "--bounce-bands", "2", "--bands", "2", "-q"],
            "mesh.prt": ["precompute", self.path("mesh.obj"), "--samples", "8", "--bands", "2", "-q"],
            "glossy.prt": ["precompute", self.path("mesh.obj"), "--samples", "8", "--bands", "2", "--material", "glossy",
                           "-q"],
        }
        for out, args in runs.items():
            self.prt_ok(args + ["-o", self.path(out)])
        # The base inputs must be accepted, or no case means anything.
        checks = [
            ["relight", scene, self.path("lm.prt"), env, "-q", "-o", self.path("check-lm.exr")],
            ["relight", scene, self.path("probes.prt"), env, "--at", self.path("pts.csv"), "-q", "-o",
             self.path("check-at.csv")],
            ["reference", scene, env, "--at", self.path("pts.csv"), "--samples", "4", "-q", "-o",
             self.path("check-ref.csv")],
            ["precompute", scene, "-o", self.path("check-mesh.prt"), "--samples", "8", "-q"],
            ["precompute", self.path("scene.glb"), "--lightmap", "8x8", "--samples", "8", "-q", "-o",
             self.path("check-glb.prt")],
            ["info", self.path("probes.prt")],
        ]
        for args in checks:
            self.prt_ok(args)

    def prt_ok(self, args):
        argv = [self.prt] + [str(a) for a in args]
        for attempt in range(6):
            try:
                r = subprocess.run(argv, capture_output=True, text=True, timeout=120)
            except OSError as e:
                if attempt == 5:
                    raise SystemExit(f"hostile_inputs.py: cannot run {self.prt}: {e}")
                time.sleep(30)
                continue
            if r.returncode == 127 and "error while loading shared libraries" in r.stderr:
                time.sleep(30)
                continue
            break
        if r.returncode != 0:
            raise SystemExit(f"hostile_inputs.py: a base input is refused, so no case would mean anything:\n  "
                             f"{shlex.join(argv)}\n  exit {r.returncode}: {r.stderr.strip()[:600]}")
        return r


# ----------------------------------------------------------------------------
# Bad values, by the kind of property they replace: (label, value, expect).

# The JSON kinds a property can have (each kind of type confusion once), the
# integers that overflow 32, 64 bits and any integer type, and the numbers
# that are not finite (1e999 is valid JSON that overflows a double; NaN is
# not JSON at all).
NOT_NUMBERS = [("null", None), ("true", True), ("string", "1"), ("object", {}), ("array-of-one", [1])]
HUGE_INTS = [("2^32", 2 ** 32), ("2^63", 2 ** 63), ("2^64-1", 2 ** 64 - 1), ("2^64", 2 ** 64),
             ("1e400-digits", Raw("1" + "0" * 400))]
NON_FINITE = [("1e999", Raw("1e999")), ("NaN-token", Raw("NaN"))]


def bad_index(n):
    """An index into an array of n: everything but 0..n-1."""
    out = [(lbl, v, "invalid") for lbl, v in NOT_NUMBERS + HUGE_INTS + NON_FINITE]
    out += [("minus-1", -1, "invalid"), ("half", 0.5, "invalid"), ("n", n, "invalid"),
            ("minus-zero", Raw("-0"), "either")]
    return out


def bad_uint(current, fit_limit):
    """A whole number >= 0 whose values past fit_limit do not fit."""
    out = [(lbl, v, "invalid") for lbl, v in NOT_NUMBERS + NON_FINITE]
    out += [("minus-1", -1, "invalid"), ("half", current + 0.5, "invalid"), ("1e308", 1e308, "invalid")]
    out += [(lbl, v, "invalid") for lbl, v in HUGE_INTS if isinstance(v, Raw) or v < 0 or v > fit_limit]
    return out


def bad_number(lo=None, hi=None, lo_open=False):
    out = [(lbl, v, "invalid") for lbl, v in NOT_NUMBERS + NON_FINITE]
    if lo is not None:
        out.append(("below-range", lo - 1 if lo != 0 else -1e-9, "invalid"))
        if lo_open:
            out.append(("zero", 0, "invalid"))
    if hi is not None:
        out.append(("above-range", hi + 1, "invalid"))
    if lo is None and hi is None:
        out.append(("1e308", 1e308, "either"))
    return out


def bad_numbers(n, lo=None, hi=None, valid=None):
    """An array of n numbers in [lo, hi]."""
    ok = valid if valid is not None else [lo if lo is not None else 0.5] * n
    out = [(lbl, v, "invalid") for lbl, v in NOT_NUMBERS[:-2] + [("number", 1)]]
    out += [("empty", [], "invalid"), ("short", ok[:-1], "invalid"), ("long", ok + [ok[-1]], "invalid")]
    for lbl, v in NOT_NUMBERS[:5] + [("nested", [0])] + NON_FINITE:
        out.append(("element-" + lbl, [v] + ok[1:], "invalid"))
    if lo is not None:
        out.append(("element-below-range", [lo - 1] + ok[1:], "invalid"))
    if hi is not None:
        out.append(("element-above-range", ok[:-1] + [hi + 1], "invalid"))
    return out


def bad_enum_int(allowed, current):
    out = [(lbl, v, "invalid") for lbl, v in NOT_NUMBERS + NON_FINITE[:2]]
    out += [("minus-1", -1, "invalid"), ("zero", 0, "invalid" if 0 not in allowed else "either"),
            ("not-listed", max(allowed) + 1, "invalid"), ("half", current + 0.5, "invalid"),
            ("2^64", 2 ** 64, "invalid"), ("as-string", str(current), "invalid")]
    out += [(f"other-{a}", a, "either") for a in allowed if a != current][:3]
    return out


def bad_enum_str(allowed, current):
    out = [(lbl, v, "invalid") for lbl, v in NOT_NUMBERS if not isinstance(v, str)]
    out += [("empty", "", "invalid"), ("lower-case", current.lower() if current.lower() != current else current.upper(),
                                       "invalid"),
            ("padded", " " + current, "invalid"), ("unknown", "SOMETHING_ELSE", "invalid"),
            ("number", 1, "invalid"), ("long", "X" * 100000, "invalid")]
    out += [(f"other-{a}", a, "either") for a in allowed if a != current]
    return out


def bad_bool(current):
    out = [(lbl, v, "invalid") for lbl, v in NOT_NUMBERS if not isinstance(v, bool)]
    return out + [("zero", 0, "invalid"), ("one", 1, "invalid"), ("as-string", "true", "invalid"),
                  ("other", not current, "valid")]


def bad_string():
    out = [(lbl, v, "invalid") for lbl, v in NOT_NUMBERS if not isinstance(v, str)]
    return out + [("number", 7, "invalid"), ("empty", "", "valid"), ("long-100k", "n" * 100000, "valid"),
                  ("nul", "a\0b", "either"), ("lone-surrogate", Raw('"\\ud800"'), "either"),
                  ("unicode", "\u00e9\u4e2d\U0001F600", "valid")]


def bad_index_list(n, current):
    out = [(lbl, v, "invalid") for lbl, v in NOT_NUMBERS if not isinstance(v, list)]
    out += [("number", current[0], "invalid"), ("empty", [], "invalid"), ("duplicate", current + [current[0]], "invalid"),
            ("out-of-range", current + [n], "invalid"), ("minus-1", current + [-1], "invalid"),
            ("half", current + [0.5], "invalid"), ("string-element", current + ["1"], "invalid"),
            ("null-element", current + [None], "invalid"), ("huge-element", current + [2 ** 64 - 1], "invalid"),
            ("1e999-element", current + [Raw("1e999")], "invalid"), ("nested", [current], "invalid")]
    return out


def bad_object():
    out = [(lbl, v, "invalid") for lbl, v in NOT_NUMBERS if not isinstance(v, dict)]
    return out + [("number", 3, "invalid")]


# glTF properties: (path, kind, args). Every value `bad_*` gives for the kind
# replaces the property in a copy of the base scene (and "remove" drops it).
def gltf_schema(doc):
    S = [
        (("asset",), "object", {"remove": "invalid"}),
        (("asset", "version"), "version", {}),
        (("asset", "minVersion"), "minVersion", {}),
        (("asset", "generator"), "string", {}),
        (("asset", "copyright"), "string", {}),
        (("scene",), "index", {"target": "scenes", "remove": "either"}),
        (("scenes", 0, "nodes"), "index_list", {"target": "nodes", "remove": "either"}),
        (("scenes", 0, "name"), "string", {}),
        (("nodes", 0, "children"), "index_list", {"target": "nodes"}),
        (("nodes", 1, "mesh"), "index", {"target": "meshes", "remove": "either"}),
        (("nodes", 2, "mesh"), "index", {"target": "meshes"}),
        (("nodes", 3, "camera"), "index", {"target": "cameras", "remove": "valid"}),
        (("nodes", 2, "translation"), "numbers", {"n": 3, "valid": [0, 0.2, 0], "remove": "valid"}),
        (("nodes", 2, "rotation"), "quat", {}),
        (("nodes", 2, "scale"), "numbers", {"n": 3, "valid": [1, 1, 1], "remove": "valid"}),
        (("nodes", 3, "matrix"), "matrix", {}),
        (("nodes", 2, "weights"), "numbers", {"n": 1, "valid": [0], "remove": "valid"}),
        (("nodes", 1, "name"), "string", {}),
        (("nodes", 1, "skin"), "index", {"target": "skins"}),
        (("meshes", 0, "primitives"), "primitives", {}),
        (("meshes", 0, "weights"), "numbers", {"n": 1, "valid": [0]}),   # mesh 0 has no morph targets
        (("meshes", 1, "weights"), "numbers", {"n": 1, "valid": [0], "remove": "valid"}),
        (("meshes", 1, "primitives", 0, "targets"), "targets", {}),
        (("meshes", 1, "primitives", 0, "targets", 0, "POSITION"), "index", {"target": "accessors"}),
        (("meshes", 1, "primitives", 0, "targets", 0, "NORMAL"), "index", {"target": "accessors"}),
        (("materials", 0, "pbrMetallicRoughness"), "object", {"remove": "valid"}),
        (("materials", 0, "pbrMetallicRoughness", "baseColorFactor"), "numbers",
         {"n": 4, "lo": 0, "hi": 1, "valid": [1, 1, 1, 1], "remove": "valid"}),
        (("materials", 0, "pbrMetallicRoughness", "metallicFactor"), "number", {"lo": 0, "hi": 1}),
        (("materials", 0, "pbrMetallicRoughness", "roughnessFactor"), "number", {"lo": 0, "hi": 1}),
        (("materials", 0, "pbrMetallicRoughness", "baseColorTexture"), "object", {"remove": "valid"}),
        (("materials", 0, "pbrMetallicRoughness", "baseColorTexture", "index"), "index",
         {"target": "textures", "remove": "invalid"}),
        (("materials", 0, "pbrMetallicRoughness", "baseColorTexture", "texCoord"), "texCoord", {"remove": "valid"}),
        (("materials", 0, "pbrMetallicRoughness", "metallicRoughnessTexture", "index"), "index", {"target": "textures"}),
        (("materials", 0, "pbrMetallicRoughness", "metallicRoughnessTexture", "texCoord"), "texCoord", {"added": True}),
        (("materials", 0, "occlusionTexture", "index"), "index", {"target": "textures", "remove": "invalid"}),
        (("materials", 0, "occlusionTexture", "texCoord"), "texCoord", {"remove": "valid"}),
        (("materials", 0, "occlusionTexture", "strength"), "number", {"lo": 0, "hi": 1}),
        (("materials", 1, "normalTexture", "index"), "index", {"target": "textures", "remove": "invalid"}),
        (("materials", 1, "normalTexture", "texCoord"), "texCoord", {"added": True}),
        (("materials", 1, "normalTexture", "scale"), "number", {}),
        (("materials", 0, "emissiveTexture", "index"), "index", {"target": "textures"}),
        (("materials", 0, "emissiveFactor"), "numbers", {"n": 3, "lo": 0, "hi": 1, "valid": [0, 0, 0], "remove": "valid"}),
        (("materials", 0, "alphaMode"), "enum_str", {"allowed": ["OPAQUE", "MASK", "BLEND"], "remove": "valid"}),
        (("materials", 0, "alphaCutoff"), "number", {"lo": 0, "remove": "valid"}),
        (("materials", 0, "doubleSided"), "bool", {"remove": "valid"}),
        (("materials", 0, "name"), "string", {}),
        (("materials", 0, "extensions"), "object", {"remove": "valid"}),
        (("materials", 0, "extensions", "KHR_materials_emissive_strength", "emissiveStrength"), "number", {"lo": 0}),
        (("textures", 0, "sampler"), "index", {"target": "samplers", "remove": "valid"}),
        (("textures", 0, "source"), "index", {"target": "images", "remove": "either"}),
        (("samplers", 0, "magFilter"), "enum_int", {"allowed": [9728, 9729], "remove": "valid"}),
        (("samplers", 0, "minFilter"), "enum_int", {"allowed": [9728, 9729, 9984, 9985, 9986, 9987], "remove": "valid"}),
        (("samplers", 0, "wrapS"), "enum_int", {"allowed": [33071, 33648, 10497], "remove": "valid"}),
        (("samplers", 0, "wrapT"), "enum_int", {"allowed": [33071, 33648, 10497], "remove": "valid"}),
        (("images", 0, "mimeType"), "enum_str", {"allowed": ["image/jpeg", "image/png"], "remove": "valid"}),
        (("images", 0, "uri"), "string_type", {"remove": "invalid"}),
        (("images", 0, "bufferView"), "index", {"target": "bufferViews"}),   # both a uri and a view
        (("buffers", 0, "uri"), "string_type", {"remove": "invalid"}),
        (("buffers", 0, "byteLength"), "uint", {"limit": len(base_gltf()[1]) - 1, "remove": "invalid"}),
        (("cameras", 0, "type"), "enum_str", {"allowed": ["perspective", "orthographic"], "remove": "invalid"}),
        (("cameras", 0, "perspective"), "object", {"remove": "invalid"}),
        (("cameras", 0, "perspective", "yfov"), "number", {"lo": 0, "lo_open": True, "remove": "invalid"}),
        (("cameras", 0, "perspective", "znear"), "number", {"lo": 0, "lo_open": True, "remove": "invalid"}),
        (("cameras", 0, "perspective", "zfar"), "number", {"lo": 0, "lo_open": True, "remove": "valid"}),
        (("cameras", 0, "perspective", "aspectRatio"), "number", {"lo": 0, "lo_open": True, "remove": "valid"}),
        (("animations", 0, "samplers", 0, "input"), "index", {"target": "accessors", "remove": "invalid"}),
        (("animations", 0, "samplers", 0, "output"), "index", {"target": "accessors", "remove": "invalid"}),
        (("animations", 0, "samplers", 0, "interpolation"), "enum_str",
         {"allowed": ["LINEAR", "STEP", "CUBICSPLINE"], "remove": "valid"}),
        (("animations", 0, "channels", 0, "sampler"), "index", {"n": 1, "remove": "invalid"}),
        (("animations", 0, "channels", 0, "target"), "object", {"remove": "invalid"}),
        (("animations", 0, "channels", 0, "target", "node"), "index", {"target": "nodes", "remove": "valid"}),
        (("animations", 0, "channels", 0, "target", "path"), "enum_str",
         {"allowed": ["translation", "rotation", "scale", "weights"], "remove": "invalid"}),
        (("extensionsUsed",), "ext_used", {}),
        (("extensionsRequired",), "ext_required", {}),
        (("extensions",), "object", {"added": True}),
    ]
    buflen = len(base_gltf()[1])
    # Views: the first vertex view, the index view, the untargeted animation
    # view; accessors: a POSITION (with min/max), the two index accessors
    # (one at an offset), the animation input (attributes and morph targets
    # meet every accessor below, through the properties that name them).
    for v in (0, 4, 6):
        S += [(("bufferViews", v, "buffer"), "index", {"target": "buffers", "remove": "invalid"}),
              (("bufferViews", v, "byteOffset"), "uint", {"limit": buflen - doc["bufferViews"][v]["byteLength"],
                                                          "remove": "either"}),
              (("bufferViews", v, "byteLength"), "uint", {"limit": buflen - doc["bufferViews"][v]["byteOffset"],
                                                          "remove": "invalid"}),
              (("bufferViews", v, "byteStride"), "stride", {"view": v}),
              (("bufferViews", v, "target"), "enum_int", {"allowed": [34962, 34963], "remove": "valid"})]
    for a in (0, 4, 9, 11):
        acc = doc["accessors"][a]
        comps = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4}[acc["type"]]
        S += [(("accessors", a, "bufferView"), "index", {"target": "bufferViews", "remove": "either"}),
              (("accessors", a, "byteOffset"), "uint", {"limit": 63, "remove": "either"}),
              (("accessors", a, "componentType"), "componentType", {"current": acc["componentType"], "remove": "invalid"}),
              (("accessors", a, "count"), "count", {"current": acc["count"], "remove": "invalid"}),
              (("accessors", a, "type"), "acctype", {"current": acc["type"], "remove": "invalid"}),
              (("accessors", a, "normalized"), "bool", {"added": True, "float": acc["componentType"] == 5126}),
              (("accessors", a, "min"), "numbers", {"n": comps, "valid": acc.get("min", [0] * comps),
                                                    "remove": "either"}),
              (("accessors", a, "max"), "numbers", {"n": comps, "valid": acc.get("max", [0] * comps),
                                                    "remove": "either"}),
              (("accessors", a, "sparse"), "sparse", {"count": acc["count"]})]
    for m, mesh in enumerate(doc["meshes"]):
        prim = mesh["primitives"][0]
        for name in prim["attributes"]:
            # Removing NORMAL is valid (computed); TEXCOORD_1 of the floor is
            # what its material's occlusion texture reads (invalid), the
            # occluder's leaves the lightmap without its UV set (either).
            remove = {"NORMAL": "valid", "TEXCOORD_0": "either", "TEXCOORD_1": "invalid" if m == 0 else "either"}
            S.append((("meshes", m, "primitives", 0, "attributes", name), "attribute",
                      {"name": name, "remove": remove.get(name, "invalid")}))
        S += [(("meshes", m, "primitives", 0, "indices"), "attribute", {"name": "indices", "remove": "either"}),
              (("meshes", m, "primitives", 0, "material"), "index", {"target": "materials", "remove": "valid"}),
              (("meshes", m, "primitives", 0, "mode"), "enum_int", {"allowed": list(range(7)), "remove": "valid"}),
              (("meshes", m, "primitives", 0, "attributes"), "object", {"remove": "invalid"})]
    return S


ATTR_RULES = {  # attribute: (types, component types, normalized integers allowed)
    "POSITION": (["VEC3"], [5126], False), "NORMAL": (["VEC3"], [5126], False),
    "TEXCOORD_0": (["VEC2"], [5126], True), "TEXCOORD_1": (["VEC2"], [5126], True),
}


def values_for(doc, path, kind, args):
    """The (label, value, expect) replacements of the property at path."""
    n = {k: len(v) for k, v in doc.items() if isinstance(v, list)}
    cur = get_path(doc, path)
    if kind == "index":
        return bad_index(args.get("n", n.get(args.get("target"), 0)))
    if kind == "index_list":
        return bad_index_list(n[args["target"]], cur if cur is not MISSING else [0])
    if kind == "uint":
        return bad_uint(cur if isinstance(cur, int) else 0, args["limit"])
    if kind == "number":
        return bad_number(args.get("lo"), args.get("hi"), args.get("lo_open", False))
    if kind == "numbers":
        return bad_numbers(args["n"], args.get("lo"), args.get("hi"), args.get("valid"))
    if kind == "enum_int":
        return bad_enum_int(args["allowed"], cur if cur is not MISSING else args["allowed"][0])
    if kind == "enum_str":
        return bad_enum_str(args["allowed"], cur if cur is not MISSING else args["allowed"][0])
    if kind == "bool":
        out = bad_bool(bool(cur) if cur is not MISSING else False)
        if args.get("added"):  # accessors' normalized: true is wrong for floats, either for integers (meaning)
            out = [(l, v, e) for l, v, e in out if l != "other"] + [("true", True, "invalid" if args["float"] else "either"),
                                                                   ("false", False, "valid")]
        return out
    if kind == "string":
        return bad_string()
    if kind == "string_type":
        return [(l, v, e) for l, v, e in bad_string() if e == "invalid"]
    if kind == "object":
        return bad_object()
    if kind == "version":
        return [(l, v, "invalid") for l, v in NOT_NUMBERS if not isinstance(v, str)] + [
            ("number-2.0", 2.0, "invalid"), ("1.0", "1.0", "invalid"), ("3.0", "3.0", "invalid"), ("2", "2", "invalid"),
            ("2.0.1", "2.0.1", "invalid"), ("empty", "", "invalid"), ("2.x", "2.x", "invalid"),
            ("-2.0", "-2.0", "invalid"), ("2.0-padded", " 2.0", "invalid"), ("v2.0", "v2.0", "invalid"),
            ("2.1", "2.1", "valid"), ("2.99", "2.99", "valid"), ("02.0", "02.0", "either"),
            ("2.99999999999999999999", "2." + "9" * 20, "either"), ("99999999999999999999.0", "9" * 20 + ".0", "invalid")]
    if kind == "minVersion":
        return [(l, v, "invalid") for l, v in NOT_NUMBERS if not isinstance(v, str)] + [
            ("2.1", "2.1", "invalid"), ("3.0", "3.0", "invalid"), ("x", "x", "invalid"), ("empty", "", "invalid"),
            ("2", "2", "invalid"), ("1.0", "1.0", "either"), ("2.0.0", "2.0.0", "invalid")]
    if kind == "texCoord":
        return [(l, v, "invalid") for l, v in NOT_NUMBERS + NON_FINITE] + [
            ("minus-1", -1, "invalid"), ("minus-2", -2, "invalid"), ("half", 0.5, "invalid"),
            ("missing-set-2", 2, "invalid"), ("missing-set-7", 7, "invalid"), ("missing-set-64", 64, "invalid"),
            ("missing-set-65", 65, "invalid"), ("2^32", 2 ** 32, "invalid"), ("2^64-1", 2 ** 64 - 1, "invalid"),
            ("set-1", 1, "valid"), ("set-0", 0, "valid")]
    if kind == "quat":
        return bad_numbers(4, -1, 1, [0, 0, 0, 1]) + [
            ("zero-quaternion", [0, 0, 0, 0], "invalid"), ("not-unit", [0, 0, 0, 0.5], "invalid"),
            ("not-unit-2", [0.9, 0.9, 0, 0], "invalid"), ("unit-x", [1, 0, 0, 0], "valid"),
            ("unit-float32", [0, 0.70710677, 0, 0.70710677], "valid"), ("negated", [0, 0, 0, -1], "valid")]
    if kind == "matrix":
        ident = [1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1]
        return bad_numbers(16, None, None, ident) + [
            ("zero-matrix", [0] * 16, "either"), ("mirror", [-1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1], "valid"),
            ("projective", ident[:15] + [2], "either"), ("huge-translation", ident[:12] + [1e300, 0, 0, 1], "either")]
    if kind == "attribute":
        return attribute_values(doc, path, args["name"])
    if kind == "primitives":
        prim = doc["meshes"][0]["primitives"][0]
        return [(l, v, "invalid") for l, v in NOT_NUMBERS if not isinstance(v, list)] + [
            ("empty", [], "invalid"), ("element-null", [None], "invalid"), ("element-number", [1], "invalid"),
            ("element-empty-object", [{}], "invalid"), ("no-position", [dict(prim, attributes={"NORMAL": 1})], "invalid"),
            ("twice", [prim, prim], "either"), ("attributes-array", [dict(prim, attributes=[0])], "invalid")]
    if kind == "targets":
        return [(l, v, "invalid") for l, v in NOT_NUMBERS if not isinstance(v, list)] + [
            ("empty", [], "invalid"), ("element-null", [None], "invalid"), ("element-empty", [{}], "invalid"),
            ("element-array", [[10]], "invalid"), ("two-targets", [{"POSITION": 10}, {"POSITION": 10}], "invalid"),
            ("target-uv-accessor", [{"POSITION": 7}], "invalid"), ("target-count-mismatch", [{"POSITION": 11}], "invalid"),
            ("unknown-attribute", [{"FOO": 10}], "either")]
    if kind == "stride":
        v = args["view"]
        uses = [a for a in doc["accessors"] if a.get("bufferView") == v]
        elem = max({"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4}[a["type"]] * (4 if a["componentType"] in (5125, 5126)
                                                                                else 2) for a in uses)
        out = [(l, v2, "invalid") for l, v2 in NOT_NUMBERS + NON_FINITE] + [
            ("zero", 0, "invalid"), ("1", 1, "invalid"), ("3", 3, "invalid"), ("minus-4", -4, "invalid"),
            ("256", 256, "invalid"), ("2^32", 2 ** 32, "invalid"), ("not-multiple-of-4", elem + 1, "invalid"),
            ("below-element", 4 if elem > 4 else 2, "invalid"), ("252", 252, "invalid")]
        if doc["bufferViews"][v].get("target") == 34963:
            out.append(("tight-on-indices", 4, "invalid"))
        elif elem % 4 == 0 and elem >= 4 and v != 6:
            out.append(("tight", elem, "valid"))
        return out
    if kind == "componentType":
        c = args["current"]
        out = [(l, v, "invalid") for l, v in NOT_NUMBERS + NON_FINITE] + [
            ("signed-int-5124", 5124, "invalid"), ("double-5130", 5130, "invalid"), ("zero", 0, "invalid"),
            ("minus-1", -1, "invalid"), ("2^64", 2 ** 64, "invalid")]
        out += [(f"other-{t}", t, "invalid" if c == 5126 else "either") for t in (5120, 5121, 5122, 5123, 5125, 5126)
                if t != c]
        return out
    if kind == "count":
        c = args["current"]
        return bad_uint(c, 2 ** 32) + [("zero", 0, "invalid"), ("plus-1", c + 1, "invalid"),
                                       ("minus-1", c - 1, "invalid" if c > 1 else "invalid"),
                                       ("2^32-1", 2 ** 32 - 1, "invalid"), ("2^31", 2 ** 31, "invalid")]
    if kind == "acctype":
        c = args["current"]
        return [(l, v, "invalid") for l, v in NOT_NUMBERS if not isinstance(v, str)] + [
            ("lower-case", c.lower(), "invalid"), ("unknown", "VEC5", "invalid"), ("empty", "", "invalid"),
            ("number", 3, "invalid")] + [(f"other-{t}", t, "invalid") for t in
                                         ("SCALAR", "VEC2", "VEC3", "VEC4", "MAT2", "MAT3", "MAT4") if t != c]
    if kind == "sparse":
        c = args["count"]
        good_idx = {"bufferView": 4, "componentType": 5123}
        return [(l, v, "invalid") for l, v in NOT_NUMBERS if not isinstance(v, dict)] + [
            ("empty", {}, "invalid"),
            ("count-zero", {"count": 0, "indices": good_idx, "values": {"bufferView": 0}}, "invalid"),
            ("count-above", {"count": c + 1, "indices": good_idx, "values": {"bufferView": 0}}, "invalid"),
            ("no-indices", {"count": 1, "values": {"bufferView": 0}}, "invalid"),
            ("no-values", {"count": 1, "indices": good_idx}, "invalid"),
            ("indices-float", {"count": 1, "indices": {"bufferView": 4, "componentType": 5126},
                               "values": {"bufferView": 0}}, "invalid"),
            ("indices-view-out-of-range", {"count": 1, "indices": {"bufferView": 99, "componentType": 5123},
                                           "values": {"bufferView": 0}}, "invalid"),
            ("values-past-view", {"count": 1, "indices": good_idx, "values": {"bufferView": 4, "byteOffset": 2 ** 40}},
             "invalid"),
            ("huge-count", {"count": 2 ** 32 - 1, "indices": good_idx, "values": {"bufferView": 0}}, "invalid")]
    if kind == "ext_used":
        return [(l, v, "invalid") for l, v in NOT_NUMBERS if not isinstance(v, list)] + [
            ("string", "KHR_materials_emissive_strength", "invalid"), ("empty", [], "invalid"),
            ("element-number", [1], "invalid"), ("element-null", [None], "invalid"),
            ("duplicate", ["KHR_materials_emissive_strength"] * 2, "invalid"),
            ("unknown-extra", ["KHR_materials_emissive_strength", "EXT_made_up"], "valid"),
            ("nested", [["KHR_materials_emissive_strength"]], "invalid")]
    if kind == "ext_required":
        used = doc.get("extensionsUsed", [])
        return [(l, v, "invalid") for l, v in NOT_NUMBERS if not isinstance(v, list)] + [
            ("string", used[0], "invalid"), ("element-number", [1], "invalid"), ("element-null", [None], "invalid"),
            ("not-in-used", ["KHR_texture_transform"], "invalid"), ("duplicate", [used[0], used[0]], "invalid"),
            ("harmless", [used[0]], "valid"), ("nested", [[used[0]]], "invalid")]
    raise ValueError(kind)


def attribute_values(doc, path, name):
    """An attribute (or indices) pointing at every accessor, and at none."""
    out = bad_index(len(doc["accessors"]))
    prim = get_path(doc, path[:-2]) if name != "indices" else get_path(doc, path[:-1])
    count = doc["accessors"][prim["attributes"]["POSITION"]]["count"]
    cur = get_path(doc, path)
    for a, acc in enumerate(doc["accessors"]):
        if a == cur:
            continue
        if name == "indices":
            ok = acc["type"] == "SCALAR" and acc["componentType"] in (5121, 5123, 5125) and acc["count"] % 3 == 0
            expect = "either" if ok else "invalid"
        elif name in ATTR_RULES:
            types, comps, _ = ATTR_RULES[name]
            ok = acc["type"] in types and acc["componentType"] in comps and acc["count"] == count
            expect = "either" if ok else "invalid"
            if ok and name == "POSITION" and "min" not in acc:
                expect = "either"
        else:
            expect = "either"
        out.append((f"accessor-{a}", a, expect))
    return out


class GltfCases:
    """Cases of class gltf-invalid: every property of the base scene x every
    bad value of its kind, on two surfaces: the scene reader (precompute
    --lightmap) and the mesh reader (precompute, per vertex)."""

    def __init__(self, base):
        self.base = base

    def surfaces(self, d, scene):
        return {
            "lightmap": ["precompute", scene, "--lightmap", "8x8", "--samples", "4", "--bands", "1", "-q", "-o",
                         d / "out.prt"],
            "mesh": ["precompute", scene, "--samples", "4", "--bands", "1", "-q", "-o", d / "out.prt"],
        }

    def doc_case(self, cls, name, mutate, expect, surface, note="", raw=None, glb=False):
        base = self.base

        def make(d):
            doc = copy.deepcopy(base.doc)
            data = None
            if mutate is not None:
                r = mutate(doc, d)
                if isinstance(r, (bytes, bytearray)):
                    data = bytes(r)
            if glb:
                scene = base.write_scene(d, name="scene.glb",
                                         raw=data if data is not None else glb_bytes(doc, base.bin))
            else:
                scene = base.write_scene(d, doc, raw=data)
            return self.surfaces(d, scene)[surface]
        return Case(cls, f"{name} [{surface}]", make, expect, tokens=("scene.gltf", "scene.glb", "scene.bin", "tex.png"),
                    note=note)

    def cases(self):
        doc = self.base.doc
        out = []
        for path, kind, args in gltf_schema(doc):
            vals = values_for(doc, path, kind, args)
            if args.get("remove") and get_path(doc, path) is not MISSING:
                vals = vals + [("removed", MISSING, args["remove"])]
            for i, (label, value, expect) in enumerate(vals):
                def mutate(d_, _doc, path=path, value=value):
                    if value is MISSING:
                        del_path(d_, path)
                    else:
                        if path[-1] == "texCoord" and get_path(d_, path[:-1]) is MISSING:
                            set_path(d_, path[:-1], {"index": 0})  # a textureInfo needs its texture
                        set_path(d_, path, copy.deepcopy(value))
                # Both readers check the same structure first: each value
                # goes to one of them, in turn (each property meets both).
                surface = ("lightmap", "mesh")[i % 2]
                out.append(self.doc_case("gltf-invalid", f"{path_text(path)} = {label}", mutate, expect, surface))
        out += self.structure_cases()
        return out

    def structure_cases(self):
        """Node graphs, texture transforms, JSON syntax and the GLB container."""
        specs = []

        def add(name, fn, expect, note=""):
            specs.append((name, fn, expect, note))

        def nodes(fn):
            return lambda d, _: fn(d["nodes"], d)
        add("node 1 has two parents (root and node 2)", nodes(lambda n, d: n[2].__setitem__("children", [1])), "invalid")
        add("node 1 is a scene root and a child", lambda d, _: d["scenes"][0].__setitem__("nodes", [0, 1, 3]), "invalid")
        add("node 0 is its own child", nodes(lambda n, d: n[0].__setitem__("children", [0, 1, 2])), "invalid")
        add("cycle 0 -> 2 -> 0", nodes(lambda n, d: n[2].__setitem__("children", [0])), "invalid")
        add("cycle 1 -> 2 -> 1 off the scene", nodes(lambda n, d: (n[0].__setitem__("children", [1]),
                                                                   n[1].__setitem__("children", [2]),
                                                                   n[2].__setitem__("children", [1]))), "invalid")
        add("scene lists node 0 twice", lambda d, _: d["scenes"][0].__setitem__("nodes", [0, 0, 3]), "invalid")
        add("scenes empty array", lambda d, _: d.__setitem__("scenes", []), "invalid")
        add("scenes not an array", lambda d, _: d.__setitem__("scenes", {"nodes": [0]}), "invalid")
        add("scene without nodes", lambda d, _: d["scenes"][0].pop("nodes"), "either")
        add("nodes empty array", lambda d, _: d.__setitem__("nodes", []), "invalid")
        add("node is not an object", nodes(lambda n, d: n.__setitem__(3, 5)), "invalid")
        add("matrix and TRS both", nodes(lambda n, d: n[3].__setitem__("translation", [0, 0, 0])), "invalid")
        add("skin without skins", nodes(lambda n, d: n[2].__setitem__("skin", 0)), "invalid")
        add("camera index on a mesh node, no cameras", lambda d, _: (d.pop("cameras"), d["nodes"].pop()), "invalid")
        add("second scene, default 1", lambda d, _: (d["scenes"].append({"nodes": [3]}), d.__setitem__("scene", 1)), "either")
        add("second scene, default 0", lambda d, _: d["scenes"].append({"nodes": [3]}), "valid")
        for where in ("baseColorTexture", "occlusionTexture"):
            tt = {"offset": [0.5, 0], "scale": [2, 2], "rotation": 0.3}
            for variant, ext, expect in (
                    ("offset/scale/rotation", tt, "invalid" if where == "baseColorTexture" else "either"),
                    ("texCoord override to set 2", {"texCoord": 2}, "invalid"),
                    ("offset not numbers", {"offset": ["a", 0]}, "invalid"),
                    ("scale length 3", {"scale": [1, 1, 1]}, "invalid"),
                    ("rotation string", {"rotation": "x"}, "invalid"),
                    ("not an object", [1], "invalid")):
                parent = ("materials", 0, "pbrMetallicRoughness", where) if where == "baseColorTexture" else \
                    ("materials", 0, where)

                def fn(d, _, parent=parent, ext=ext):
                    d["extensionsUsed"] = d.get("extensionsUsed", []) + ["KHR_texture_transform"]
                    set_path(d, parent + ("extensions",), {"KHR_texture_transform": copy.deepcopy(ext)})
                add(f"KHR_texture_transform on {where}: {variant}", fn, expect)
        add("extensionsRequired names an unknown extension",
            lambda d, _: (d["extensionsUsed"].append("EXT_unknown_thing"),
                          d.__setitem__("extensionsRequired", ["EXT_unknown_thing"])), "invalid")
        add("extensionsRequired KHR_draco, no fallback",
            lambda d, _: (d["extensionsUsed"].append("KHR_draco_mesh_compression"),
                          d.__setitem__("extensionsRequired", ["KHR_draco_mesh_compression"])), "invalid")
        add("Draco primitive without buffer views",
            lambda d, _: (d["extensionsUsed"].append("KHR_draco_mesh_compression"),
                          d["meshes"][0]["primitives"][0].__setitem__(
                              "extensions", {"KHR_draco_mesh_compression": {"bufferView": 0, "attributes": {"POSITION": 0}}}),
                          [d["accessors"][i].pop("bufferView") or d["accessors"][i].pop("byteOffset") for i in (0, 1, 2, 3)]),
            "invalid")
        add("TEXCOORD_3 without TEXCOORD_2",
            lambda d, _: d["meshes"][0]["primitives"][0]["attributes"].__setitem__("TEXCOORD_3", 2), "invalid")
        add("COLOR_0 as SCALAR", lambda d, _: d["meshes"][0]["primitives"][0]["attributes"].__setitem__("COLOR_0", 4),
            "invalid")
        add("TEXCOORD_x (not a number)",
            lambda d, _: d["meshes"][0]["primitives"][0]["attributes"].__setitem__("TEXCOORD_x", 2), "either")
        add("index buffer value past the vertex count",
            lambda d, _: d["meshes"][0]["primitives"][0].__setitem__("indices", 9) or d["accessors"][9].__setitem__(
                "byteOffset", 0) or None, "either")
        # JSON syntax and top level.
        raw = dump_json(self.base.doc).encode()
        for name, data, expect in (
                ("empty file", b"", "invalid"), ("null", b"null", "invalid"), ("array", b"[]", "invalid"),
                ("number", b"2", "invalid"), ("truncated half", raw[: len(raw) // 2], "invalid"),
                ("truncated last byte", raw[:-1], "invalid"), ("trailing garbage", raw + b"xyz", "invalid"),
                ("BOM", b"\xef\xbb\xbf" + raw, "either"), ("comment", b"// c\n" + raw, "invalid"),
                ("NUL inside", raw[:10] + b"\0" + raw[10:], "invalid"), ("invalid UTF-8 in a name",
                                                                          raw.replace(b'"root"', b'"r\xff\xfet"'), "invalid"),
                ("UTF-16", raw.decode().encode("utf-16"), "invalid"),
                ("nested 100 deep in extras", raw[:-1] + b',"extras":' + b"[" * 100 + b"]" * 100 + b"}", "either"),
                ("duplicate key asset", b'{"asset":{"version":"1.0"},' + raw[1:], "either"),
                ("no asset", dump_json({k: v for k, v in self.base.doc.items() if k != "asset"}).encode(), "invalid")):
            add(f"JSON: {name}", (lambda data: lambda d, _: data)(data), expect)
        out = []
        for name, fn, expect, note in specs:
            for surface in ("lightmap", "mesh"):
                e = expect
                if surface == "mesh" and name.startswith("KHR_texture_transform on baseColorTexture: offset"):
                    e = "either"  # the mesh reader never samples the texture
                out.append(self.doc_case("gltf-invalid", name, fn, e, surface, note))
        out += self.glb_cases()
        return out

    def glb_cases(self):
        good = glb_bytes(self.base.doc, self.base.bin)
        jlen = struct.unpack_from("<I", good, 12)[0]
        bin_at = 20 + jlen
        blen = struct.unpack_from("<I", good, bin_at)[0]
        specs = []
        for lbl, v in (("magic", b"gltf"), ("magic-zero", b"\0\0\0\0")):
            specs.append((f"GLB header {lbl}", good[:0] + v + good[4:], "invalid"))
        for lbl, v in (("1", 1), ("0", 0), ("3", 3), ("2^32-1", 2 ** 32 - 1)):
            specs.append((f"GLB version {lbl}", good[:4] + struct.pack("<I", v) + good[8:], "invalid"))
        for lbl, v in (("0", 0), ("12", 12), ("size-1", len(good) - 1), ("size+1", len(good) + 1),
                       ("2^32-1", 2 ** 32 - 1)):
            specs.append((f"GLB length {lbl}", good[:8] + struct.pack("<I", v) + good[12:], "invalid"))
        for lbl, v in (("0", 0), ("+1", jlen + 1), ("-4", jlen - 4), ("2^32-1", 2 ** 32 - 1), ("2^31", 2 ** 31)):
            specs.append((f"GLB JSON chunk length {lbl}", good[:12] + struct.pack("<I", v) + good[16:], "invalid"))
        specs.append(("GLB JSON chunk type BIN", good[:16] + b"BIN\0" + good[20:], "invalid"))
        for lbl, v in (("0", 0), ("+4", blen + 4), ("2^32-1", 2 ** 32 - 1), ("-4", blen - 4)):
            specs.append((f"GLB BIN chunk length {lbl}", good[:bin_at] + struct.pack("<I", v) + good[bin_at + 4:],
                          "invalid" if lbl != "-4" else "invalid"))
        specs.append(("GLB BIN chunk type XYZ", good[:bin_at + 4] + b"XYZ\0" + good[bin_at + 8:], "invalid"))
        for cut in (0, 4, 11, 12, 19, 20, 21, bin_at - 1, bin_at, bin_at + 4, bin_at + 8, len(good) - 1):
            specs.append((f"GLB truncated at {cut}", good[:cut], "invalid"))
        specs.append(("GLB with a trailing chunk", good[:8] + struct.pack("<I", len(good) + 12) + good[12:] +
                      struct.pack("<I4s", 4, b"XTRA") + b"\0" * 4, "either"))
        out = []
        for name, data, expect in specs:
            for surface in ("lightmap", "mesh"):
                out.append(self.doc_case("gltf-invalid", name, (lambda data: lambda d, _: data)(data), expect, surface,
                                         glb=True))
        return out


def gltf_cost_cases(base, py):
    """Class gltf-cost: small files that ask for much (deep and wide node
    graphs, deep JSON, images that are not files, PNG bombs). Any outcome
    but crash or hang will do, within COST_RSS_MB whatever the outcome."""
    g = GltfCases(base)
    out = []

    def add(name, mutate, expect, surfaces=("lightmap", "mesh"), rss=COST_RSS_MB, timeout=None):
        for surface in surfaces:
            c = g.doc_case("gltf-cost", name, mutate, expect, surface)
            c.rss_mb, c.timeout = rss, timeout
            out.append(c)

    def chain(n, cycle=False):
        def m(d, _):
            nodes = [{"children": [i + 1]} for i in range(n - 1)] + [{"mesh": 0}]
            if cycle:
                nodes[-1]["children"] = [1]
            d["nodes"] = nodes + [{"mesh": 1}]
            d["scenes"] = [{"nodes": [0, n]}]
            d.pop("animations")
            d.pop("cameras")
        return m
    for n in (1000, 10 ** 4, 10 ** 5, 10 ** 6):
        add(f"chain of {n} nested nodes", chain(n), "either")
    add("cycle of 100000 nodes below a root", chain(10 ** 5, cycle=True), "invalid")

    def wide(n, mesh):
        def m(d, _):
            d["nodes"] = [{"mesh": mesh, "translation": [0, 0.001 * i, 0]} for i in range(n)]
            d["scenes"] = [{"nodes": list(range(n))}]
            d.pop("animations")
            d.pop("cameras")
        return m
    for n in (10 ** 4, 10 ** 5):
        add(f"{n} sibling nodes sharing the floor mesh", wide(n, 0), "either")

    def binary_tree(levels):
        def m(d, _):
            n = 2 ** levels - 1
            d["nodes"] = [{"children": [2 * i + 1, 2 * i + 2]} if 2 * i + 2 < n else {"mesh": 1, "scale": [0.01] * 3}
                          for i in range(n)]
            d["scenes"] = [{"nodes": [0]}]
            d.pop("animations")
            d.pop("cameras")
        return m
    add("balanced binary node tree, 2^16 - 1 nodes", binary_tree(16), "either")

    def deep_json(n):
        return lambda d, _: dump_json(d)[:-1].encode() + b',"extras":' + b"[" * n + b"]" * n + b"}"
    for n in (10 ** 4, 10 ** 6):
        add(f"JSON nested {n} deep in extras", deep_json(n), "either")
    add("a node name of 10 MB", lambda d, _: d["nodes"][1].__setitem__("name", "n" * 10 ** 7), "either")

    def many_prims(n):
        def m(d, _):
            prim = d["meshes"][1]["primitives"][0]
            d["meshes"][1]["primitives"] = [copy.deepcopy(prim) for _ in range(n)]
        return m
    add("a mesh of 100000 primitives", many_prims(10 ** 5), "either")

    # Files that are not regular files, as image and as buffer.
    for target in ("image", "buffer"):
        for kind in ("directory", "fifo", "dev-zero-link", "dev-urandom-link", "link-loop", "dir-link", "missing"):
            for surface in ("lightmap", "mesh"):
                def mutate(doc, d, kind=kind, target=target):
                    name = f"{target}-{kind}"
                    p = d / name
                    if kind == "directory":
                        p.mkdir()
                    elif kind == "fifo":
                        os.mkfifo(p)
                    elif kind == "dev-zero-link":
                        p.symlink_to("/dev/zero")
                    elif kind == "dev-urandom-link":
                        p.symlink_to("/dev/urandom")
                    elif kind == "link-loop":
                        p.symlink_to(name)
                    elif kind == "dir-link":
                        p.symlink_to(".")
                    if target == "image":
                        doc["images"][0]["uri"] = name
                    else:
                        doc["buffers"][0]["uri"] = name
                # A missing image: the mesh reader never needs it (either); the scene reader does.
                expect = "either" if (kind == "missing" and target == "image" and surface == "mesh") else "invalid"
                c = g.doc_case("gltf-cost", f"{target} uri names a {kind}", mutate, expect, surface)
                c.rss_mb = COST_RSS_MB
                c.tokens = c.tokens + (f"{target}-{kind}",)
                out.append(c)
    for uri in ("/dev/zero", "file:///dev/zero", "http://example.invalid/x.bin", "../../../../../../dev/zero"):
        for target in ("image", "buffer"):
            def mutate(doc, d, uri=uri, target=target):
                doc["images" if target == "image" else "buffers"][0]["uri"] = uri
            c = g.doc_case("gltf-cost", f"{target} uri {uri}", mutate,
                           "either" if uri.startswith("../") else "invalid", "lightmap")
            c.rss_mb = COST_RSS_MB
            out.append(c)

    # PNG bombs: tiny files, huge pictures (the texture the floor samples).
    bombs = [
        ("16384x16384 1-bit grey", dict(width=16384, height=16384, bit_depth=1, color_type=0), "either"),
        ("16384x16384 RGBA 8-bit", dict(width=16384, height=16384, bit_depth=8, color_type=6), "either"),
        ("32768x32768 1-bit grey", dict(width=32768, height=32768, bit_depth=1, color_type=0), "either"),
        ("65535x65535 1-bit grey", dict(width=65535, height=65535, bit_depth=1, color_type=0), "either"),
        ("16777216x1 1-bit grey", dict(width=16777216, height=1, bit_depth=1, color_type=0), "either"),
        ("1x16777216 1-bit grey", dict(width=1, height=16777216, bit_depth=1, color_type=0), "either"),
        ("header 2^31-1 square, no data", dict(width=1, height=1, ihdr=struct.pack(">IIBBBBB", 2 ** 31 - 1, 2 ** 31 - 1,
                                                                                  8, 6, 0, 0, 0), idat=b""), "invalid"),
        ("header 0x0", dict(width=1, height=1, ihdr=struct.pack(">IIBBBBB", 0, 0, 8, 2, 0, 0, 0)), "invalid"),
        ("header 16384 square, 1 row of data", dict(width=16384, height=1, bit_depth=8, color_type=6,
                                                     ihdr=struct.pack(">IIBBBBB", 16384, 16384, 8, 6, 0, 0, 0)),
         "invalid"),
        ("16-bit RGBA 8192x8192", dict(width=8192, height=8192, bit_depth=16, color_type=6), "either"),
    ]
    for name, kw, expect in bombs:
        for surface in ("lightmap", "mesh"):
            def mutate(doc, d, kw=kw, name=name):
                cache = base.dir / ("bomb-" + "".join(ch if ch.isalnum() else "-" for ch in name) + ".png")
                with BOMB_LOCK:
                    if not cache.exists():
                        tmp = cache.with_suffix(".tmp%d" % threading.get_ident())
                        tmp.write_bytes(png_bytes(**kw))
                        os.replace(tmp, cache)
                os.link(cache, d / "bomb.png")
                doc["images"][0]["uri"] = "bomb.png"
            c = g.doc_case("gltf-cost", f"PNG bomb {name}", mutate, "either" if surface == "mesh" else expect, surface)
            c.rss_mb = COST_RSS_MB
            c.tokens = c.tokens + ("bomb.png", "image 0")
            out.append(c)

    def data_uri_bomb(doc, d):
        png = png_bytes(16384, 16384, bit_depth=1, color_type=0)
        doc["images"][0]["uri"] = "data:image/png;base64," + base64.b64encode(png).decode()
    c = g.doc_case("gltf-cost", "PNG bomb 16384x16384 1-bit as a data URI", data_uri_bomb, "either", "lightmap")
    c.rss_mb = COST_RSS_MB
    out.append(c)
    return out


BOMB_LOCK = threading.Lock()
GENERATORS["gltf-cost"] = gltf_cost_cases


def gltf_valid_cases(base, py):
    """Class gltf-valid: files the specification allows, which prt must read."""
    g = GltfCases(base)
    out = []

    def add(name, mutate, expect="valid", surfaces=("lightmap", "mesh")):
        for surface in surfaces:
            out.append(g.doc_case("gltf-valid", name, mutate, expect, surface))

    def rename_buffer(file_name, uri):
        def m(doc, d):
            shutil.copyfile(base.path("scene.bin"), d / file_name)
            doc["buffers"][0]["uri"] = uri
        return m

    def rename_image(file_name, uri):
        def m(doc, d):
            shutil.copyfile(base.path("tex.png"), d / file_name)
            doc["images"][0]["uri"] = uri
        return m
    for file_name, uri, expect in (("buffer data.bin", "buffer%20data.bin", "valid"),
                                   ("buffer data.bin", "buffer%20data%2Ebin", "valid"),
                                   ("b\u00fcffer.bin", "b%C3%BCffer.bin", "valid"),
                                   ("b\u00fcffer.bin", "b%c3%bcffer.bin", "valid"),
                                   ("100%.bin", "100%25.bin", "valid"),
                                   ("a#b.bin", "a%23b.bin", "valid"),
                                   ("scene.bin", "./scene.bin", "valid"),
                                   ("b\u00fcffer.bin", "b\u00fcffer.bin", "either"),
                                   ("buffer data.bin", "buffer data.bin", "either")):
        add(f"buffer uri {uri!r} for file {file_name!r}", rename_buffer(file_name, uri), expect)
        img_file, img_uri = file_name[:-3] + "png", uri[:-3] + "png"
        add(f"image uri {img_uri!r} for file {img_file!r}", rename_image(img_file, img_uri), expect)

    def in_subdir(doc, d):
        (d / "sub dir").mkdir()
        shutil.copyfile(base.path("scene.bin"), d / "sub dir" / "scene.bin")
        shutil.copyfile(base.path("tex.png"), d / "sub dir" / "tex.png")
        doc["buffers"][0]["uri"] = "sub%20dir/scene.bin"
        doc["images"][0]["uri"] = "sub%20dir/tex.png"
    add("buffer and image in a sub%20dir", in_subdir)

    def data_uris(doc, d):
        doc["buffers"][0]["uri"] = "data:application/octet-stream;base64," + base64.b64encode(base.bin).decode()
        doc["images"][0]["uri"] = "data:image/png;base64," + base64.b64encode(base.png).decode()
    add("buffer and image as base64 data URIs", data_uris)
    add("buffer as data:application/gltf-buffer", lambda doc, d: doc["buffers"][0].__setitem__(
        "uri", "data:application/gltf-buffer;base64," + base64.b64encode(base.bin).decode()))
    add("GLB", None, surfaces=("lightmap",))
    out[-1].make = (lambda make: make)(g.doc_case("gltf-valid", "GLB", None, "valid", "lightmap", glb=True).make)

    def glb_image_view(doc, d):
        buf = base.bin + base.png + b"\0" * (-len(base.png) % 4)
        doc["buffers"][0]["byteLength"] = len(buf)
        doc["bufferViews"].append({"buffer": 0, "byteOffset": len(base.bin), "byteLength": len(base.png)})
        doc["images"][0] = {"bufferView": len(doc["bufferViews"]) - 1, "mimeType": "image/png"}
        return glb_bytes(doc, buf)
    for surface in ("lightmap", "mesh"):
        out.append(g.doc_case("gltf-valid", "GLB with the image in a buffer view", glb_image_view, "valid", surface,
                              glb=True))

    def everywhere(doc, key, value):
        """key: value on every glTF object (not on maps of names: attributes,
        morph targets, the extensions map itself)."""
        def walk(v, parent):
            if isinstance(v, dict):
                for k, x in list(v.items()):
                    walk(x, k)
                if parent not in ("attributes", "targets", "extensions"):
                    v[key] = copy.deepcopy(value)
            elif isinstance(v, list):
                for x in v:
                    walk(x, parent)
        for k, v in doc.items():
            walk(v, k)
        doc[key] = copy.deepcopy(value)
    add("extras object on every object", lambda doc, d: everywhere(doc, "extras", {"a": [1, {"b": None}], "c": "x"}))
    add("extras number on every object", lambda doc, d: everywhere(doc, "extras", 3))
    add("unknown property on every object", lambda doc, d: everywhere(doc, "vendorThing", [1, 2]), "either")
    add("empty extensions object on the root", lambda doc, d: doc.__setitem__("extensions", {}))
    add("unused extension listed in extensionsUsed",
        lambda doc, d: doc["extensionsUsed"].append("EXT_something_unknown"))
    add("KHR_materials_emissive_strength required", lambda doc, d: doc.__setitem__(
        "extensionsRequired", ["KHR_materials_emissive_strength"]))
    add("asset.version 2.1, no minVersion", lambda doc, d: (doc["asset"].pop("minVersion"),
                                                            doc["asset"].__setitem__("version", "2.1")))

    def retype_indices(ct):
        def m(doc, d):
            vals = IDX_FLOOR + IDX_OCC
            fmt = {5121: "B", 5123: "H", 5125: "I"}[ct]
            blob = struct.pack("<%d%s" % (len(vals), fmt), *vals)
            blob += b"\0" * (-len(blob) % 4)
            (d / "idx.bin").write_bytes(blob)
            doc["buffers"].append({"uri": "idx.bin", "byteLength": len(blob)})
            doc["bufferViews"][4] = {"buffer": 1, "byteOffset": 0, "byteLength": len(blob), "target": 34963}
            doc["accessors"][4].update(componentType=ct, byteOffset=0)
            doc["accessors"][9].update(componentType=ct, byteOffset=6 * struct.calcsize(fmt))
        return m
    add("unsigned byte indices", retype_indices(5121))
    add("unsigned int indices", retype_indices(5125))

    def normalized_uv(ct):
        def m(doc, d):
            scale = 255 if ct == 5121 else 65535
            fmt = "2B2x" if ct == 5121 else "2H"  # bytes: 4-byte aligned elements (byteStride 4)
            blob = b"".join(struct.pack("<" + fmt, *(round(c * scale) for c in uv)) for uv in UV0 + UV0)
            blob += b"\0" * (-len(blob) % 4)
            (d / "uv.bin").write_bytes(blob)
            doc["buffers"].append({"uri": "uv.bin", "byteLength": len(blob)})
            doc["bufferViews"].append({"buffer": 1, "byteLength": len(blob), "byteStride": 4, "target": 34962}
                                      if ct == 5121 else {"buffer": 1, "byteLength": len(blob), "target": 34962})
            v = len(doc["bufferViews"]) - 1
            step = struct.calcsize(fmt)
            doc["accessors"][2] = {"bufferView": v, "componentType": ct, "normalized": True, "count": 4, "type": "VEC2"}
            doc["accessors"][7] = {"bufferView": v, "byteOffset": 4 * step, "componentType": ct, "normalized": True,
                                   "count": 4, "type": "VEC2"}
        return m
    add("normalized unsigned byte TEXCOORD_0 (stride 4)", normalized_uv(5121))
    add("normalized unsigned short TEXCOORD_0", normalized_uv(5123))

    def interleaved(doc, d):
        blob = b"".join(struct.pack("<3f3f", *p, *n) for p, n in zip(FLOOR + OCC, [(0, 1, 0)] * 4 + [(0, -1, 0)] * 4))
        (d / "inter.bin").write_bytes(blob)
        doc["buffers"].append({"uri": "inter.bin", "byteLength": len(blob)})
        doc["bufferViews"].append({"buffer": 1, "byteLength": len(blob), "byteStride": 24, "target": 34962})
        v = len(doc["bufferViews"]) - 1
        doc["accessors"][0].update(bufferView=v, byteOffset=0)
        doc["accessors"][1].update(bufferView=v, byteOffset=12)
        doc["accessors"][5].update(bufferView=v, byteOffset=4 * 24)
        doc["accessors"][6].update(bufferView=v, byteOffset=4 * 24 + 12)
    add("interleaved POSITION and NORMAL (byteStride 24)", interleaved)
    add("no NORMAL (computed)", lambda doc, d: [m["primitives"][0]["attributes"].pop("NORMAL") for m in doc["meshes"]])
    add("no material (the default)", lambda doc, d: [m["primitives"][0].pop("material") for m in doc["meshes"]])
    add("texture without a sampler", lambda doc, d: (doc["textures"][0].pop("sampler"), doc.pop("samplers")))
    add("no camera, no animation", lambda doc, d: (doc.pop("cameras"), doc.pop("animations"), doc["nodes"][3].pop("camera")))
    add("node matrix instead of TRS", lambda doc, d: (
        [doc["nodes"][2].pop(k) for k in ("translation", "rotation", "scale")],
        doc["nodes"][2].__setitem__("matrix", [1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0.2, 0, 1])))
    add("mirrored occluder (scale -1, 1, 1)", lambda doc, d: doc["nodes"][2].__setitem__("scale", [-1, 1, 1]))
    add("rotation quaternion in float32 digits", lambda doc, d: doc["nodes"][2].__setitem__(
        "rotation", [0, 0.38268343, 0, 0.92387953]))

    def deep(levels):
        def m(doc, d):
            start = len(doc["nodes"])
            for i in range(levels):
                doc["nodes"].append({"children": [start + i + 1]} if i + 1 < levels else {"mesh": 1,
                                                                                          "translation": [0, 0.1, 0]})
            doc["nodes"][0]["children"].append(start)
            doc["meshes"][1]["primitives"][0].pop("targets", None)
            doc["meshes"][1].pop("weights")
            doc["nodes"][2].pop("weights")
        return m
    add("a second occluder 30 nodes deep", deep(30), "either")

    def points_too(doc, d):
        prim = copy.deepcopy(doc["meshes"][0]["primitives"][0])
        prim.pop("indices")
        prim["mode"] = 0
        doc["meshes"][0]["primitives"].append(prim)
    add("a points primitive beside the triangles", points_too)

    def no_indices(doc, d):
        vals = IDX_FLOOR
        blob = b"".join(struct.pack("<3f", *FLOOR[i]) for i in vals) + b"".join(
            struct.pack("<3f", 0, 1, 0) for _ in vals) + b"".join(struct.pack("<2f", *UV0[i]) for i in vals) + b"".join(
            struct.pack("<2f", *UV1_FLOOR[i]) for i in vals)
        (d / "flat.bin").write_bytes(blob)
        doc["buffers"].append({"uri": "flat.bin", "byteLength": len(blob)})
        base_v = len(doc["bufferViews"])
        doc["bufferViews"].append({"buffer": 1, "byteLength": len(blob)})
        base_a = len(doc["accessors"])
        off = 0
        for typ, size in (("VEC3", 12), ("VEC3", 12), ("VEC2", 8), ("VEC2", 8)):
            a = {"bufferView": base_v, "byteOffset": off, "componentType": 5126, "count": 6, "type": typ}
            if off == 0:
                a.update(min=[-1, 0, -1], max=[1, 0, 1])
            doc["accessors"].append(a)
            off += size * 6
        doc["meshes"][0]["primitives"][0] = {"attributes": {"POSITION": base_a, "NORMAL": base_a + 1,
                                                            "TEXCOORD_0": base_a + 2, "TEXCOORD_1": base_a + 3},
                                             "material": 0}
    add("non-indexed triangles", no_indices)
    add("KHR_texture_transform on the occlusion texture", lambda doc, d: (
        doc["extensionsUsed"].append("KHR_texture_transform"),
        doc["materials"][0]["occlusionTexture"].__setitem__("extensions", {"KHR_texture_transform": {"scale": [2, 2]}})),
        "either")
    for name, kw in (("16-bit RGB", dict(bit_depth=16, color_type=2)), ("grey", dict(bit_depth=8, color_type=0)),
                     ("grey+alpha", dict(bit_depth=8, color_type=4)), ("RGBA", dict(bit_depth=8, color_type=6)),
                     ("1x1", dict(bit_depth=8, color_type=2, width=1, height=1)),
                     ("non-square 7x3", dict(bit_depth=8, color_type=2, width=7, height=3))):
        def m(doc, d, kw=kw):
            k = dict(width=4, height=4)
            k.update(kw)
            ch = {0: 1, 2: 3, 4: 2, 6: 4}[k["color_type"]] * (2 if k["bit_depth"] == 16 else 1)
            (d / "alt.png").write_bytes(png_bytes(k["width"], k["height"], rows=lambda y, w=k["width"], ch=ch: bytes(
                (37 * x + 11 * y + c) % 256 for x in range(w) for c in range(ch)), bit_depth=k["bit_depth"],
                color_type=k["color_type"]))
            doc["images"][0]["uri"] = "alt.png"
        add(f"{name} PNG texture", m)
    return out


GENERATORS["gltf-valid"] = gltf_valid_cases


# ----------------------------------------------------------------------------
# Damaged probe volumes (docs/FORMAT.md, "Probe volume"), checksum recomputed.

PROBE_HEADER_FIELDS = [  # name, offset, struct code
    ("version", 8, "<I"), ("nx", 12, "<i"), ("ny", 16, "<i"), ("nz", 20, "<i"),
    ("min.x", 24, "<d"), ("min.y", 32, "<d"), ("min.z", 40, "<d"), ("max.x", 48, "<d"), ("max.y", 56, "<d"),
    ("max.z", 64, "<d"), ("bands", 72, "<i"), ("cube_res", 76, "<i"), ("depth_res", 80, "<i"), ("mode", 84, "<i"),
    ("bounces", 88, "<i"), ("bounce_bands", 92, "<i"), ("channels", 96, "<i"), ("rays_per_texel", 100, "<i"),
    ("seed", 104, "<Q"), ("scene_hash", 112, "<Q"), ("depth_cap", 120, "<f")]
PROBE_HEADER = 124
PROBE_ARRAYS = [("state", "B"), ("positions", "f"), ("vis_nodes", "H"), ("vis_offsets", "Q"), ("vis_complement", "B"),
                ("partial_nodes", "H"), ("partial_mask", "H"), ("partial_offsets", "Q"), ("depth", "H"),
                ("bounce", "f")]


def parse_probes(data):
    """(header bytes, {name: [values]}, {name: count}) of a probe file."""
    at, arrays, counts = PROBE_HEADER, {}, {}
    for name, code in PROBE_ARRAYS:
        (n,) = struct.unpack_from("<Q", data, at)
        at += 8
        k = 3 * n if name == "positions" else n
        arrays[name] = list(struct.unpack_from("<%d%s" % (k, code), data, at))
        counts[name] = n
        at += struct.calcsize("<%d%s" % (k, code))
    assert at == len(data) - 12, "probe file layout differs from docs/FORMAT.md"
    return bytearray(data[:PROBE_HEADER]), arrays, counts


def build_probes(header, arrays, counts=None, checksum=True):
    b = bytearray(header)
    for name, code in PROBE_ARRAYS:
        v = arrays[name]
        n = (counts or {}).get(name, len(v) // 3 if name == "positions" else len(v))
        b += struct.pack("<Q", n) + struct.pack("<%d%s" % (len(v), code), *v)
    return with_checksum(b) if checksum else bytes(b) + b"\0" * 8 + b"PRTE"


def probe_damage_cases(base, py):
    out = []
    env, scene, pts = base.path("env.hdr"), base.path("scene.gltf"), base.path("pts.csv")

    def surfaces(d, f):
        return {
            "info": ["info", f],
            "relight": ["relight", scene, f, env, "--at", pts, "-q", "-o", d / "out.csv"],
            "export": ["export", scene, "--probes", f, "--bake", env, "-q", "-o", d / "out.json", "--matrices",
                       d / "m.bin"],
        }

    def add(name, source, damage, expect="invalid", which=("info", "relight"), checksum=True):
        """damage(header, arrays, counts, info) changes them in place, or returns the file's bytes."""
        for surface in which:
            def make(d, source=source, damage=damage, surface=surface):
                data = base.path(source).read_bytes()
                header, arrays, counts = parse_probes(data)
                given = dict(counts)
                r = damage(header, arrays, counts, probe_info(header, arrays))
                # Counts the damage set itself stay; the others follow the arrays.
                override = {k: v for k, v in counts.items() if v != given[k]}
                blob = r if isinstance(r, (bytes, bytearray)) else build_probes(header, arrays, override, checksum)
                f = d / "damaged.prt"
                f.write_bytes(blob)
                return surfaces(d, f)[surface]
            out.append(Case("probe-damage", f"{source}: {name} [{surface}]", make, expect,
                            tokens=("damaged.prt", "out.csv", "out.json", "m.bin")))

    def set_field(name, value):
        off, code = next((o, c) for n, o, c in PROBE_HEADER_FIELDS if n == name)
        return lambda h, a, c, i: struct.pack_into(code, h, off, value)

    i32 = [("0", 0), ("1", 1), ("-1", -1), ("2^31-1", 2 ** 31 - 1), ("-2^31", -2 ** 31)]
    header_values = {
        "version": [("0", 0), ("2", 2), ("2^32-1", 2 ** 32 - 1)],
        "nx": i32 + [("1025", 1025), ("4", 4)], "ny": i32 + [("3", 3)], "nz": i32 + [("1024", 1024)],
        "bands": i32 + [("2", 2), ("17", 17), ("65", 65)],
        "cube_res": i32 + [("2", 2), ("3", 3), ("4", 4), ("16", 16), ("128", 128), ("65536", 65536)],
        "depth_res": i32 + [("2", 2), ("65", 65), ("65536", 65536)],
        "mode": i32 + [("2 (interreflected)", 2), ("3", 3)],
        "bounces": i32 + [("65", 65)], "bounce_bands": i32 + [("17", 17)], "channels": i32 + [("3", 3), ("4", 4)],
        "rays_per_texel": i32,
        "seed": [("0", 0), ("2^64-1", 2 ** 64 - 1)],
        "scene_hash": [("flipped", None)],
    }
    floats = [("NaN", float("nan")), ("inf", float("inf")), ("-inf", float("-inf")), ("1e13", 1e13), ("-1e13", -1e13),
              ("1e308", 1e308), ("denormal", 5e-324)]
    # What each header field may hold (docs/FORMAT.md and prt precompute's
    # ranges); a value outside is invalid, one inside "either" (a consistent
    # file may hold it), the field's own value is skipped.
    ranges = {"version": (1, 1), "nx": (2, 1024), "ny": (2, 1024), "nz": (2, 1024), "bands": (1, 16),
              "cube_res": (4, 64), "depth_res": (1, 64), "mode": (1, 2), "bounces": (0, 64), "bounce_bands": (1, 16),
              "channels": (1, 3), "rays_per_texel": (1, 2 ** 31 - 1), "seed": (0, 2 ** 64 - 1)}
    ir_header = parse_probes(base.path("probes-ir.prt").read_bytes())[0]
    for src, hdr in (("probes.prt", parse_probes(base.path("probes.prt").read_bytes())[0]), ("probes-ir.prt", ir_header)):
        for fi, (name, off, code) in enumerate(PROBE_HEADER_FIELDS):
            if src == "probes-ir.prt" and name not in ("mode", "bounces", "bounce_bands", "channels", "bands"):
                continue
            own = struct.unpack_from(code, hdr, off)[0]
            if code == "<d":
                vals = floats + [("0", 0.0)]
            elif name == "depth_cap":
                vals = [(l, v) for l, v in floats if l != "1e308"] + [("0", 0.0), ("-1", -1.0), ("9e12", 9e12),
                                                                      ("3.4e38", 3.4e38)]
            else:
                vals = header_values[name]
            for vi, (label, value) in enumerate(vals):
                if value is not None and value == own:
                    continue
                which = ("info", "relight") if (fi + vi) % 2 == 0 else ("info",)
                if name == "scene_hash":
                    def dmg(h, a, c, i):
                        struct.pack_into("<Q", h, 112, struct.unpack_from("<Q", h, 112)[0] ^ 1)
                    add("scene hash flipped (another scene's)", src, dmg, "either", ("info",))
                    add("scene hash flipped (another scene's)", src, dmg, "invalid", ("relight",))
                    continue
                if name in ranges:
                    lo, hi = ranges[name]
                    expect = "either" if lo <= value <= hi else "invalid"
                    if name in ("nx", "ny", "nz", "cube_res", "depth_res", "channels") and expect == "either":
                        expect = "either"  # sizes change what the arrays must hold: a reader may or may not notice
                    if name == "version" or (name == "mode" and src == "probes.prt" and value == 2):
                        expect = "invalid"
                elif code == "<d":   # the box: finite, within 1e12
                    expect = "either" if label in ("0", "denormal") else "invalid"
                else:                # the depth cap: positive, at most 8e12
                    expect = "either" if label in ("3.4e38",) else ("invalid" if label != "denormal" else "either")
                    if label == "3.4e38":
                        expect = "invalid"
                add(f"header {name} = {label}", src, set_field(name, value), expect, which)
    # Counts: each array's count off by one, zero, huge (data unchanged).
    for arr, _ in PROBE_ARRAYS:
        for label, delta in (("+1", 1), ("-1", -1), ("0", None), ("2^32", 2 ** 32), ("2^63", 2 ** 63),
                             ("2^64-1", 2 ** 64 - 1)):
            src = "probes-ir.prt" if arr == "bounce" else "probes.prt"

            def dmg(h, a, c, i, arr=arr, delta=delta):
                if delta is None:
                    c[arr] = 0
                elif delta in (1, -1):
                    c[arr] = max(0, c[arr] + delta)
                else:
                    c[arr] = delta
            if arr == "bounce" and label == "0":
                continue
            add(f"count of {arr} {label}", src, dmg)
    # Contents: the quadtree's node ids, offsets, partial texels, flags.
    def first_with(a, kind, stored):
        offs = a[kind + "_offsets"]
        for p in range(stored):
            if offs[p + 1] > offs[p]:
                return p, offs[p], offs[p + 1]
        raise RuntimeError("no probe with " + kind + " entries")

    def node_change(value_fn, label, expect="invalid"):
        def dmg(h, a, c, i):
            p, lo, hi = first_with(a, "vis", i["stored"])
            a["vis_nodes"][lo] = value_fn(a["vis_nodes"][lo], i, a, lo, hi)
        add(f"visibility node {label}", "probes.prt", dmg, expect)

    def node_insert(value_fn, label, expect="invalid"):
        def dmg(h, a, c, i):
            p, lo, hi = first_with(a, "vis", i["stored"])
            a["vis_nodes"].insert(hi, value_fn(a["vis_nodes"][lo], i, a, lo, hi))
            for k in range(p + 1, i["stored"] + 1):
                a["vis_offsets"][k] += 1
        add(f"visibility node {label}", "probes.prt", dmg, expect)
    node_change(lambda v, i, a, lo, hi: 6 * i["per_face"], "id = 6 x nodes per face (past the last)")
    node_change(lambda v, i, a, lo, hi: 6 * i["per_face"] + 1, "id = 6 x nodes per face + 1")
    node_change(lambda v, i, a, lo, hi: 65535, "id = 65535")
    node_change(lambda v, i, a, lo, hi: a["vis_nodes"][lo + 1] if hi - lo > 1 else v, "equal to the next")
    node_insert(lambda v, i, a, lo, hi: v, "listed twice")
    node_insert(lambda v, i, a, lo, hi: node_parent(v, i["cube"]) if node_parent(v, i["cube"]) is not None
                else node_child(v, i["cube"]), "and its parent (one inside the other)")
    node_insert(lambda v, i, a, lo, hi: node_child(v, i["cube"]) if node_child(v, i["cube"]) is not None
                else node_parent(v, i["cube"]), "and its child")
    node_insert(lambda v, i, a, lo, hi: (v // i["per_face"] + 1) * i["per_face"] - 1, "and its face's root")
    for face in range(6):
        def dmg(h, a, c, i, face=face):
            p, lo, hi = first_with(a, "vis", i["stored"])
            roots = [(f + 1) * i["per_face"] - 1 for f in range(6)]
            a["vis_nodes"][lo:hi] = roots
            for k in range(p + 1, i["stored"] + 1):
                a["vis_offsets"][k] += len(roots) - (hi - lo)
            a["vis_nodes"][lo + face] = roots[(face + 1) % 6]  # one root twice, one face missing
        add(f"probe's nodes: six face roots with face {face} twice", "probes.prt", dmg)

    def offsets(kind, label, fn, expect="invalid"):
        def dmg(h, a, c, i):
            fn(a[kind + "_offsets"], len(a[kind + "_nodes"]))
        add(f"{kind} offsets {label}", "probes.prt", dmg, expect)
    for kind in ("vis", "partial"):
        offsets(kind, "first 1", lambda o, n: o.__setitem__(0, 1))
        offsets(kind, "decreasing", lambda o, n: o.__setitem__(1, o[2] + 1))
        offsets(kind, "last past the count", lambda o, n: o.__setitem__(-1, n + 1))
        offsets(kind, "last short of the count", lambda o, n: o.__setitem__(-1, n - 1))
        offsets(kind, "one 2^64-1", lambda o, n: o.__setitem__(1, 2 ** 64 - 1))
        offsets(kind, "one 2^63", lambda o, n: o.__setitem__(2, 2 ** 63))
        offsets(kind, "all zero but the last", lambda o, n: o.__setitem__(slice(0, -1), [0] * (len(o) - 1)), "either")

    def partial(label, fn, expect="invalid"):
        def dmg(h, a, c, i):
            p, lo, hi = first_with(a, "partial", i["stored"])
            fn(a, i, p, lo, hi)
        add(f"partial texel {label}", "probes.prt", dmg, expect)
    partial("mask 0", lambda a, i, p, lo, hi: a["partial_mask"].__setitem__(lo, 0))
    partial("mask 0xffff", lambda a, i, p, lo, hi: a["partial_mask"].__setitem__(lo, 0xFFFF))
    partial("mask another edge pattern", lambda a, i, p, lo, hi: a["partial_mask"].__setitem__(lo, 0x00FF), "either")
    partial("on a seventh face", lambda a, i, p, lo, hi: a["partial_nodes"].__setitem__(
        lo, 6 * i["per_face"] + a["partial_nodes"][lo] % i["per_face"]))
    partial("id 65535", lambda a, i, p, lo, hi: a["partial_nodes"].__setitem__(lo, 65535))
    partial("not a finest texel", lambda a, i, p, lo, hi: a["partial_nodes"].__setitem__(
        lo, a["partial_nodes"][lo] // i["per_face"] * i["per_face"] + i["cube"] ** 2))
    partial("a face root", lambda a, i, p, lo, hi: a["partial_nodes"].__setitem__(
        lo, (a["partial_nodes"][lo] // i["per_face"] + 1) * i["per_face"] - 1))

    def partial_twice(a, i, p, lo, hi):
        a["partial_nodes"].insert(hi, a["partial_nodes"][lo])
        a["partial_mask"].insert(hi, a["partial_mask"][lo])
        for k in range(p + 1, i["stored"] + 1):
            a["partial_offsets"][k] += 1
    partial("listed twice", partial_twice)

    def partial_inside_node(a, i, p, lo, hi):
        # A finest texel inside one of the probe's listed nodes, as a partial texel.
        vlo, vhi = a["vis_offsets"][p], a["vis_offsets"][p + 1]
        comp = a["vis_complement"][p]
        inside = [t for t in range(i["per_face"] * 6) if t % i["per_face"] < i["cube"] ** 2 and
                  any(node_contains(n, t, i["cube"]) for n in a["vis_nodes"][vlo:vhi])]
        outside = [t for t in range(i["per_face"] * 6) if t % i["per_face"] < i["cube"] ** 2 and t not in inside]
        pick = (inside if comp == 0 else outside)
        listed = set(a["partial_nodes"][lo:hi])
        pick = [t for t in pick if t not in listed]
        if pick:
            a["partial_nodes"][lo] = pick[0]
    partial("inside the region its nodes already count", partial_inside_node)
    partial("complement flag flipped", lambda a, i, p, lo, hi: a["vis_complement"].__setitem__(
        p, a["vis_complement"][p] ^ 1))
    for label, v in (("2", 2), ("255", 255)):
        add(f"complement flag {label}", "probes.prt", lambda h, a, c, i, v=v: a["vis_complement"].__setitem__(0, v))
    for label, v in (("3", 3), ("255", 255)):
        add(f"state of probe 0 = {label}", "probes.prt", lambda h, a, c, i, v=v: a["state"].__setitem__(0, v))
    add("state of probe 0 stored -> sky", "probes.prt", lambda h, a, c, i: a["state"].__setitem__(0, 0))
    add("state of probe 0 stored -> invalid", "probes.prt", lambda h, a, c, i: a["state"].__setitem__(0, 2))
    for label, v in [(l, v) for l, v in floats if l != "1e308"] + [("8.5e12", 8.5e12), ("7e12", 7e12)]:
        add(f"position of probe 0 x = {label}", "probes.prt",
            lambda h, a, c, i, v=v: a["positions"].__setitem__(0, struct.unpack("<f", struct.pack("<f", v))[0]
                                                                if math.isfinite(v) and abs(v) < 3.4e38 else v),
            "either" if label in ("7e12", "denormal") else "invalid")
    for label, v in (("0", 0), ("65535", 65535)):
        add(f"every depth moment {label}", "probes.prt", lambda h, a, c, i, v=v: a["depth"].__setitem__(
            slice(None), [v] * len(a["depth"])), "either")
    for label, v in (("NaN", float("nan")), ("inf", float("inf")), ("1e38", 1e38)):
        add(f"bounce matrix entry {label}", "probes-ir.prt",
            lambda h, a, c, i, v=v: a["bounce"].__setitem__(0, v), "either" if label == "1e38" else "invalid")
    # Truncated, padded, trailer damage (no recomputed checksum where noted).
    for cut in (0, 7, 8, 12, 123, 124, 131, 200, -13, -12, -5, -1):
        def dmg(h, a, c, i, cut=cut):
            data = build_probes(h, a)
            return data[:cut]
        add(f"truncated at byte {cut}", "probes.prt", dmg)
    add("a byte appended", "probes.prt", lambda h, a, c, i: build_probes(h, a) + b"\0")
    add("a byte flipped, checksum kept", "probes.prt",
        lambda h, a, c, i: (lambda b: b[:300] + bytes([b[300] ^ 1]) + b[301:])(build_probes(h, a)))
    add("trailer PRTX", "probes.prt", lambda h, a, c, i: build_probes(h, a)[:-4] + b"PRTX")
    add("signature PRTT (a transfer's)", "probes.prt",
        lambda h, a, c, i: with_checksum(b"PRTT" + build_probes(h, a)[4:-12]))
    add("empty file", "probes.prt", lambda h, a, c, i: b"")
    # The same damage through export (its own reader path), a sample of the above.
    sample = [c for c in out if c.name.endswith("[info]")][::6]
    for c in sample:
        src, rest = c.name.split(": ", 1)
        name = rest[: -len(" [info]")]

        def make(d, c=c):
            argv = c.make(d)
            return ["export", scene, "--probes", argv[1], "--bake", env, "-q", "-o", d / "out.json", "--matrices",
                    d / "m.bin"]
        out.append(Case("probe-damage", f"{src}: {name} [export]", make, c.expect, tokens=("damaged.prt",)))
    return out


def probe_info(header, arrays):
    cube = struct.unpack_from("<i", header, 76)[0]
    cube = cube if 0 < cube <= 1024 else 8
    return {"cube": cube, "per_face": (4 * cube * cube - 1) // 3, "stored": len(arrays["vis_offsets"]) - 1}


def node_coords(node, r):
    """(face, level, x, y) of a node id of a cube of face size r."""
    per_face = (4 * r * r - 1) // 3
    face, rest = divmod(node, per_face)
    level, size = 0, r
    while rest >= size * size:
        rest -= size * size
        level += 1
        size >>= 1
    return face, level, rest % size, rest // size


def node_id(face, level, x, y, r):
    per_face = (4 * r * r - 1) // 3
    off = sum((r >> l) ** 2 for l in range(level))
    return face * per_face + off + y * (r >> level) + x


def node_parent(node, r):
    face, level, x, y = node_coords(node, r)
    return None if (r >> level) == 1 else node_id(face, level + 1, x // 2, y // 2, r)


def node_child(node, r):
    face, level, x, y = node_coords(node, r)
    return None if level == 0 else node_id(face, level - 1, 2 * x, 2 * y, r)


def node_contains(node, texel, r):
    f1, l1, x1, y1 = node_coords(node, r)
    f2, l2, x2, y2 = node_coords(texel, r)
    return f1 == f2 and l2 <= l1 and (x2 >> (l1 - l2)) == x1 and (y2 >> (l1 - l2)) == y1


GENERATORS["probe-damage"] = probe_damage_cases


# ----------------------------------------------------------------------------
# Options: every option of precompute, relight, reference and export (read
# from their --help) x the bad values of its type, in a context where it
# applies; the combinations the issue names; outputs that collide.

INPUT_FILES = ("scene.gltf", "scene.bin", "tex.png", "env.hdr", "mesh.obj", "pts.csv", "lm.prt", "probes.prt",
               "mesh.prt", "glossy.prt")


def copy_inputs(base, d):
    """Copies of the base inputs in d (a case may write over one if prt lets it)."""
    for name in INPUT_FILES:
        shutil.copyfile(base.path(name), d / name)


CONTEXTS = {  # name: (subcommand args before the option, output file name)
    "vertex": (["precompute", "mesh.obj", "--samples", "4", "--bands", "1", "-q"], "out.prt"),
    "lightmap": (["precompute", "scene.gltf", "--lightmap", "8x8", "--samples", "4", "--bands", "1", "-q"], "out.prt"),
    "probes": (["precompute", "scene.gltf", "--probes", "2x2x2", "--probe-cube", "4", "--samples", "8", "-q"], "out.prt"),
    "subdivide": (["precompute", "mesh.obj", "--samples", "4", "--bands", "1", "--subdivide", "0.5", "-q"], "out.prt"),
    "zh": (["precompute", "mesh.obj", "--samples", "4", "--bands", "2", "--basis", "zh", "-q"], "out.prt"),
    "wavelet": (["precompute", "mesh.obj", "--basis", "wavelet", "--cube-res", "4", "-q"], "out.prt"),
    "adaptive": (["precompute", "mesh.obj", "--samples", "4", "--bands", "1", "--adaptive", "0.01", "-q"], "out.prt"),
    "compress": (["precompute", "mesh.obj", "--samples", "4", "--bands", "2", "--compress", "2x2", "-q"], "out.prt"),
    "target": (["precompute", "mesh.obj", "--target-error", "0.5", "--env", "env.hdr", "--samples", "4", "-q"],
               "out.prt"),
    "relight-lm": (["relight", "scene.gltf", "lm.prt", "env.hdr", "-q"], "out.exr"),
    "relight-vertex": (["relight", "mesh.obj", "mesh.prt", "env.hdr", "-q"], "out.csv"),
    "relight-at": (["relight", "scene.gltf", "probes.prt", "env.hdr", "--at", "pts.csv", "-q"], "out.csv"),
    "relight-glossy": (["relight", "mesh.obj", "glossy.prt", "env.hdr", "--eye", "0,1,3", "-q"], "out.csv"),
    "reference-glossy": (["reference", "mesh.obj", "env.hdr", "--material", "glossy", "--eye", "0,1,3", "--samples",
                          "4", "-q"], "out.csv"),
    "reference-at": (["reference", "scene.gltf", "env.hdr", "--at", "pts.csv", "--samples", "4", "-q"], "out.csv"),
    "reference-lm": (["reference", "scene.gltf", "env.hdr", "--lightmap", "8x8", "--samples", "4", "-q"], "out.exr"),
    "reference-vertex": (["reference", "mesh.obj", "env.hdr", "--samples", "4", "-q"], "out.csv"),
    "export-lm": (["export", "scene.gltf", "lm.prt", "-q"], "out.glb"),
    "export-probes": (["export", "scene.gltf", "--probes", "probes.prt", "--bake", "env.hdr", "-q"], "out.json"),
    "export-web": (["export", "mesh.obj", "mesh.prt", "--web", "web", "-q"], None),
}

# option: context, for those that apply in one only (others: the subcommand's first).
OPTION_CONTEXT = {
    "precompute": {"--uv": "lightmap", "--ao-map": "lightmap", "--bent-normal-map": "lightmap",
                   "--obscurance": "lightmap", "--obscurance-map": "lightmap", "--lightmap": "lightmap",
                   "--probe-cube": "probes", "--bounce-bands": "probes", "--probes": "probes",
                   "--subdivide": "subdivide", "--subdivide-max-vertices": "subdivide", "--subdivided-mesh": "subdivide",
                   "--lobes": "zh", "--tangent": "zh", "--cube-res": "wavelet", "--threshold": "wavelet",
                   "--verify-adaptive": "adaptive", "--compress-weights": "compress", "--env": "target",
                   "--cache": "target", "--target-error": "target", "--memory-limit": "lightmap"},
    "relight": {"--at": "relight-at", "--terms": "relight-vertex", "--eye": "relight-glossy",
                "--window-width": "relight-vertex", "--gloss": "relight-glossy", "--specular": "relight-glossy",
                "--diffuse": "relight-glossy", "--tonemap": "relight-vertex", "--exposure": "relight-vertex",
                "--deform": "relight-vertex", "--time": "relight-vertex", "--animation": "relight-vertex"},
    "reference": {"--lightmap": "reference-lm", "--uv": "reference-lm", "--at": "reference-at",
                  "--eye": "reference-glossy", "--gloss": "reference-glossy", "--specular": "reference-glossy"},
    "export": {"--probes": "export-probes", "--bake": "export-probes", "--matrices": "export-probes",
               "--matrix-bands": "export-probes", "--web": "export-web", "--env": "export-web",
               "--camera": "export-web", "--fov": "export-web", "--tonemap": "export-web", "--exposure": "export-web"},
}
FIRST_CONTEXT = {"precompute": "vertex", "relight": "relight-vertex", "reference": "reference-vertex",
                 "export": "export-lm"}
OUTPUT_EXT = {"--ao-map": ".exr", "--bent-normal-map": ".exr", "--obscurance-map": ".exr", "--subdivided-mesh": ".ply",
              "--matrices": ".bin", "--web": ""}
OUTPUT_OPTIONS = {"--output", "--ao-map", "--bent-normal-map", "--obscurance-map", "--subdivided-mesh", "--matrices",
                  "--web"}
INPUT_OPTIONS = {"--at", "--env", "--bake", "--probes"}
SKIP_OPTIONS = {"--help"}


def parse_help(prt, sub):
    """[(long name, type text, whole line)] of `prt SUB --help`."""
    r = subprocess.run([prt, sub, "--help"], capture_output=True, text=True, timeout=60)
    out, in_options = [], False
    for line in r.stdout.splitlines():
        if line.startswith("Options:"):
            in_options = True
            continue
        if in_options and line and not line.startswith(" "):
            break
        m = re.match(r"^\s+(?:-\w,)?(--[\w-]+)(.*)$", line)
        if in_options and m and m.group(1) not in SKIP_OPTIONS:
            out.append((m.group(1), m.group(2).strip(), line))
    return out


def option_values(name, spec, sub):
    """(label, value, expect) bad values of an option by its type (spec: the
    text after the name in --help)."""
    inv = lambda pairs: [(l, v, "invalid") for l, v in pairs]  # noqa: E731
    junk = [("empty", ""), ("letters", "abc"), ("garbage", "1;2")]
    m_range = re.match(r"(INT|UINT|FLOAT|FRACTION):(\w+)(?: in ([\[(])\s*([-+\d.e]+)\s*[,-]\s*([-+\d.e]+)\s*([\])]))?",
                       spec)
    m_enum = re.match(r"INT:\{([^}]*)\}", spec)
    if m_enum:
        allowed = [int(x) for x in re.findall(r"\d+", m_enum.group(1))]
        return inv(junk + [("not-listed", str(max(allowed) + 1)), ("minus", "-" + str(allowed[0])),
                           ("zero", "0"), ("half", f"{allowed[0]}.5"), ("2^64", str(2 ** 64)), ("nan", "nan")]) + \
            [("leading-zero", "0" + str(allowed[0]), "either")]
    if m_range:
        base_t, sub_t, lb, lo, hi, rb = m_range.groups()
        is_int = base_t in ("INT", "UINT") and sub_t not in ("NUMBER", "FLOAT")
        out = inv(junk + [("nan", "nan"), ("inf", "inf"), ("1e400", "1e400")])
        if is_int:
            if lo is not None:
                lo_i, hi_i = int(float(lo)), int(float(hi))
            else:  # UINT64 (a seed) or an unbounded INT
                lo_i, hi_i = (0, 2 ** 64 - 1) if sub_t == "UINT64" or base_t == "UINT" else (-2 ** 31, 2 ** 31 - 1)
            for l, v in (("minus-1", -1), ("2^31", 2 ** 31), ("2^32", 2 ** 32), ("2^63", 2 ** 63), ("2^64", 2 ** 64)):
                out.append((l, str(v), "either" if lo_i <= v <= hi_i else "invalid"))
            out += inv([("half", "1.5"), ("hex", "0x10"), ("digits-400", "9" * 400)])
            out += [("exponent-form", "1e1", "either"), ("plus", "+2", "either"), ("leading-zero", "02", "either")]
            if lo is not None:
                out += [("below", str(lo_i - 1), "invalid"), ("above", str(hi_i + 1), "invalid")]
                if sub_t == "POW2":
                    out.append(("not-power-of-2", str(lo_i + 1 if lo_i + 1 & lo_i else lo_i * 3), "invalid"))
        else:
            out += [("underflow", "1e-400", "either"), ("hex-float", "0x1p-2", "either")]
            if lo is not None:
                lo_f, hi_f = float(lo), float(hi)
                out += [("below", repr(lo_f - 1), "invalid"), ("above", repr(hi_f * 2 + 1), "invalid")]
                if lb == "(":
                    out.append(("open-low-end", lo, "invalid"))
                if rb == ")":
                    out.append(("open-high-end", hi, "invalid"))
            elif sub_t == "POSITIVE":
                out += [("negative", "-1", "invalid"), ("minus-zero", "-0", "either")]
        return out
    if spec.startswith("TEXT:{"):
        choices = re.findall(r"[\w-]+", spec[6:spec.index("}")])
        return inv(junk + [("unknown", "unknown"), ("two", ",".join(choices[:2]))]) + \
            [("upper-case", choices[0].upper(), "either")]
    tuples = {"r,g,b": (3, "0.5"), "x,y,z": (3, "0.5"), "yaw,pitch,roll": (3, "10"), "ex,ey,ez": (9, None),
              "rho or r,g,b": (3, "0.5")}
    for key, (n, good) in tuples.items():
        if spec.startswith("TEXT:" + key):
            if n == 9:
                ok = ["2", "1", "2", "0", "0", "0", "0", "1", "0"]
            else:
                ok = [good] * n
            j = lambda v: ",".join(v)  # noqa: E731
            out = inv(junk + [("short", j(ok[:-1])), ("long", j(ok + ok[:1])), ("nan", j(["nan"] + ok[1:])),
                              ("inf", j(["inf"] + ok[1:])), ("1e400", j(["1e400"] + ok[1:])),
                              ("commas", "," * (n - 1)), ("trailing-comma", j(ok) + ","),
                              ("letters", j(["a"] * n)), ("semicolons", ";".join(ok))])
            if key in ("r,g,b", "rho or r,g,b"):
                out += inv([("above-1", j(["2"] + ok[1:])), ("negative", j(["-0.5"] + ok[1:]))])
            if key == "x,y,z":  # an eye point: far away is a direction, not a wrong input
                out += [("beyond-1e12", j(["1e13"] + ok[1:]), "either"), ("1e300", j(["1e300"] + ok[1:]), "either")]
            if n == 9:  # a web page's first camera: far is odd, not wrong
                out += [("beyond-1e12", j(["1e13"] + ok[1:]), "either"), ("1e300", j(["1e300"] + ok[1:]), "either")]
            if n == 9:
                out += inv([("eye-equals-target", j(["0", "0", "0", "0", "0", "0", "0", "1", "0"])),
                            ("up-zero", j(ok[:6] + ["0", "0", "0"])),
                            ("up-along-view", j(["0", "2", "0", "0", "0", "0", "0", "1", "0"]))])
            if key == "yaw,pitch,roll":
                out += [("1e13-degrees", j(["1e13", "0", "0"]), "either"),
                        ("1e300-degrees", j(["1e300", "0", "0"]), "either")]
            if key == "rho or r,g,b":
                out = [x for x in out if x[0] != "short"] + [("two", "0.5,0.5", "invalid")]
            return out
    if spec.startswith("TEXT:SIZE"):
        return inv(junk + [("zero", "0"), ("negative", "-1G"), ("1e400G", "1e400G"), ("unit-X", "100X"),
                           ("2^64", str(2 ** 64)), ("two-dots", "1.5.5G"), ("unit-twice", "1GG"), ("nan", "nan"),
                           ("inf", "inf"), ("1", "1"), ("1e30T", "1e30T")]) + \
            [("lower-case-unit", "100m", "either"), ("spaced", "100 M", "either"), ("fraction", "0.5G", "either")]
    if spec.startswith("TEXT:STOPS|auto"):
        return inv(junk + [("nan", "nan"), ("inf", "inf"), ("65", "65"), ("-65", "-65"), ("1e400", "1e400"),
                           ("autox", "autox")]) + [("AUTO", "AUTO", "either")]
    if spec.startswith("TEXT:bend:ANGLE"):
        return inv(junk + [("no-angle", "bend:"), ("nan", "bend:nan"), ("inf", "bend:inf"), ("721", "bend:721"),
                           ("1e400", "twist:1e400"), ("unknown", "shear:10"), ("no-kind", ":10")])
    if spec.startswith("TEXT:KxN") or name == "--compress":
        return inv(junk + [("zero-k", "0x4"), ("x", "x"), ("negative", "-2x2"),
                           ("huge", "99999999999x8"), ("three", "2x2x2"), ("half", "2.5x2")]) + [
            ("zero-n (N = 0 is allowed by prt compress --pca)", "4x0", "either")]
    if name == "--cache":  # a directory (a refusal names it: tokens below)
        return inv([("empty", "")]) + [("a-file", "scene.gltf", "either"), ("missing", "no/such/dir", "either")]
    if spec.startswith("[TOL]"):
        return inv([("nan", "nan"), ("inf", "inf"), ("negative", "-0.1"), ("letters", "abc"), ("1e400", "1e400"),
                    ("two", "2")]) + [("zero", "0", "either"), ("empty", "", "either")]
    if name == "--lightmap":
        return inv(junk + [("0x8", "0x8"), ("8x0", "8x0"), ("neg", "-8x8"), ("16385", "16385x8"), ("one", "8"),
                           ("8x", "8x"), ("x8", "x8"), ("three", "8x8x8"), ("float", "8.5x8"),
                           ("20-digits", "99999999999999999999x8"), ("junk-after", "8x8junk"), ("exp", "1e1x8")]) + \
            [("upper-X", "8X8", "either"), ("plus", "+8x8", "either"), ("leading-zero", "08x08", "either")]
    if name == "--probes" and sub == "precompute":
        return inv(junk + [("1x2x2", "1x2x2"), ("2x2x1", "2x2x1"), ("0x0x0", "0x0x0"), ("neg", "-2x2x2"),
                           ("1025", "1025x2x2"), ("1024^3", "1024x1024x1024"), ("257x256x256", "257x256x256"),
                           ("two", "2x2"), ("four", "2x2x2x2"), ("float", "2.5x2x2"),
                           ("20-digits", "2x2x99999999999999999999")])
    if name == "--web":  # a directory it makes, or an empty one
        return inv([("empty", ""), ("an existing file", "scene.gltf")]) + [("an empty directory", "@dir", "either"),
                                                                          ("a missing directory", "@missingx", "either")]
    if name in OUTPUT_OPTIONS:
        ext = OUTPUT_EXT.get(name, "")
        return inv([("empty", ""), ("a-directory", "@dir" + ext), ("missing-directory", "@missing" + "x" + ext)])
    if name in INPUT_OPTIONS:
        return inv([("empty", ""), ("a-directory", "."), ("missing", "missing.file"), ("fifo", "@fifo"),
                    ("dev-zero", "/dev/zero")])
    if spec.startswith("TEXT"):  # a word from a list in the description
        return inv(junk + [("unknown", "unknown-thing")])
    return []  # a flag


def options_cases(base, py):
    out = []
    prt = base.prt

    def case(name, ctx, extra, expect, tokens, rss=None, timeout=None, note="", output=True):
        pre, outname = CONTEXTS[ctx]

        def make(d, pre=pre, outname=outname, extra=extra):
            copy_inputs(base, d)
            args = list(pre)
            if output and outname:
                args += ["-o", outname]
            extra = list(extra)
            if extra and extra[0].startswith("--") and "=" not in extra[0] and extra[0] in args and len(extra) == 2:
                args[args.index(extra[0]) + 1] = extra[1]  # the context's own option: a new value, not a second one
                extra = []
            for a in extra:
                if a == "@fifo":
                    os.mkfifo(d / "fifo")
                    a = "fifo"
                elif a.startswith("@dir"):
                    (d / a[1:]).mkdir()
                    a = a[1:]
                elif a.startswith("@missing"):
                    a = "no/such/dir/" + a[len("@missing"):]
                args.append(a)
            return args
        c = Case("options", name, make, expect, tokens=tokens, rss_mb=rss, timeout=timeout, note=note)
        out.append(c)
        return c

    for sub in ("precompute", "relight", "reference", "export"):
        for name, spec, line in parse_help(prt, sub):
            ctx = OPTION_CONTEXT.get(sub, {}).get(name, FIRST_CONTEXT[sub])
            for label, value, expect in option_values(name, spec, sub):
                if name == "--output" and value.startswith("@"):
                    out_ext = os.path.splitext(CONTEXTS[ctx][1] or "")[1]
                    value += out_ext
                if name == "--output":
                    extra = ["-o", value] if not value.startswith("-") else ["-o=" + value]
                    shown = value[1:] if value.startswith("@dir") else ("no/such/dir/" + value[8:] if
                                                                         value.startswith("@missing") else value)
                    case(f"{sub} --output {label} ({shown!r})", ctx, extra, expect,
                         (name, "-o", "output", shown + ":" if shown else "''", shown + " " if shown else "''"),
                         output=False)
                    continue
                if value.startswith("-") or value == "":
                    extra = [name + "=" + value] if value.startswith("-") else [name, value]
                else:
                    extra = [name, value]
                if name == "--obscurance-map":
                    extra += ["--obscurance", "0.5"]
                elif name == "--obscurance":
                    extra += ["--obscurance-map", "obs.exr"]
                shown = value[1:] if value.startswith("@dir") else ("no/such/dir/" + value[8:] if
                                                                     value.startswith("@missing") else value)
                tokens = (name,) + ((shown + ":", shown + " ") if name in INPUT_OPTIONS | OUTPUT_OPTIONS and value else ())
                if name == "--cache" and value:
                    tokens += (value,)
                if value == "@fifo":
                    tokens += ("fifo:",)
                case(f"{sub} {name} {label} ({value!r}) [{ctx}]", ctx, extra, expect, tokens)
    # Positional inputs that are not files of their kind.
    for ctx, slots in (("lightmap", [(1, "SCENE")]), ("relight-lm", [(1, "SCENE"), (2, "TRANSFER"), (3, "ENV")]),
                       ("relight-at", [(2, "TRANSFER")]), ("export-probes", [(1, "SCENE")]),
                       ("reference-at", [(1, "SCENE"), (2, "ENV")])):
        for pos, what in slots:
            for label, value in (("empty", ""), ("a-directory", "."), ("missing", "missing.gltf"), ("fifo", "@fifo"),
                                 ("dev-zero", "/dev/zero"), ("dev-null", "/dev/null"), ("pts.csv", "pts.csv"),
                                 ("the lightmap as this", "lm.prt")):
                pre, outname = CONTEXTS[ctx]
                if pre[pos] == value:
                    continue

                def make(d, pre=pre, outname=outname, pos=pos, value=value):
                    copy_inputs(base, d)
                    args = list(pre) + ["-o", outname]
                    if value == "@fifo":
                        os.mkfifo(d / "fifo.gltf")
                        value = "fifo.gltf"
                    args[pos] = value
                    return args
                expect = "either" if (what == "TRANSFER" and value == "lm.prt" and ctx == "relight-lm") else "invalid"
                if pre[pos] == value:
                    continue
                out.append(Case("options", f"{pre[0]} {what} = {label} [{ctx}]", make, expect,
                                tokens=(value + ":" if value else "''", value + " " if value else "''", "fifo.gltf",
                                        what, "'.'", "'" + value + "'")))
    # The issue's combinations.
    case("--lightmap 16384x16384", "vertex", ["--lightmap", "16384x16384"], "either", ("--lightmap", "16384"),
         rss=COST_RSS_MB, note="cost")
    out[-1].make = (lambda d: (copy_inputs(base, d), ["precompute", "scene.gltf", "--lightmap", "16384x16384",
                                                      "--samples", "4", "--bands", "1", "-q", "-o", "out.prt"])[1])
    for size, limit, expect in (("8192x8192", "100M", "invalid"), ("16384x16384", "100M", "invalid"),
                                ("16384x16384", "1G", "invalid"), ("4096x4096", "10M", "invalid"),
                                ("64x64", "1K", "invalid")):
        c = case(f"--lightmap {size} --memory-limit {limit}", "vertex", [], expect, ("--memory-limit", "memory"),
                 rss=COST_RSS_MB)
        c.make = (lambda size, limit: lambda d: (copy_inputs(base, d), [
            "precompute", "scene.gltf", "--lightmap", size, "--memory-limit", limit, "--samples", "4", "--bands", "1",
            "-q", "-o", "out.prt"])[1])(size, limit)
    for ctx in ("probes", "wavelet"):
        case(f"--memory-limit 1G with {ctx}", ctx, ["--memory-limit", "1G"], "invalid", ("--memory-limit",))
    case("--memory-limit 1G with --lightmap (valid)", "lightmap", ["--memory-limit", "1G"], "valid", ())
    # One path for two outputs, and outputs over inputs.
    lm_outputs = ["-o", "--ao-map", "--bent-normal-map", "--obscurance-map"]
    for a, b in itertools.combinations(lm_outputs, 2):
        for spelling in ("same", "dot-slash", "link"):
            def make(d, a=a, b=b, spelling=spelling):
                copy_inputs(base, d)
                args = ["precompute", "scene.gltf", "--lightmap", "8x8", "--samples", "4", "--bands", "1", "-q",
                        "--obscurance", "0.5"]
                given = {o: f"{o.strip('-')}.exr" for o in lm_outputs}
                given["-o"] = "out.prt"
                second = given[a] if spelling == "same" else ("./" + given[a] if spelling == "dot-slash" else
                                                               "alias" + given[b][-4:])  # b's own extension
                if spelling == "link":
                    (d / second).symlink_to(given[a])
                given[b] = second
                for o in lm_outputs:
                    args += [o, given[o]]
                return args
            # Through a link, an atomic write replaces the link and clobbers nothing: either.
            out.append(Case("options", f"{a} and {b} name one file ({spelling})", make,
                            "either" if spelling == "link" else "invalid", tokens=(a, b)))
    for a, b, ctx, extra in (("-o", "--subdivided-mesh", "subdivide", []), ("-o", "--matrices", "export-probes", [])):
        for spelling in ("same", "dot-slash"):
            def make(d, a=a, b=b, ctx=ctx, spelling=spelling):
                copy_inputs(base, d)
                pre, outname = CONTEXTS[ctx]
                return list(pre) + ["-o", outname, b, outname if spelling == "same" else "./" + outname]
            out.append(Case("options", f"{a} and {b} name one file ({spelling}) [{ctx}]", make, "invalid",
                            tokens=(a, b, "--output")))
    over_inputs = [("lightmap", "-o", "scene.gltf"), ("lightmap", "-o", "scene.bin"), ("lightmap", "-o", "tex.png"),
                   ("lightmap", "--ao-map", "scene.gltf"), ("lightmap", "--ao-map", "env.hdr"),
                   ("subdivide", "--subdivided-mesh", "mesh.obj"), ("subdivide", "-o", "mesh.obj"),
                   ("relight-lm", "-o", "lm.prt"), ("relight-lm", "-o", "env.hdr"), ("relight-at", "-o", "pts.csv"),
                   ("relight-at", "-o", "probes.prt"), ("reference-at", "-o", "pts.csv"),
                   ("export-probes", "-o", "probes.prt"), ("export-probes", "--matrices", "probes.prt"),
                   ("export-probes", "--matrices", "env.hdr"), ("export-lm", "-o", "lm.prt"),
                   ("export-lm", "-o", "scene.gltf"), ("vertex", "-o", "mesh.obj")]
    for ctx, opt, target in over_inputs:
        def make(d, ctx=ctx, opt=opt, target=target):
            copy_inputs(base, d)
            pre, outname = CONTEXTS[ctx]
            args = list(pre)
            if opt == "-o":
                return args + ["-o", target]
            extra = ["--obscurance", "0.5"] if opt == "--obscurance-map" else []
            return args + ["-o", outname, opt, target] + extra
        expect = "either" if target in ("scene.bin", "tex.png") else "invalid"
        out.append(Case("options", f"{opt} writes over the input {target} [{ctx}]", make, expect,
                        tokens=(opt, target, "--output")))
    return out


GENERATORS["options"] = options_cases


# ----------------------------------------------------------------------------
# Query points (prt relight --at, prt reference --at): every field x every
# bad number, and the file's structure.

POINT_FIELDS = ["x", "y", "z", "nx", "ny", "nz"]
GOOD_POINT = ["0.1", "0.3", "0.2", "0", "1", "0"]


def point_values(field):
    normal = field.startswith("n")
    out = [("nan", "nan", "invalid"), ("NaN", "NaN", "invalid"), ("-nan", "-nan", "invalid"),
           ("inf", "inf", "invalid"), ("-inf", "-inf", "invalid"), ("Infinity", "Infinity", "invalid"),
           ("1e309 (overflows)", "1e309", "invalid"), ("-1e999", "-1e999", "invalid"), ("empty", "", "invalid"),
           ("space", " ", "invalid"), ("letters", "abc", "invalid"), ("two numbers", "1 2", "invalid"),
           ("trailing junk", "1x", "invalid"), ("underscore", "1_0", "invalid"), ("hex float", "0x1p-3", "either"),
           ("underflow", "1e-400", "either"), ("plus sign", "+0.5", "either"), ("quoted", '"0.5"', "either"),
           ("padded", " 0.5 ", "either"), ("minus zero", "-0", "either" if normal else "valid")]
    if normal:
        out += [("1e13 (a direction)", "1e13", "either"), ("1e300", "1e300", "either"),
                ("1.7e308", "1.7e308", "either"), ("denormal", "4.9e-324", "either")]
    else:
        out += [("1e12 (the limit)", "1e12", "either"), ("1.0000001e12", "1.0000001e12", "invalid"),
                ("-1e13", "-1e13", "invalid"), ("1e13", "1e13", "invalid"), ("1e300", "1e300", "invalid"),
                ("1.7976931348623157e308", "1.7976931348623157e308", "invalid"), ("-1.7e308", "-1.7e308", "invalid"),
                ("1e11 (far outside the volume)", "1e11", "either"), ("denormal", "4.9e-324", "valid")]
    return out


def points_cases(base, py):
    out = []
    env, scene = base.path("env.hdr"), base.path("scene.gltf")

    def commands(d, f):
        return {"relight": ["relight", scene, base.path("probes.prt"), env, "--at", f, "-q", "-o", d / "out.csv"],
                "reference": ["reference", scene, env, "--at", f, "--samples", "4", "-q", "-o", d / "out.csv"]}

    def add(name, text, expect, which=("relight", "reference"), rss=None, timeout=None):
        for cmd in which:
            def make(d, text=text, cmd=cmd):
                f = d / "points.csv"
                data = text() if callable(text) else text
                f.write_bytes(data if isinstance(data, bytes) else data.encode())
                return commands(d, f)[cmd]
            out.append(Case("points", f"{name} [{cmd} --at]", make, expect, tokens=("points.csv", "--at"),
                            rss_mb=rss, timeout=timeout))
    head = ",".join(POINT_FIELDS) + "\n"
    # Both commands read the points the same way: each value goes to one of
    # them, in turn (each field meets both).
    for k, field in enumerate(POINT_FIELDS):
        for i, (label, value, expect) in enumerate(point_values(field)):
            row = list(GOOD_POINT)
            row[k] = value
            add(f"{field} = {label} ({value!r})", head + "0,0.3,0,0,1,0\n" + ",".join(row) + "\n", expect,
                (("relight", "reference")[(i + k) % 2],))
    for label, n, expect in (("zero normal", ["0", "0", "0"], "invalid"), ("minus-zero normal", ["-0", "-0", "-0"], "invalid"),
                             ("tiny normal 1e-30", ["1e-30", "0", "0"], "either"),
                             ("denormal normal", ["4.9e-324", "0", "0"], "either"),
                             ("huge normal 1e300 each", ["1e300", "1e300", "1e300"], "either"),
                             ("unnormalised (3, 4, 0)", ["3", "4", "0"], "valid"),
                             ("all three 1e-320", ["1e-320", "1e-320", "1e-320"], "either")):
        add(f"normal {label}", head + "0.1,0.3,0.2," + ",".join(n) + "\n", expect)
    good = "0.1,0.3,0.2,0,1,0\n"
    structure = [
        ("no header", good * 2, "invalid"), ("header only", head, "either"), ("empty file", "", "invalid"),
        ("header x,y,z only", "x,y,z\n0.1,0.3,0.2\n", "invalid"), ("header reordered", "nx,ny,nz,x,y,z\n0,1,0,0.1,0.3,0.2\n",
                                                                    "either"),
        ("header with an extra column", head.strip() + ",w\n0.1,0.3,0.2,0,1,0,7\n", "either"),
        ("header upper case", head.upper() + good, "either"), ("header with spaces", "x, y, z, nx, ny, nz\n" + good, "either"),
        ("a row of 5 fields", head + "0.1,0.3,0.2,0,1\n", "invalid"),
        ("a row of 7 fields", head + "0.1,0.3,0.2,0,1,0,5\n", "invalid"),
        ("CRLF line ends", (head + good * 2).replace("\n", "\r\n"), "valid"), ("no final newline", head + good.strip(), "valid"),
        ("blank lines between", head + good + "\n\n" + good, "either"), ("BOM", "\ufeff" + head + good, "either"),
        ("semicolons", head.replace(",", ";") + good.replace(",", ";"), "invalid"),
        ("NUL inside", (head + good).replace("0.3", "0\x003"), "invalid"),
        ("UTF-16", (head + good).encode("utf-16"), "invalid"),
        ("invalid UTF-8", head.encode() + b"0.1,\xff\xfe,0.2,0,1,0\n", "invalid"),
        ("a 10 MB line", head + "0." + "1" * 10 ** 7 + ",0.3,0.2,0,1,0\n", "either"),
        ("a 10 MB field of digits before the point", head + "1" * 10 ** 7 + ",0.3,0.2,0,1,0\n", "invalid"),
        ("relight's output (point,r,g,b) as input", "point,r,g,b\n0,0.1,0.2,0.3\n", "invalid"),
        ("a vertex CSV (vertex,r,g,b)", "vertex,r,g,b\n0,0.1,0.2,0.3\n", "invalid"),
        ("comment line", head + "# note\n" + good, "either"), ("quoted fields", head + '"0.1","0.3","0.2","0","1","0"\n', "either"),
    ]
    for name, text, expect in structure:
        add(name, text, expect)
    # Many points: bounded time and memory whatever the answer.
    rows = lambda n: head + "".join("%g,%g,%g,0,1,0\n" % ((i % 97) / 50.0 - 0.97, 0.05 + (i % 13) / 10.0,  # noqa
                                                         (i % 89) / 45.0 - 0.98) for i in range(n))
    add("100000 points", lambda: rows(10 ** 5), "either", ("relight",), rss=COST_RSS_MB)
    add("1000000 points", lambda: rows(10 ** 6), "either", ("relight",), rss=COST_RSS_MB)
    add("10000 points", lambda: rows(10 ** 4), "either", ("reference",), rss=COST_RSS_MB)
    return out


GENERATORS["points"] = points_cases


# ----------------------------------------------------------------------------
# The Python module: each case a fresh interpreter running one call.

PY_PRELUDE = """
import sys
try:
    import numpy as np
    import prt
except BaseException as e:
    print("HOSTILE-IMPORT-FAILED: %r" % (e,), file=sys.stderr)
    sys.exit(5)
W = {work!r}
def scene():
    return prt.load_scene(W + "/scene.gltf")
def mesh():
    return prt.load_mesh(W + "/mesh.obj")
def probes():
    return prt.read_probes(W + "/probes.prt")
def transfer():
    return prt.read_transfer(W + "/mesh.prt")
P = np.array([[0.1, 0.3, 0.2], [0.5, 0.1, 0.5]], dtype=np.float32)
N = np.array([[0, 1, 0], [1, 0, 0]], dtype=np.float32)
def call():
{body}
try:
    call()
except prt.Error as e:
    print("PYREFUSED: prt.Error: %s" % (e,), file=sys.stderr)
    sys.exit(1)
except (ValueError, TypeError, OverflowError) as e:
    print("PYREFUSED: %s: %s" % (type(e).__name__, e), file=sys.stderr)
    sys.exit(1)
except MemoryError as e:
    print("MemoryError: %s" % (e,), file=sys.stderr)
    sys.exit(4)
except BaseException as e:
    import traceback
    traceback.print_exc()
    print("internal error (not prt.Error): %s: %s" % (type(e).__name__, e), file=sys.stderr)
    sys.exit(3)
"""


def python_cases(base, py):
    python, pythonpath = py["python"], py["pythonpath"]
    env = dict(os.environ, PYTHONPATH=pythonpath)
    try:
        r = subprocess.run([python, "-c", "import numpy, prt"], capture_output=True, text=True, env=env, timeout=120)
    except (OSError, subprocess.TimeoutExpired) as e:
        return f"cannot run {python}: {e}"
    if r.returncode != 0:
        return f"{python} cannot import prt from {pythonpath}: {(r.stderr.strip().splitlines() or ['?'])[-1]}"
    out = []
    work = str(base.dir)

    def add(name, body, expect, tokens=(), rss=None, note=""):
        # A refusal may name the argument as Python spells it or as the command does.
        tokens = tuple(tokens) + tuple("--" + t.replace("_", "-") for t in tokens) + \
            tuple(t.replace("_", " ") for t in tokens)
        code = PY_PRELUDE.format(work=work, body="\n".join("    " + ln for ln in body.strip().splitlines()))
        out.append(Case("python", name, (lambda code: lambda d: code)(code), expect, tokens=tokens, kind="python",
                        rss_mb=rss, note=note or " ; ".join(ln.strip() for ln in body.strip().splitlines())))


    def ints(lo, hi, extra=()):
        vals = [("below", str(lo - 1)), ("above", str(hi + 1)), ("minus-1", "-1"), ("2^64", "2**64"),
                ("-2^63-1", "-2**63-1"), ("nan", "float('nan')"), ("string", "'3'"), ("None", "None")] + list(extra)
        res, seen = [], set()
        for l, v in vals:
            try:
                x = eval(v)
            except Exception:
                x = None
            expect = "either" if isinstance(x, int) and not isinstance(x, bool) and lo <= x <= hi else "invalid"
            if v in seen:
                continue
            seen.add(v)
            res.append((l, v, expect))
        return res
    # precompute(mesh, ...)
    for arg, lo, hi in (("bands", 1, 16), ("samples", 1, 2 ** 24), ("bounces", 0, 64), ("threads", 0, 1024)):
        for label, v, expect in ints(lo, hi):
            if arg == "bands" and label == "None":
                expect = "valid"
            if arg == "samples" and expect == "either":
                continue  # a valid huge sample count only costs time
            extra = ", samples=4" if arg != "samples" else ""
            extra += ", mode='interreflected'" if arg == "bounces" else ""
            add(f"precompute({arg}={label})", f"prt.precompute(mesh(), {arg}={v}{extra})", expect, (arg,))
    for arg, vals in (("albedo", [("-0.1", "-0.1"), ("1.5", "1.5"), ("nan", "float('nan')"), ("inf", "float('inf')"),
                                  ("pair", "(0.5, 0.5)"), ("four", "(0.5,)*4"), ("string", "'x'"),
                                  ("rgb-nan", "(0.5, float('nan'), 0.5)")]),
                      ("offset", [("-1", "-1.0"), ("nan", "float('nan')"), ("inf", "float('inf')"), ("1e300", "1e300")]),
                      ("bounce_tolerance", [("-0.1", "-0.1"), ("1", "1.0"), ("nan", "float('nan')")]),
                      ("seed", [("-1", "-1"), ("2^64", "2**64"), ("nan", "float('nan')")]),
                      ("mode", [("unknown", "'sideways'"), ("empty", "''"), ("number", "1")]),
                      ("material", [("unknown", "'metal'")]), ("basis", [("unknown", "'fourier'")]),
                      ("adaptive", [("-0.5", "-0.5"), ("nan", "float('nan')"), ("2", "2.0"), ("string", "'x'")]),
                      ("verify_adaptive", [("1.5 with adaptive", "1.5, adaptive=0.01"), ("nan", "float('nan')")])):
        for label, v in vals:
            add(f"precompute({arg}={label})", f"prt.precompute(mesh(), samples=4, bands=1, {arg}={v})", "invalid", (arg,))
    for arg, vals in (("cube_res", [("3", "3"), ("0", "0"), ("512", "512"), ("-4", "-4"), ("2^31", "2**31")]),
                      ("threshold", [("-0.1", "-0.1"), ("1", "1.0"), ("nan", "float('nan')")])):
        for label, v in vals:
            add(f"precompute(basis='wavelet', {arg}={label})",
                f"prt.precompute(mesh(), basis='wavelet', {arg}={v})", "invalid", (arg,))
    # precompute_lightmap(scene, w, h, ...)
    for label, v, expect in ints(1, 16384):
        if expect == "either":
            continue
        add(f"precompute_lightmap(width={label})", f"prt.precompute_lightmap(scene(), {v}, 8, samples=4, bands=1)",
            expect, ("width", "lightmap size"))
        add(f"precompute_lightmap(height={label})", f"prt.precompute_lightmap(scene(), 8, {v}, samples=4, bands=1)",
            expect, ("height", "lightmap size"))
    for arg, lo, hi in (("bands", 1, 16), ("uv_set", -1, 7), ("samples", 1, 2 ** 24), ("bounces", 0, 64)):
        for label, v, expect in ints(lo, hi, [("minus-2", "-2")]):
            if expect == "either":
                continue
            extra = "" if arg in ("bands", "samples") else ", samples=4, bands=1"
            extra += ", samples=4" if arg == "bands" else (", bands=1" if arg == "samples" else "")
            add(f"precompute_lightmap({arg}={label})", f"prt.precompute_lightmap(scene(), 8, 8, {arg}={v}{extra})",
                expect, (arg, "UV set") if arg == "uv_set" else (arg,))
    add("precompute_lightmap(mode='x')", "prt.precompute_lightmap(scene(), 8, 8, samples=4, mode='x')", "invalid",
        ("mode",))
    add("precompute_lightmap(16384, 16384)", "prt.precompute_lightmap(scene(), 16384, 16384, samples=4, bands=1)",
        "either", ("width", "memory"), rss=COST_RSS_MB)
    # precompute_probes(scene, dims, ...)
    dims = [("(1,2,2)", "(1, 2, 2)", "invalid"), ("(2,2,1)", "(2, 2, 1)", "invalid"), ("(0,0,0)", "(0, 0, 0)", "invalid"),
            ("(-2,2,2)", "(-2, 2, 2)", "invalid"), ("(1025,2,2)", "(1025, 2, 2)", "invalid"),
            ("(1024,1024,1024)", "(1024, 1024, 1024)", "invalid"), ("(257,256,256)", "(257, 256, 256)", "invalid"),
            ("(2,2)", "(2, 2)", "invalid"), ("(2,2,2,2)", "(2, 2, 2, 2)", "invalid"), ("(2.5,2,2)", "(2.5, 2, 2)", "invalid"),
            ("('2',2,2)", "('2', 2, 2)", "invalid"), ("(2^31,2,2)", "(2**31, 2, 2)", "invalid"),
            ("(2^64,2,2)", "(2**64, 2, 2)", "invalid"), ("(nan,2,2)", "(float('nan'), 2, 2)", "invalid"),
            ("None", "None", "invalid"), ("'2x2x2'", "'2x2x2'", "invalid"), ("5", "5", "invalid"),
            ("{}", "{}", "invalid"), ("generator", "(i for i in (2, 2, 2))", "either"),
            ("numpy int array", "np.array([2, 2, 2])", "valid"), ("list", "[2, 2, 2]", "valid"),
            ("numpy float array", "np.array([2.0, 2.0, 2.0])", "either"), ("numpy uint8 (3,)", "np.array([2, 2, 2], np.uint8)", "valid"),
            ("numpy 2-D", "np.array([[2, 2, 2]])", "invalid"), ("True,2,2", "(True, 2, 2)", "either")]
    for label, v, expect in dims:
        add(f"precompute_probes(dims={label})", f"prt.precompute_probes(scene(), {v})", expect, ("dims", "probe grid"))
    for arg, lo, hi in (("bands", 1, 16), ("bounce_bands", 1, 16), ("bounces", 0, 64)):
        for label, v, expect in ints(lo, hi):
            if expect == "either":
                continue
            mode = ", mode='interreflected'" if arg != "bands" else ""
            add(f"precompute_probes({arg}={label})", f"prt.precompute_probes(scene(), (2, 2, 2), {arg}={v}{mode})",
                expect, (arg,))
    add("precompute_probes(mode='x')", "prt.precompute_probes(scene(), (2, 2, 2), mode='x')", "invalid", ("mode",))
    # Scene.lightmap_uv_set(requested)
    for label, v, expect in ints(-1, 7, [("minus-2", "-2"), ("8", "8")]):
        if label in ("below",):
            continue
        if expect == "either":
            expect = "either"
        add(f"Scene.lightmap_uv_set({label})", f"scene().lightmap_uv_set({v})", expect, ("requested", "UV set"))
    add("Scene.lightmap_uv_set(1) (valid)", "scene().lightmap_uv_set(1)", "valid")
    add("Scene.lightmap_uv_set(2) (a set no object has)", "scene().lightmap_uv_set(2)", "invalid", ("TEXCOORD_2", "2"))
    # ProbeVolume.at(scene, points, normals, sh)
    at = "v = probes(); sh = v.relight(W + '/env.hdr')\n"
    cases_at = [
        ("zero normals", "P", "np.zeros((2, 3), np.float32)", "invalid"),
        ("one zero normal", "P", "np.array([[0, 1, 0], [0, 0, 0]], np.float32)", "invalid"),
        ("minus-zero normal", "P", "np.array([[-0.0, -0.0, -0.0]] * 2, np.float32)", "invalid"),
        ("NaN normal", "P", "np.array([[np.nan, 1, 0]] * 2, np.float32)", "invalid"),
        ("inf normal", "P", "np.array([[np.inf, 1, 0]] * 2, np.float32)", "invalid"),
        ("tiny normal 1e-30", "P", "np.array([[1e-30, 0, 0]] * 2, np.float32)", "either"),
        ("denormal normal", "P", "np.array([[1e-45, 0, 0]] * 2, np.float32)", "either"),
        ("huge normal 3e38", "P", "np.array([[3e38, 3e38, 3e38]] * 2, np.float32)", "either"),
        ("unnormalised normal", "P", "np.array([[0, 5, 0]] * 2, np.float32)", "valid"),
        ("NaN point", "np.array([[np.nan, 0.3, 0.2]] * 2, np.float32)", "N", "invalid"),
        ("inf point", "np.array([[np.inf, 0.3, 0.2]] * 2, np.float32)", "N", "invalid"),
        ("point 1e13", "np.array([[1e13, 0.3, 0.2]] * 2, np.float32)", "N", "invalid"),
        ("point 1e12 (float64)", "np.array([[1e12, 0.3, 0.2]] * 2)", "N", "either"),
        ("point 3e38", "np.array([[3e38, 0.3, 0.2]] * 2, np.float32)", "N", "invalid"),
        ("point 1e300 (float64)", "np.array([[1e300, 0.3, 0.2]] * 2)", "N", "invalid"),
        ("points (N, 2)", "P[:, :2]", "N", "invalid"), ("normals (N, 2)", "P", "N[:, :2]", "invalid"),
        ("points 1-D", "P[0]", "N[0]", "either"), ("fewer normals", "P", "N[:1]", "invalid"),
        ("no points (0, 3)", "P[:0]", "N[:0]", "either"), ("points as lists", "P.tolist()", "N.tolist()", "either"),
        ("int points", "P.astype(np.int64)", "N", "either"), ("string points", "'abc'", "N", "invalid"),
        ("None normals", "P", "None", "invalid"), ("object array", "np.array([[1, 'a', 2]], dtype=object)", "N[:1]",
                                                   "invalid"),
        ("non-contiguous points", "np.repeat(P, 2, axis=1)[:, ::2]", "N", "valid"),
        ("float16 points", "P.astype(np.float16)", "N", "either"),
    ]
    for label, pts, nrm, expect in cases_at:
        add(f"ProbeVolume.at: {label}", at + f"v.at(scene(), {pts}, {nrm}, sh)", expect, ("normal", "point", "at"))
    for label, shv, expect in (("sh of 2 bands", "sh[:, :4]", "invalid"), ("sh NaN", "sh * np.nan", "either"),
                               ("sh of another volume size", "sh[:2]", "invalid"), ("sh None", "None", "invalid"),
                               ("sh (P, 9)", "sh[:, :, 0]", "invalid")):
        add(f"ProbeVolume.at: {label}", at + f"v.at(scene(), P, N, {shv})", expect, ("sh",))
    add("ProbeVolume.at: another scene (the mesh)", at + "v.at(prt.load_scene(W + '/mesh.obj'), P, N, sh)", "invalid",
        ("scene", "hash"))
    add("ProbeVolume.at: 1000000 points", at + "Q = np.tile(P, (500000, 1)); M = np.tile(N, (500000, 1))\n"
        "v.at(scene(), Q, M, sh)", "either", rss=COST_RSS_MB)
    for label, v in (("-1", "-1"), ("17", "17"), ("0", "0"), ("2^64", "2**64"), ("nan", "float('nan')")):
        add(f"ProbeVolume.matrices(in_bands={label})", f"probes().matrices(in_bands={v})",
            "invalid", ("in_bands", "bands"))
    for label, rot in (("nan", "(float('nan'), 0, 0)"), ("two", "(1, 2)"), ("inf", "(float('inf'), 0, 0)")):
        add(f"ProbeVolume.relight(rotate={label})", f"probes().relight(W + '/env.hdr', rotate={rot})", "invalid",
            ("rotate",))
    # export_probes(probes, scene, bake, path, matrices=...)
    ep = "import shutil, os, tempfile\nD = tempfile.mkdtemp()\nshutil.copy(W + '/probes.prt', D)\n" \
         "shutil.copy(W + '/env.hdr', D)\n"
    exports = [
        ("matrices over its own output", "D + '/o.json'", "D + '/o.json'", "invalid"),
        ("matrices over its own output (./ spelling)", "D + '/o.json'", "D + '/./o.json'", "invalid"),
        ("matrices over the probe file", "D + '/o.json'", "D + '/probes.prt'", "invalid"),
        ("output over the probe file", "D + '/probes.prt'", "D + '/m.bin'", "invalid"),
        ("output over the bake map", "D + '/env.hdr'", "None", "invalid"),
        ("matrices over the bake map", "D + '/o.json'", "D + '/env.hdr'", "invalid"),
        ("output ''", "''", "None", "invalid"), ("matrices ''", "D + '/o.json'", "''", "invalid"),
        ("output a directory", "D", "None", "invalid"), ("output in a missing directory", "D + '/no/o.json'", "None",
                                                        "invalid"),
        ("valid", "D + '/o.json'", "D + '/m.bin'", "valid"),
    ]
    for label, path, mats, expect in exports:
        add(f"export_probes: {label}", ep + f"prt.export_probes(D + '/probes.prt', scene(), D + '/env.hdr', {path}, "
            f"matrices={mats})", expect, ("path", "matrices", "output", "probes", "bake", "/o.json", "env.hdr"))
    for label, v in (("0", "0"), ("17", "17"), ("-1", "-1"), ("2^64", "2**64")):
        add(f"export_probes(matrix_bands={label})", ep + "prt.export_probes(D + '/probes.prt', scene(), D + '/env.hdr', "
            f"D + '/o.json', matrices=D + '/m.bin', matrix_bands={v})", "invalid", ("matrix_bands",))
    # compress(transfer, ...)
    for arg, lo, hi in (("rotations", 1, 4096), ("eyes", 1, 4096), ("clusters", 1, 2 ** 24), ("pca", 0, 2 ** 20),
                        ("iterations", 1, 1000), ("glossy_clusters", 1, 2 ** 24)):
        for label, v, expect in ints(lo, hi):
            if expect == "either":
                continue
            extra = "" if arg in ("clusters", "pca") else ", clusters=2, pca=2"
            extra += ", pca=2" if arg == "clusters" else (", clusters=2" if arg == "pca" else "")
            add(f"compress({arg}={label})", f"prt.compress(transfer(), {arg}={v}{extra})", expect, (arg,))
    for label, v in (("8", "8"), ("0", "0"), ("64", "64"), ("-16", "-16")):
        add(f"compress(weights={label})", f"prt.compress(transfer(), clusters=2, pca=2, weights={v})", "invalid",
            ("weights",))
    for label, v in (("0", "0"), ("1", "1.0"), ("nan", "float('nan')"), ("-0.1", "-0.1")):
        add(f"compress(target_error={label})", f"prt.compress(transfer(), target_error={v}, mesh=mesh(), "
            "envs=[W + '/env.hdr'], rotations=1)", "invalid", ("target_error",))
    add("compress(rotations=4097) with target_error", "prt.compress(transfer(), target_error=0.5, mesh=mesh(), "
        "envs=[W + '/env.hdr'], rotations=4097)", "invalid", ("rotations",))
    add("compress(statistic='x')", "prt.compress(transfer(), clusters=2, pca=2, statistic='x')", "invalid",
        ("statistic",))
    add("compress(metric='x')", "prt.compress(transfer(), clusters=2, pca=2, metric='x')", "invalid", ("metric",))
    # A few more of the SH core with band counts past the limit.
    for label, call, expect in (("project(bands=65)", "prt.project(W + '/env.hdr', 65)", "invalid"),
                                ("project(bands=0)", "prt.project(W + '/env.hdr', 0)", "invalid"),
                                ("project(bands=2^31)", "prt.project(W + '/env.hdr', 2**31)", "invalid"),
                                ("sh_eval(bands=0)", "prt.sh_eval(0, np.array([[0, 0, 1.0]]))", "invalid"),
                                ("sh_eval(bands=65)", "prt.sh_eval(65, np.array([[0, 0, 1.0]]))", "invalid"),
                                ("sh_eval(zero direction)", "prt.sh_eval(3, np.zeros((1, 3)))", "invalid"),
                                ("sh_eval(NaN direction)", "prt.sh_eval(3, np.array([[np.nan, 0, 1.0]]))", "invalid"),
                                ("rotate_sh(NaN rotation)", "prt.rotate_sh(np.zeros((9, 3)), (float('nan'), 0, 0))",
                                 "invalid"),
                                ("rotate_sh(not a square count)", "prt.rotate_sh(np.zeros((8, 3)), (10, 0, 0))",
                                 "invalid"),
                                ("rotate_sh(non-orthogonal matrix)", "prt.rotate_sh(np.zeros((9, 3)), np.eye(3) * 2)",
                                 "invalid")):
        add(label, call, expect, ("bands", "dirs", "direction", "rotation", "coeffs", "matrix"))
    return out


GENERATORS["python"] = python_cases


# ----------------------------------------------------------------------------
# The driver.

def find_prt():
    for p in (REPO / "build" / "prt", REPO / "build" / "tools" / "prt" / "prt"):
        if p.is_file() and os.access(p, os.X_OK):
            return str(p)
    build = REPO / "build"
    if build.is_dir():
        for root, _, files in os.walk(build):
            if "prt" in files and os.access(os.path.join(root, "prt"), os.X_OK) and \
                    os.path.isfile(os.path.join(root, "prt")):
                return os.path.join(root, "prt")
    return None


def find_python(prt):
    """The interpreter the module was built for (CMakeCache) and its PYTHONPATH."""
    build = pathlib.Path(prt).resolve().parent
    for _ in range(3):
        if (build / "CMakeCache.txt").exists():
            break
        build = build.parent
    python = "/usr/bin/python3"
    cache = build / "CMakeCache.txt"
    if cache.exists():
        for line in cache.read_text(errors="replace").splitlines():
            if line.startswith("Python3_EXECUTABLE:"):
                python = line.split("=", 1)[1].strip() or python
    return python, str(build / "python")


def generate(classes, base, py):
    out = []
    for cls in classes:
        if cls == "gltf-invalid":
            out += GltfCases(base).cases()
        elif cls in GENERATORS:
            made = GENERATORS[cls](base, py)
            if isinstance(made, str):
                print(f"note: class {cls} skipped: {made}", file=sys.stderr)
                continue
            out += made
    return out


def repro(r):
    """The case's command line, to paste as it is (its inputs stay in the case's directory)."""
    env = "".join(f"{k}={shlex.quote(v)} " for k, v in r.env.items())
    return f"cd {shlex.quote(str(r.cwd))} && " + env + shlex.join(r.argv)


def main(argv=None):
    ap = argparse.ArgumentParser(description="Hostile inputs against prt (issue 45)", epilog=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--prt", help="the prt command (default: found under build/)")
    ap.add_argument("--class", dest="classes", action="append", choices=CLASSES,
                    help="run this class only (repeatable)")
    ap.add_argument("--limit", type=int, default=0, help="at most N cases per class (spread over the class)")
    ap.add_argument("--jobs", type=int, default=2, help="cases run at once (default 2)")
    ap.add_argument("--out", help="directory for cases.csv and the inputs (default: a new temporary directory)")
    ap.add_argument("--timeout", type=float, default=DEFAULT_TIMEOUT, help="seconds per case (default 20)")
    ap.add_argument("--memory-cap", type=float, default=DEFAULT_CAP_GB, help="address-space cap per case, GiB (4)")
    ap.add_argument("--python", help="interpreter for the python class (default: the one CMake built prt's module for)")
    ap.add_argument("--list", action="store_true", help="list the cases and exit")
    ap.add_argument("--quiet", action="store_true", help="no progress line")
    args = ap.parse_args(argv)
    prt = args.prt or find_prt()
    if not prt:
        print("hostile_inputs.py: no prt command under build/ (give --prt)", file=sys.stderr)
        return 2
    for attempt in range(6):  # the shared build may be mid-rebuild
        if os.path.isfile(prt) and os.access(prt, os.X_OK):
            break
        print(f"waiting for {prt} (missing: mid-rebuild?)", file=sys.stderr)
        time.sleep(30)
    prt = os.path.abspath(prt)
    out = pathlib.Path(args.out or tempfile.mkdtemp(prefix="prt-hostile-")).resolve()
    work = out / "work"
    work.mkdir(parents=True, exist_ok=True)
    classes = args.classes or CLASSES
    python, pythonpath = find_python(prt)
    if args.python:
        python = args.python
    base = Base(work, prt)
    base.setup()  # the generators read the base files (probe volumes) and prt's --help
    py = {"python": python, "pythonpath": pythonpath, "runner_ok": None}
    cases = generate(classes, base, py)
    by_class = collections.OrderedDict((c, []) for c in classes)
    for c in cases:
        by_class.setdefault(c.cls, []).append(c)
    selected = []
    for cls, lst in by_class.items():
        if args.limit and len(lst) > args.limit:
            step = len(lst) / args.limit
            lst = [lst[int(i * step)] for i in range(args.limit)]
        for i, c in enumerate(lst):
            c.id = f"{cls}-{i:05d}"
        selected += lst
    if args.list:
        for c in selected:
            print(f"{c.id}\t{c.expect}\t{c.name}")
        return 0
    runner = Runner(prt, work, args.timeout, int(args.memory_cap * 2 ** 30), python, pythonpath)
    results, done, t0 = [], 0, time.monotonic()
    lock = threading.Lock()

    def one(c):
        try:
            return runner.run(c)
        except Exception as e:  # a harness failure: report it as a case, not a crash of the run
            r = Result()
            r.case, r.argv, r.env, r.cwd, r.rc, r.sig, r.wall, r.rss_mb = c, [], {}, "", None, None, 0.0, 0.0
            r.outcome, r.message, r.finding, r.stderr = "harness-error", f"{type(e).__name__}: {e}", "", ""
            return r

    with concurrent.futures.ThreadPoolExecutor(max_workers=max(1, args.jobs)) as pool:
        for r in pool.map(one, selected):
            results.append(r)
            with lock:
                done += 1
                if not args.quiet and (done % 25 == 0 or done == len(selected)):
                    el = time.monotonic() - t0
                    print(f"\r{done}/{len(selected)} cases, {el:.0f} s, "
                          f"{sum(1 for x in results if x.finding)} findings", end="", file=sys.stderr, flush=True)
    runner.close()
    if not args.quiet:
        print(file=sys.stderr)
    write_csv(out / "cases.csv", results)
    return report(results, out, time.monotonic() - t0)


def write_csv(path, results):
    with open(path, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["id", "class", "case", "expect", "outcome", "finding", "exit", "signal", "seconds", "peak_rss_mb",
                    "message", "command"])
        for r in results:
            w.writerow([r.case.id, r.case.cls, r.case.name, r.case.expect, r.outcome, r.finding,
                        "" if r.rc is None else r.rc, "" if r.sig is None else r.sig, f"{r.wall:.2f}",
                        f"{r.rss_mb:.0f}", r.message, repro(r) if r.argv else ""])


def report(results, out, seconds):
    cols = OUTCOMES + ["harness-error"]
    print(f"\n{'class':<14}{'cases':>7}" + "".join(f"{c:>10}" for c in cols) + f"{'findings':>10}")
    classes = list(collections.OrderedDict((r.case.cls, 1) for r in results))
    total = collections.Counter()
    for cls in classes:
        rs = [r for r in results if r.case.cls == cls]
        cnt = collections.Counter(r.outcome for r in rs)
        nf = sum(1 for r in rs if r.finding)
        total.update(cnt)
        total["findings"] += nf
        print(f"{cls:<14}{len(rs):>7}" + "".join(f"{cnt[c]:>10}" for c in cols) + f"{nf:>10}")
    print(f"{'all':<14}{len(results):>7}" + "".join(f"{total[c]:>10}" for c in cols) + f"{total['findings']:>10}")
    kinds = collections.Counter(r.finding for r in results if r.finding)
    print("\nfindings by kind: " + (", ".join(f"{k} {v}" for k, v in kinds.most_common()) or "none"))
    # Each finding kind, grouped by what was changed (the part of a case's
    # name before " = ", its surface dropped): the values, and one command.
    for kind in ("crash", "hang", "memory", "accepted-invalid", "valid-refused", "unclear-refusal"):
        rs = [r for r in results if r.finding == kind]
        if not rs:
            continue
        print(f"\n== {kind} ({len(rs)})")
        groups = collections.OrderedDict()
        for r in rs:
            name = re.sub(r" \[[^\]]*\]$", "", r.case.name)
            key, _, value = name.partition(" = ")
            groups.setdefault((r.case.cls, key), []).append((value, r))
        for (cls, key), items in groups.items():
            r = items[0][1]
            what = f"exit {r.rc}" if r.rc is not None else (f"signal {r.sig}" if r.sig else "killed")
            values = sorted(set(v for v, _ in items if v))
            ids = ", ".join(x.case.id for _, x in items[:3]) + (", ..." if len(items) > 3 else "")
            print(f"- [{cls}] {key}" + (f" = {', '.join(values)}" if values else "") + f" ({len(items)} cases: {ids})")
            print(f"    e.g. {r.case.name}: {what}, {r.wall:.1f} s, {r.rss_mb:.0f} MB"
                  + (f"; {r.message[:200]}" if r.message else ""))
            print(f"    {repro(r)}")
            if r.case.kind == "python":
                print(f"    (case.py calls: {r.case.note})")
    errors = [r for r in results if r.outcome == "harness-error"]
    for r in errors:
        print(f"harness error in {r.case.id} {r.case.name}: {r.message}")
    print(f"\n{len(results)} cases in {seconds:.0f} s; every case: {out / 'cases.csv'}")
    return 1 if total["findings"] else (2 if errors else 0)


if __name__ == "__main__":
    sys.exit(main())
