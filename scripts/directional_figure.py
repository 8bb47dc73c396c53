#!/usr/bin/env python3
"""Makes docs/images/lightmap_directional.png: what directional lightmaps do
for a normal-mapped floor (docs/LIGHTMAPS.md "Directional lightmaps").

The floor of models/room.gltf, seen top-down in its own lightmap chart, under
envmaps/sunset.exr (the sun through the window), with a procedural normal map
(a field of round bumps, 8 x 8 over the 4 m floor; the box stands on the
black square). The lightmap: 128 x 128, interreflected, 1024 samples (about
12 s on 2 cores). Four panels, E/pi (the
incident light before the albedo), one exposure and tone curve for all:

  1. the plain (diffuse) lightmap, prt relight's value over the texel's albedo:
     flat, it knows only the texel's own normal;
  2. prt's L1 at the mapped normals, S0 + S1 . n per pixel (exact L1);
  3. Godot 4's packing (L0 and 1/2 + S1 / (8 S0) in half floats), decoded as
     its shader does;
  4. Unity's dominant-direction packing (float colour, 8-bit direction and
     rebalancing), decoded as UnityCG's DecodeDirectionalLightmap does.

Formulas: docs/CONVENTIONS.md "Directional lightmaps". Each packing is made
per texel (as the files are), its stored values filtered bilinearly between
texel centres (as a GPU samples the texture), and decoded per pixel at the
normal map's normal there.

Usage (from the repository root, after building the Python module):

  PYTHONPATH=build/python python3 scripts/directional_figure.py [--out PNG] [--size N]
"""
import argparse
import base64
import io
import json
import math
import os
import sys
import time

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)

Y00 = 0.282095
Y1_A1 = (2.0 / 3.0) * 0.488603  # 0.325735: Y_1 x A_1 / pi


def parse_args():
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--out", default=os.path.join(ROOT, "docs", "images", "lightmap_directional.png"),
                   help="the PNG to write (default: docs/images/lightmap_directional.png)")
    p.add_argument("--size", type=int, default=128, help="the lightmap atlas, N x N texels (default 128)")
    p.add_argument("--samples", type=int, default=1024,
                   help="rays per texel (default 1024: at 256 the plain lightmap's texel noise shows as steps)")
    p.add_argument("--scale", type=int, default=0,
                   help="pixels per lightmap texel in the panels (default 0: about 380 pixels a panel)")
    p.add_argument("--stops", type=float, default=None,
                   help="exposure in stops (default: the sunlit patch of panel 2 just below white)")
    return p.parse_args()


# --- the scene ------------------------------------------------------------

def floor_chart(scene):
    """The floor's vertices (normal y > 0.9 at the lowest such y): the affine
    map from lightmap UV to world (x, z) (a 3 x 2 matrix on (u, v, 1)), the
    map from world (x, z) to TEXCOORD_0 (for the albedo texture), the chart's
    UV bounds and the floor's world bounds."""
    pos = np.asarray(scene.positions, dtype=np.float64)
    nrm = np.asarray(scene.normals, dtype=np.float64)
    up = nrm[:, 1] > 0.9
    y0 = pos[up, 1].min()
    sel = up & (np.abs(pos[:, 1] - y0) < 1e-4)
    uv = np.asarray(scene.uv_sets[scene.lightmap_uv_set()], dtype=np.float64)[sel]
    uv0 = np.asarray(scene.uv_sets[0], dtype=np.float64)[sel]
    xz = pos[sel][:, [0, 2]]
    A = np.c_[uv, np.ones(len(uv))]
    uv_to_xz, *_ = np.linalg.lstsq(A, xz, rcond=None)
    xz_to_uv0, *_ = np.linalg.lstsq(np.c_[xz, np.ones(len(xz))], uv0, rcond=None)
    fit = np.abs(A @ uv_to_xz - xz).max()
    if fit > 1e-3:
        sys.exit(f"the floor's lightmap UVs are not affine in (x, z) (off by {fit:g})")
    return uv_to_xz, xz_to_uv0, uv.min(0), uv.max(0), xz.min(0), xz.max(0)


