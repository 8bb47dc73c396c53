#!/usr/bin/env bash
# Seams at low resolution: does a 64 x 64 lightmap of models/room.gltf show
# bright lines along the wall-ceiling and wall-floor seams? (Its charts' edges
# fall on texel centres at 64 x 64, half the 128 x 128 they were packed for.)
# For each wall, the mean radiance (mean of R, G, B) of its texels in the row
# along the seam (row 0: the texel centres within half a texel of the seam
# edge in UV), one and two rows inward, and the same rows of the ceiling's
# (floor's) texels on the other side of that seam; then the step row 0 / row 1,
# of ours (prt precompute + relight, 5 bands, 1024 rays, and 16384 rays to
# tell the rays' noise from a bias: one direction set serves every texel, so
# a row's texels share their error) against that of
# prt reference --lightmap (16384 samples a texel; the step's standard error
# from the reference's se channels). Texels within a texel of a seam's ends
# (the room's corners) are left out. Shadowed and interreflected, under a
# constant map (radiance 1) and envmaps/sunset.exr. Also the whole lightmap's
# rel_rms_noise_corrected (prt compare --json).
# Rows come from the scene's TEXCOORD_1 (glTF JSON and buffers parsed with
# numpy); the EXRs are read by a small numpy reader (scanline, zip/none).
# Usage: bash scripts/lightmap_seam_step.sh [BUILD_DIR]  (~2 min on 2 shared cores)
#   SEAM_REF_BUILD=DIR takes the reference from DIR/prt (e.g. an old build against the current
#   reference); SEAM_SIZE (64) and SEAM_REF_SAMPLES (16384) change the atlas and the reference.
set -euo pipefail
cd "$(dirname "$0")/.."
prt="${1:-build}/prt"
# SEAM_REF_BUILD=DIR: make the reference with DIR/prt instead (an older build's lightmap against
# the current build's reference, at the same texels but the current sample points).
ref_prt="${SEAM_REF_BUILD:-${1:-build}}/prt"
scene=models/room.gltf
size=${SEAM_SIZE:-64}
refs=${SEAM_REF_SAMPLES:-16384}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
py=/usr/bin/python3
# A constant map of radiance 1 (SH is exact under it).
$py scripts/constant_map.py "$work/constant.hdr"

cat > "$work/seam.py" <<'EOF'
import base64, json, os, struct, sys, zlib
import numpy as np