def floor_albedo_fn(gltf_path):
    """The floor material's albedo at TEXCOORD_0, as prt's Scene::albedo: the
    base colour factor times the base colour texture (sRGB decoded, bilinear
    with texel centres at (i + 1/2) / size, repeat)."""
    from PIL import Image
    g = json.load(open(gltf_path))
    mat = g["materials"][g["meshes"][[n["name"] for n in g["nodes"]].index("floor")]["primitives"][0]["material"]]
    pbr = mat["pbrMetallicRoughness"]
    factor = np.array(pbr.get("baseColorFactor", [1, 1, 1, 1])[:3])
    if "baseColorTexture" not in pbr:
        return lambda uv: np.broadcast_to(factor, uv.shape[:-1] + (3,))
    uri = g["images"][g["textures"][pbr["baseColorTexture"]["index"]]["source"]]["uri"]
    if uri.startswith("data:"):
        data = base64.b64decode(uri.split(",", 1)[1])
    else:
        data = open(os.path.join(os.path.dirname(gltf_path), uri), "rb").read()
    img = np.asarray(Image.open(io.BytesIO(data)).convert("RGB"), dtype=np.float64) / 255.0
    img = np.where(img <= 0.04045, img / 12.92, ((img + 0.055) / 1.055) ** 2.4)
    th, tw = img.shape[:2]

    def sample(uv):
        x = uv[..., 0] * tw - 0.5
        y = uv[..., 1] * th - 0.5
        fx, fy = np.floor(x), np.floor(y)
        ax, ay = (x - fx)[..., None], (y - fy)[..., None]
        x0, y0 = fx.astype(np.int64) % tw, fy.astype(np.int64) % th
        x1, y1 = (x0 + 1) % tw, (y0 + 1) % th
        t = ((1 - ay) * ((1 - ax) * img[y0, x0] + ax * img[y0, x1])
             + ay * ((1 - ax) * img[y1, x0] + ax * img[y1, x1]))
        return np.clip(factor * t, 0.0, 1.0)

    return sample


# --- the normal map -------------------------------------------------------

def bump_normals(x, z, lo, hi, cells=8, radius_frac=0.42, max_tilt_deg=60.0):
    """World normals of a field of cells x cells round bumps over the floor
    [lo, hi] (x, z): cosine domes of radius radius_frac x the cell, steepest
    max_tilt_deg at half the radius. Returns (..., 3)."""
    cell = (hi - lo) / cells
    cx = (np.floor((x - lo[0]) / cell[0]) + 0.5) * cell[0] + lo[0]
    cz = (np.floor((z - lo[1]) / cell[1]) + 0.5) * cell[1] + lo[1]
    dx, dz = x - cx, z - cz
    R = radius_frac * cell.min()
    r = np.hypot(dx, dz)
    # h = a (1 + cos(pi r / R)) / 2 inside R: dh/dr = -a pi / (2R) sin(pi r / R)
    a = math.tan(math.radians(max_tilt_deg)) * 2 * R / math.pi
    slope = np.where(r < R, -a * math.pi / (2 * R) * np.sin(np.pi * np.minimum(r, R) / R), 0.0)
    with np.errstate(invalid="ignore", divide="ignore"):
        gx = np.where(r > 0, slope * dx / r, 0.0)
        gz = np.where(r > 0, slope * dz / r, 0.0)
    n = np.stack([-gx, np.ones_like(gx), -gz], axis=-1)
    return n / np.linalg.norm(n, axis=-1, keepdims=True)


# --- filtering ------------------------------------------------------------

def bilinear(grid, mask, u, v):
    """Samples grid (H, W, ...) at UV (u, v) bilinearly between texel centres
    ((x + 1/2) / W, (y + 1/2) / H), as a GPU's linear filter; texels outside
    `mask` (uncovered: gutters) take no weight (the neighbours' are
    renormalised), as a gutter filled from the chart's edge would give."""
    H, W = mask.shape
    x = u * W - 0.5
    y = v * H - 0.5
    x0, y0 = np.floor(x).astype(np.int64), np.floor(y).astype(np.int64)
    ax, ay = x - x0, y - y0
    out = 0.0
    wsum = 0.0
    for dy, wy in ((0, 1 - ay), (1, ay)):
        for dx, wx in ((0, 1 - ax), (1, ax)):
            xi = np.clip(x0 + dx, 0, W - 1)
            yi = np.clip(y0 + dy, 0, H - 1)
            w = wx * wy * mask[yi, xi]
            w = w.reshape(w.shape + (1,) * (grid.ndim - 2))
            out = out + w * grid[yi, xi]
            wsum = wsum + w
    return out / np.maximum(wsum, 1e-12)


# --- the packings ---------------------------------------------------------

def sh_to_s(c):
    """(..., 4, 3) prt L1 coefficients -> S0 (..., 3), S1 (..., 3 axes, 3 colours)."""
    s0 = Y00 * c[..., 0, :]
    s1 = Y1_A1 * np.stack([-c[..., 3, :], -c[..., 1, :], c[..., 2, :]], axis=-2)
    return s0, s1


def pack_godot(s0, s1):
    """Godot 4: L0 = S0, t_a = clamp(1/2 + S1_a / (8 S0), 0, 1), half floats."""
    with np.errstate(invalid="ignore", divide="ignore"):
        t = np.where(s0[..., None, :] > 0, 0.5 + s1 / (8.0 * s0[..., None, :]), 0.5)
    t = np.clip(t, 0.0, 1.0)
    return s0.astype(np.float16).astype(np.float64), t.astype(np.float16).astype(np.float64)


def decode_godot(l0, t, n):
    return l0 + np.einsum("...ac,...a->...c", 2.0 * t - 1.0, n) * 4.0 * l0


def pack_dominant(s0, s1, N=np.array([0.0, 1.0, 0.0])):
    """Unity's directional mode: float colour S0 + S1 . N; 8-bit
    d = 1/2 + D/2 and w = (1 + D . N) / 2, D = S1m / S0m of length <= 1."""
    colour = s0 + np.einsum("...ac,a->...c", s1, N)
    s0m = s0.sum(-1)
    s1m = s1.sum(-1)
    with np.errstate(invalid="ignore", divide="ignore"):
        D = np.where(s0m[..., None] > 0, s1m / s0m[..., None], 0.0)
    L = np.linalg.norm(D, axis=-1, keepdims=True)
    D = np.where(L > 1.0, D / np.maximum(L, 1e-12), D)
    d = np.round(255.0 * (0.5 + D / 2.0)) / 255.0
    w = np.round(255.0 * (1.0 + D @ N) / 2.0) / 255.0
    return colour, d, w


def decode_dominant(colour, d, w, n):
    half_lambert = np.einsum("...a,...a->...", n, d - 0.5) + 0.5
    return colour * (half_lambert / np.maximum(w, 1e-4))[..., None]


# --- the picture ----------------------------------------------------------

def tone(img, stops):
    lin = np.clip(img * 2.0 ** stops, 0.0, 1.0)
    srgb = np.where(lin <= 0.0031308, 12.92 * lin, 1.055 * lin ** (1 / 2.4) - 0.055)
    return (srgb * 255.0 + 0.5).astype(np.uint8)