def read_exr(path):
    """Scanline EXR (compression none, zips or zip; half or float) -> {channel: H x W array}."""
    b = open(path, 'rb').read()
    assert struct.unpack_from('<I', b, 0)[0] == 20000630, path
    p = 8; attrs = {}
    while b[p] != 0:
        e = b.index(b'\0', p); name = b[p:e].decode(); p = e + 1
        e = b.index(b'\0', p); typ = b[p:e].decode(); p = e + 1
        n = struct.unpack_from('<i', b, p)[0]; p += 4
        attrs[name] = b[p:p + n]; p += n
    p += 1
    chans = []; cb = attrs['channels']; q = 0
    while cb[q] != 0:
        e = cb.index(b'\0', q); chans.append((cb[q:e].decode(), struct.unpack_from('<i', cb, e + 1)[0])); q = e + 17
    comp = attrs['compression'][0]
    assert comp in (0, 2, 3), 'EXR compression %d not read' % comp
    x0, y0, x1, y1 = struct.unpack('<4i', attrs['dataWindow'])
    W, H = x1 - x0 + 1, y1 - y0 + 1
    lines = 16 if comp == 3 else 1
    offs = struct.unpack_from('<%dQ' % ((H + lines - 1) // lines), b, p)
    size = {0: 4, 1: 2, 2: 4}; dts = {0: '<u4', 1: '<f2', 2: '<f4'}
    out = {nm: np.zeros((H, W), np.float64) for nm, _ in chans}
    for o in offs:
        y, n = struct.unpack_from('<ii', b, o); data = b[o + 8:o + 8 + n]
        ny = min(lines, y1 + 1 - y)
        if comp and n < sum(size[pt] for _, pt in chans) * W * ny:
            t = np.frombuffer(zlib.decompress(data), np.uint8).astype(np.int64)
            t = (np.cumsum(np.concatenate([t[:1], t[1:] - 128])) & 255).astype(np.uint8)
            h = (len(t) + 1) // 2
            u = np.empty_like(t); u[0::2] = t[:h]; u[1::2] = t[h:]
            data = u.tobytes()
        q = 0
        for r in range(ny):
            for nm, pt in chans:
                out[nm][y - y0 + r] = np.frombuffer(data, dts[pt], W, q); q += size[pt] * W
    return out

def load_gltf(path, uvset=1):
    """Objects (named nodes' triangle primitives): name -> (world positions of the triangles' corners, their UVs)."""
    d = json.load(open(path))
    bufs = []
    for bf in d['buffers']:
        uri = bf['uri']
        bufs.append(base64.b64decode(uri.split(',', 1)[1]) if uri.startswith('data:')
                    else open(os.path.join(os.path.dirname(path), uri), 'rb').read())
    def acc(i):
        a = d['accessors'][i]; bv = d['bufferViews'][a['bufferView']]
        n = {'SCALAR': 1, 'VEC2': 2, 'VEC3': 3, 'VEC4': 4}[a['type']]
        dt = {5126: np.float32, 5125: np.uint32, 5123: np.uint16, 5121: np.uint8}[a['componentType']]
        it = np.dtype(dt).itemsize; stride = bv.get('byteStride', 0) or n * it
        off = bv.get('byteOffset', 0) + a.get('byteOffset', 0)
        arr = np.ndarray((a['count'], n), dt, bufs[bv['buffer']], off, (stride, it))
        return arr.astype(np.float64 if dt == np.float32 else np.int64)
    def local(nd):
        if 'matrix' in nd: return np.array(nd['matrix'], float).reshape(4, 4).T
        x, y, z, w = nd.get('rotation', [0, 0, 0, 1])
        R = np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                      [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                      [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])
        M = np.eye(4); M[:3, :3] = R * np.array(nd.get('scale', [1, 1, 1])); M[:3, 3] = nd.get('translation', [0, 0, 0])
        return M
    objs = {}
    def walk(i, parent):
        nd = d['nodes'][i]; M = parent @ local(nd)
        if 'mesh' in nd:
            for pr in d['meshes'][nd['mesh']]['primitives']:
                if pr.get('mode', 4) != 4: continue
                P = acc(pr['attributes']['POSITION']); U = acc(pr['attributes']['TEXCOORD_%d' % uvset])
                I = acc(pr['indices']).reshape(-1, 3) if 'indices' in pr else np.arange(len(P)).reshape(-1, 3)
                Pw = P @ M[:3, :3].T + M[:3, 3]
                objs[nd.get('name', 'node%d' % i)] = (Pw[I], U[I])
        for c in nd.get('children', []): walk(c, M)
    for i in d['scenes'][d.get('scene', 0)]['nodes']: walk(i, np.eye(4))
    return objs

def coverage(uv, W, H, sub=8):
    """Texels any triangle (UV corners, texel units) touches, from sub x sub points a texel."""
    g = (np.arange(W * sub) + 0.5) / sub; h = (np.arange(H * sub) + 0.5) / sub
    X, Y = np.meshgrid(g, h)
    inside = np.zeros(X.shape, bool)
    for a, b, c in uv:
        def e(p, q): return (q[0] - p[0]) * (Y - p[1]) - (q[1] - p[1]) * (X - p[0])
        s0, s1, s2 = e(a, b), e(b, c), e(c, a)
        inside |= ((s0 >= 0) & (s1 >= 0) & (s2 >= 0)) | ((s0 <= 0) & (s1 <= 0) & (s2 <= 0))
    return inside.reshape(H, sub, W, sub).any(axis=(1, 3))

def seam_rows(P, uv, on_seam, W, H, rows=3):
    """Texel (y, x) lists of rows 0..rows-1 from the UV images of the triangle edges that lie on the seam
    (on_seam(point) true at both ends); a texel's row is its centre's distance into the chart from the
    edge, rounded (x.5 down); texels whose centre projects within a texel of the edge's ends are left out."""
    cov = coverage(uv, W, H)
    ys, xs = np.nonzero(cov); C = np.stack([xs + 0.5, ys + 0.5], 1)
    best = np.full(len(C), np.inf)
    for t in range(len(P)):
        for i in range(3):
            j, k = (i + 1) % 3, (i + 2) % 3
            if not (on_seam(P[t][i]) and on_seam(P[t][j])): continue
            a, b, c = uv[t][i], uv[t][j], uv[t][k]
            L = np.linalg.norm(b - a); dvec = (b - a) / L
            n = np.array([-dvec[1], dvec[0]])
            if np.dot(c - a, n) < 0: n = -n
            s = (C - a) @ dvec; dist = (C - a) @ n
            ok = (s > 1) & (s < L - 1) & (dist > -0.5)
            best = np.where(ok & (np.abs(dist) < np.abs(best)), dist, best)
    r = np.ceil(best - 0.5)  # distance (-0.5, 0.5]: row 0 (an edge on texel centres or on texel borders alike)
    return [(ys[r == k], xs[r == k]) for k in range(rows)]

def main():
    scene, W, H = sys.argv[1], int(sys.argv[2]), int(sys.argv[3])
    ours, ref, exact = read_exr(sys.argv[4]), read_exr(sys.argv[5]), read_exr(sys.argv[6]); label = sys.argv[7]
    objs = load_gltf(scene)
    lo = min(P[..., 1].min() for P, _ in objs.values()); hi = max(P[..., 1].max() for P, _ in objs.values())
    val = lambda img: (img['R'] + img['G'] + img['B']) / 3
    o, rf, ox = val(ours), val(ref), val(exact)
    se2 = (ref['se.R'] ** 2 + ref['se.G'] ** 2 + ref['se.B'] ** 2) / 9
    covered = ours['A'] > 0
    for wall in sorted(n for n in objs if n.startswith('wall')):
        Pw, Uw = objs[wall]; Uw = Uw * [W, H]
        # the wall's plane: its normal's horizontal direction
        nrm = np.cross(Pw[0][1] - Pw[0][0], Pw[0][2] - Pw[0][0]); nrm /= np.linalg.norm(nrm)
        d0 = Pw[0][0] @ nrm
        for other, yv in (('ceiling', hi), ('floor', lo)):
            on = lambda p, yv=yv: abs(p[1] - yv) < 1e-4 and abs(p @ nrm - d0) < 1e-4
            for side, (P, U) in ((wall, (Pw, Uw)), (other, (objs[other][0], objs[other][1] * [W, H]))):
                rows = seam_rows(P, U, on, W, H)
                m_o, m_r, m_x, s_r, n = [], [], [], [], []
                for ys, xs in rows:
                    keep = covered[ys, xs]; ys, xs = ys[keep], xs[keep]
                    n.append(len(ys))
                    m_o.append(o[ys, xs].mean() if len(ys) else np.nan)
                    m_r.append(rf[ys, xs].mean() if len(ys) else np.nan)
                    m_x.append(ox[ys, xs].mean() if len(ys) else np.nan)
                    s_r.append(np.sqrt(se2[ys, xs].sum()) / max(len(ys), 1))
                if min(n[:2]) == 0 or m_r[1] <= 0 or m_r[0] <= 0:  # a wall no light reaches (the window's wall, shadowed)
                    steps = '- | - | - | - | -'
                else:
                    st_o = m_o[0] / m_o[1]; st_x = m_x[0] / m_x[1]; st_r = m_r[0] / m_r[1]
                    st_se = st_r * np.hypot(s_r[0] / m_r[0], s_r[1] / m_r[1])
                    steps = '%.3f | %.3f | %.3f +- %.3f | %+.1f | %+.1f' % (st_o, st_x, st_r, st_se, (st_o - st_r) / st_se, (st_x - st_r) / st_se)
                print('| %s | %s-%s | %s | %d | %.3g / %.3g / %.3g | %.3g / %.3g / %.3g | %s |' % (
                    label, wall, other, side, n[0], *m_o, *m_r, steps))
main()
EOF

err() { "$prt" compare "$1" "$2" --json | $py -c 'import json,sys; print("%.2f%%" % (100 * json.load(sys.stdin)["rel_rms_noise_corrected"]))'; }
summary=()
echo "Texel rows along each seam (mean of R, G, B; row 0 = the texels on the seam, then 1 and 2 rows inward),"
echo "${size}x${size}, 5 bands; ours: 1024 rays (rows and step) and 16384 rays (step); reference ${refs} samples a texel."
echo "z = (ours' step - reference's) / the reference step's standard error (ours' own ray noise not included)."
echo
echo "| map, mode | seam | texels of | n | ours rows 0 / 1 / 2 | reference rows 0 / 1 / 2 | ours step 0/1 | ours step, 16384 rays | reference step 0/1 | z | z, 16384 rays |"
echo "|---|---|---|---|---|---|---|---|---|---|---|"
for mode in shadowed interreflected; do
  for s in 1024 16384; do
    "$prt" precompute "$scene" --lightmap "${size}x${size}" --mode "$mode" --bands 5 --samples "$s" -q -o "$work/t$s.prt"
  done
  for map in "$work/constant.hdr" envmaps/sunset.exr; do
    name=$(basename "$map"); name=${name%.*}
    for s in 1024 16384; do "$prt" relight "$scene" "$work/t$s.prt" "$map" -q -o "$work/t$s.exr"; done
    "$ref_prt" reference "$scene" "$map" --lightmap "${size}x${size}" --mode "$mode" --samples "$refs" -q -o "$work/ref.exr"
    $py "$work/seam.py" "$scene" "$size" "$size" "$work/t1024.exr" "$work/ref.exr" "$work/t16384.exr" "$name, $mode"
    summary+=("| $name | $mode | $(err "$work/t1024.exr" "$work/ref.exr") | $(err "$work/t16384.exr" "$work/ref.exr") |")
  done
done
echo
echo "Whole lightmap, relative RMS error against the reference (its noise subtracted):"
echo
echo "| map | mode | 1024 rays | 16384 rays |"
echo "|---|---|---|---|"
printf '%s\n' "${summary[@]}"