def main():
    args = parse_args()
    sys.path.insert(0, os.path.join(ROOT, "build", "python"))
    import prt

    t_start = time.time()
    gltf = os.path.join(ROOT, "models", "room.gltf")
    scene = prt.load_scene(gltf)
    W = H = args.size
    lm = prt.precompute_lightmap(scene, W, H, mode="interreflected", samples=args.samples, directional=True)
    lighting = prt.project(os.path.join(ROOT, "envmaps", "sunset.exr"), lm.bands)
    plain = lm.relight(scene, lighting)                      # (H, W, 4) radiance, gutters filled
    l1 = np.asarray(lm.relight_directional(scene, lighting), dtype=np.float64)  # (N, 4, 3)
    texels = np.asarray(lm.texels)
    t_bake = time.time() - t_start

    uv_to_xz, xz_to_uv0, uv_lo, uv_hi, xz_lo, xz_hi = floor_chart(scene)
    albedo_at = floor_albedo_fn(gltf)

    # The floor's covered texels: covered, and their centre on the floor's chart.
    covered = np.zeros(H * W, bool)
    covered[texels] = True
    covered = covered.reshape(H, W)
    ty, tx = np.mgrid[0:H, 0:W]
    tu, tv = (tx + 0.5) / W, (ty + 0.5) / H
    half = 0.5 / np.array([W, H])
    on_chart = ((tu >= uv_lo[0] - half[0]) & (tu <= uv_hi[0] + half[0])
                & (tv >= uv_lo[1] - half[1]) & (tv <= uv_hi[1] + half[1]))
    mask = (covered & on_chart).astype(np.float64)

    # Per texel: E/pi of the plain lightmap (radiance over the texel's albedo),
    # and the L1 coefficients, in atlas layout.
    txz = np.stack([tu, tv, np.ones_like(tu)], -1) @ uv_to_xz
    tuv0 = np.concatenate([txz, np.ones(txz.shape[:-1] + (1,))], -1) @ xz_to_uv0
    albedo = albedo_at(tuv0)
    with np.errstate(invalid="ignore", divide="ignore"):
        e_plain = np.where(albedo > 1e-3, plain[..., :3] / albedo, 0.0)
    c_grid = np.zeros((H * W, 4, 3))
    c_grid[texels] = l1
    c_grid = c_grid.reshape(H, W, 4, 3)
    s0, s1 = sh_to_s(c_grid)
    g_l0, g_t = pack_godot(s0, s1)
    u_col, u_d, u_w = pack_dominant(s0, s1)

    # The panels' pixels: the chart's texel range, `scale` pixels a texel.
    x0, x1 = int(math.floor(uv_lo[0] * W)), int(math.ceil(uv_hi[0] * W))
    y0, y1 = int(math.floor(uv_lo[1] * H)), int(math.ceil(uv_hi[1] * H))
    scale = args.scale or max(2, round(380 / max(x1 - x0, y1 - y0)))
    py, px = np.mgrid[0:(y1 - y0) * scale, 0:(x1 - x0) * scale]
    u = (x0 + (px + 0.5) / scale) / W
    v = (y0 + (py + 0.5) / scale) / H
    xz = np.stack([u, v, np.ones_like(u)], -1) @ uv_to_xz
    inside = ((xz[..., 0] >= xz_lo[0]) & (xz[..., 0] <= xz_hi[0])
              & (xz[..., 1] >= xz_lo[1]) & (xz[..., 1] <= xz_hi[1]))
    n = bump_normals(xz[..., 0], xz[..., 1], xz_lo, xz_hi)

    c_px = bilinear(c_grid, mask, u, v)
    ps0, ps1 = sh_to_s(c_px)
    panels = [
        ("diffuse lightmap (no normal map)", bilinear(e_plain, mask, u, v)),
        ("prt's L1 at the mapped normals", ps0 + np.einsum("...ac,...a->...c", ps1, n)),
        ("Godot 4 (half-float L1)",
         decode_godot(bilinear(g_l0, mask, u, v), bilinear(g_t, mask, u, v), n)),
        ("Unity dominant direction",
         decode_dominant(bilinear(u_col, mask, u, v), bilinear(u_d, mask, u, v),
                         bilinear(u_w, mask, u, v), n)),
    ]

    # Exposure, in quarter stops: the brightest 0.5% of panel 2's floor (the
    # sunlit patch) just below white (0.8 to 0.95 of it), nothing flat-clipped.
    ref = panels[1][1][inside].max(-1)
    stops = args.stops
    if stops is None:
        stops = math.floor(4 * math.log2(0.95 / np.percentile(ref, 99.5))) / 4
    for name, img in panels:
        vals = img[inside]
        print(f"{name}: mean {vals.mean():.4f}, 99.5th pct {np.percentile(vals.max(-1), 99.5):.4f}, "
              f"clipped {np.mean((vals * 2 ** stops).max(-1) >= 1):.2%}")

    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 4, figsize=(16, 4.5), dpi=100)
    for ax, (name, img) in zip(axes, panels):
        rgb = tone(np.where(inside[..., None], img, 0.0), stops)
        ax.imshow(rgb, interpolation="nearest")
        ax.set_title(name, fontsize=13)
        ax.set_axis_off()
    fig.text(0.5, 0.025,
             f"room.gltf's floor in its {W}x{H} lightmap chart ({scale} px a texel; interreflected, "
             f"{args.samples} samples), sunset.exr, "
             f"E/pi (before the albedo), 2^{stops:g} x linear, clamped, sRGB",
             ha="center", fontsize=10, color="0.3")
    fig.subplots_adjust(left=0.01, right=0.99, top=0.9, bottom=0.08, wspace=0.04)
    out = os.path.abspath(args.out)
    os.makedirs(os.path.dirname(out), exist_ok=True)
    tmp = out + ".tmp.png"
    fig.savefig(tmp, dpi=100)
    plt.close(fig)
    os.replace(tmp, out)
    print(f"wrote {out} ({os.path.getsize(out):,} bytes); exposure {stops:g} stops; "
          f"bake {t_bake:.1f} s, total {time.time() - t_start:.1f} s")


if __name__ == "__main__":
    main()
