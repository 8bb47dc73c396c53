#!/usr/bin/env python3
"""Plots of `prt report` (docs/REPORT.md).

`prt report` embeds this script, writes it beside its results as plots.py and
runs it: python3 plots.py DIR. It reads DIR/report.csv and DIR/report.json
(written by prt, which also did every computation: errors, the Pareto front,
the fitted slopes) and draws:
  error_vs_time.png      error against precompute time, Pareto front marked
  error_vs_settings.png  error against SH bands and against wavelet terms K
  error_vs_samples.png   log-log error against samples with the fitted slope
  compression.png        clustered PCA: bytes per vertex against relit error (log-log, Pareto
                         front as a line) and GPU frame time against relit error
  images.png             the reference, a few settings, their error heat maps
Needs matplotlib and numpy (Debian: python3-matplotlib, python3-numpy).
"""
import csv
import json
import os
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.colors import LogNorm  # noqa: E402

SWEEP_STYLE = {
    "bands": ("SH bands", "tab:blue", "o"),
    "samples": ("SH samples", "tab:orange", "s"),
    "bounces": ("SH bounces (vs interreflected ref.)", "tab:green", "^"),
    "terms": ("wavelet K", "tab:purple", "D"),
}


def read_rows(path):
    with open(path, newline="") as f:
        rows = list(csv.DictReader(f))
    for r in rows:
        for k, v in r.items():
            if k in ("sweep", "basis", "reference"):
                continue
            r[k] = float(v) if v not in ("", "nan") else float("nan")
    return rows


def floor_line(ax, value, label):
    if value > 0:
        ax.axhline(value, color="0.6", linestyle=":", linewidth=1)
        ax.annotate(label, (1.0, value), xycoords=("axes fraction", "data"), ha="right", va="bottom",
                    fontsize=7, color="0.4")


def error_vs_time(rows, meta, out):
    if not any(r["sweep"] in SWEEP_STYLE for r in rows):
        return
    fig, ax = plt.subplots(figsize=(7, 4.5))
    for sweep, (label, color, marker) in SWEEP_STYLE.items():
        pts = [r for r in rows if r["sweep"] == sweep]
        if pts:
            ax.scatter([r["precompute_s"] for r in pts], [max(r["rel_rms"], 1e-6) for r in pts], label=label,
                       color=color, marker=marker, s=28, zorder=3)
    for ref, style in (("shadowed", "k-"), ("interreflected", "g--")):
        front = sorted((r for r in rows if r["pareto"] == 1 and r["reference"] == ref),
                       key=lambda r: r["precompute_s"])
        if front:
            ax.plot([r["precompute_s"] for r in front], [max(r["rel_rms"], 1e-6) for r in front], style,
                    linewidth=1, zorder=2, label=f"Pareto front ({ref})")
    floor_line(ax, meta["shadowed_noise_floor"], "shadowed reference noise")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("precompute time, whole mesh (s)")
    ax.set_ylabel("relative RMS error vs reference")
    ax.set_title(f"{meta['mesh_name']} under {meta['map_name']}: error against precompute time")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(os.path.join(out, "error_vs_time.png"), dpi=120)
    plt.close(fig)


def error_vs_settings(rows, meta, out):
    bands = [r for r in rows if r["sweep"] == "bands"]
    terms = [r for r in rows if r["sweep"] == "terms"]
    panels = [p for p in (bands, terms) if p]
    if not panels:
        return
    fig, axes = plt.subplots(1, len(panels), figsize=(5.5 * len(panels), 4), squeeze=False)
    for ax, pts in zip(axes[0], panels):
        is_bands = pts[0]["sweep"] == "bands"
        x = [r["bands"] if is_bands else r["terms"] for r in pts]
        ax.plot(x, [r["rel_rms"] for r in pts], "o-", label="relative RMS")
        ax.plot(x, [r["p99_rel"] for r in pts], "s--", label="99th percentile")
        floor_line(ax, meta["shadowed_noise_floor"], "reference noise")
        ax.set_yscale("log")
        if is_bands:
            ax.set_xlabel(f"SH bands (shadowed, {int(pts[0]['samples'])} samples)")
        else:
            ax.set_xscale("log")
            ax.set_xlabel(f"wavelet terms K (cube {int(pts[0]['cube_res'])}^2 x 6)")
        ax.set_ylabel("error vs reference")
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=8)
    fig.suptitle(f"{meta['mesh_name']} under {meta['map_name']}")
    fig.tight_layout()
    fig.savefig(os.path.join(out, "error_vs_settings.png"), dpi=120)
    plt.close(fig)


def error_vs_samples(rows, meta, out):
    pts = [r for r in rows if r["sweep"] == "samples"]
    if not pts:
        return
    fit = meta.get("samples_fit", {})
    fig, ax = plt.subplots(figsize=(6.5, 4.5))
    s = np.array([r["samples"] for r in pts])
    ax.loglog(s, [r["rel_rms"] for r in pts], "o", label="vs reference")
    self_pts = [r for r in pts if not np.isnan(r["self_rms"])]
    if self_pts:
        ax.loglog([r["samples"] for r in self_pts], [r["self_rms"] for r in self_pts], "s",
                  label=f"vs {int(max(s))} samples (sampling error alone)")
    for key, style, what in (("slope", "C0-", "fit vs reference"), ("self_slope", "C1--", "fit, sampling alone")):
        if key in fit:
            xs = np.array(fit[key + "_range"], dtype=float)
            ax.loglog(xs, np.exp(fit[key.replace("slope", "intercept")]) * xs ** fit[key], style,
                      label=f"{what}: slope {fit[key]:.2f}")
    floor_line(ax, meta["shadowed_noise_floor"], "reference noise")
    ax.set_xlabel(f"samples per vertex ({int(pts[0]['bands'])} bands, shadowed)")
    ax.set_ylabel("relative RMS error")
    ax.set_title("convergence in samples (Monte Carlo: slope -1/2)")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(os.path.join(out, "error_vs_samples.png"), dpi=120)
    plt.close(fig)


COMPRESSION_STYLE = {
    "cpca": ("diffuse", "tab:blue", "o", "C0-"),
    "cpca glossy": ("glossy", "tab:red", "s", "C3--"),
}


def compression(rows, meta, out):
    pts = [r for r in rows if r["sweep"] == "compression"]
    if not pts:
        return
    info = meta.get("compression", {})
    fig, (left, right) = plt.subplots(1, 2, figsize=(11, 4.5))
    timed = False
    for basis, (label, color, marker, style) in COMPRESSION_STYLE.items():
        sel = [r for r in pts if r["basis"] == basis]
        if not sel:
            continue
        what = f"{label}, {int(sel[0]['bands'])} bands"
        err = [max(r["rel_rms"], 1e-7) for r in sel]
        left.scatter([r["bytes_per_vertex"] for r in sel], err, color=color, marker=marker, s=24, zorder=3,
                     label=what)
        for r, e in zip(sel, err):
            left.annotate(f"{int(r['clusters'])}x{int(r['vectors'])}", (r["bytes_per_vertex"], e), fontsize=6,
                          xytext=(3, 2), textcoords="offset points", color="0.35")
        front = sorted((r for r in sel if r["pareto"] == 1), key=lambda r: r["bytes_per_vertex"])
        left.plot([r["bytes_per_vertex"] for r in front], [max(r["rel_rms"], 1e-7) for r in front], style,
                  linewidth=1, zorder=2, label=f"Pareto front ({label})")
        left.axvline(sel[0]["uncompressed_bytes_per_vertex"], color=color, linestyle=":", linewidth=1)
        left.annotate(f"uncompressed ({label})", (sel[0]["uncompressed_bytes_per_vertex"], 1.0),
                      xycoords=("data", "axes fraction"), rotation=90, ha="right", va="top", fontsize=7, color=color)
        frames = [r for r in sel if not np.isnan(r["frame_ms"])]
        if frames:
            timed = True
            right.scatter([r["frame_ms"] for r in frames], [max(r["rel_rms"], 1e-7) for r in frames], color=color,
                          marker=marker, s=24, zorder=3, label=what)
            for r in frames:
                right.annotate(f"{int(r['clusters'])}x{int(r['vectors'])}", (r["frame_ms"], max(r["rel_rms"], 1e-7)),
                               fontsize=6, xytext=(3, 2), textcoords="offset points", color="0.35")
            if not np.isnan(frames[0]["uncompressed_frame_ms"]):
                right.axvline(frames[0]["uncompressed_frame_ms"], color=color, linestyle=":", linewidth=1,
                              label=f"uncompressed ({label})")
    left.set_xscale("log")
    left.set_yscale("log")
    left.set_xlabel("bytes per vertex (compressed signals, over all vertices)")
    left.set_ylabel("relit error vs uncompressed (relative RMS)")
    left.set_title(f"{int(info.get('weight_bits', 16))}-bit weights, K clusters x N vectors")
    left.grid(True, which="both", alpha=0.3)
    left.legend(fontsize=7)
    if timed:
        right.set_yscale("log")
        right.set_xlabel(f"GPU frame time, {info.get('frame_size', 512)}^2 (ms, median)")
        right.set_ylabel("relit error vs uncompressed (relative RMS)")
        right.set_title(info.get("device", "") or "frame time", fontsize=8)
        right.grid(True, which="both", alpha=0.3)
        right.legend(fontsize=7)
    else:
        right.axis("off")
        right.text(0.5, 0.5, "no frame times:\n" + (info.get("no_frames") or "not measured"), ha="center",
                   va="center", fontsize=8, wrap=True, transform=right.transAxes)
    fig.suptitle(f"{meta['mesh_name']} under {meta['map_name']}: clustered PCA compression")
    fig.tight_layout()
    fig.savefig(os.path.join(out, "compression.png"), dpi=120)
    plt.close(fig)


def read_pfm(path):
    with open(path, "rb") as f:
        kind = f.readline().strip()
        w, h = map(int, f.readline().split())
        scale = float(f.readline())
        data = np.frombuffer(f.read(), dtype="<f4" if scale < 0 else ">f4")
    channels = 3 if kind == b"PF" else 1
    return np.flipud(data.reshape(h, w, channels))  # PFM rows run bottom to top


def images(meta, out):
    pics = meta.get("pictures", [])
    if not pics or "reference_image" not in meta:
        return
    n = len(pics) + 1
    fig, axes = plt.subplots(2, n, figsize=(3.2 * n, 6.6), squeeze=False)
    axes[0][0].imshow(plt.imread(os.path.join(out, meta["reference_image"])))
    axes[0][0].set_title(f"reference\n({meta['image_samples']} samples, noise {meta['image_noise']:.2g})", fontsize=9)
    axes[1][0].axis("off")
    axes[1][0].text(0.5, 0.5, "error = |result - reference|\n/ mean |reference|\n(log colour scale)", ha="center",
                    va="center", fontsize=9, transform=axes[1][0].transAxes)
    norm = LogNorm(vmin=1e-3, vmax=1.0)
    im = None
    for i, p in enumerate(pics, start=1):
        axes[0][i].imshow(plt.imread(os.path.join(out, p["image"])))
        axes[0][i].set_title(f"{p['label']}\nrel. RMS {p['rel_rms']:.3g} (noise-corrected)", fontsize=9)
        e = read_pfm(os.path.join(out, p["error"]))
        err, covered = e[:, :, 0], e[:, :, 1] > 0.5
        shown = np.ma.masked_where(~covered, np.maximum(err, 1e-3))
        im = axes[1][i].imshow(shown, cmap="inferno", norm=norm)
    for ax in axes.flat:
        ax.set_xticks([])
        ax.set_yticks([])
    if im is not None:
        bar = fig.colorbar(im, ax=list(axes[1][1:]), fraction=0.025, pad=0.02)
        # Errors below the reference's own noise are not resolved.
        bar.ax.axhline(meta["image_noise"], color="cyan", linewidth=2)
        bar.ax.annotate("reference\nnoise", (1.0, meta["image_noise"]), xycoords=("axes fraction", "data"),
                        xytext=(4, 0), textcoords="offset points", fontsize=7, va="center", color="tab:cyan")
    fig.suptitle(f"{meta['mesh_name']} under {meta['map_name']}")
    fig.savefig(os.path.join(out, "images.png"), dpi=110)
    plt.close(fig)


def main():
    if len(sys.argv) != 2:
        sys.exit("usage: plots.py DIR (a prt report output directory)")
    out = sys.argv[1]
    rows = read_rows(os.path.join(out, "report.csv"))
    with open(os.path.join(out, "report.json")) as f:
        meta = json.load(f)
    error_vs_time(rows, meta, out)
    error_vs_settings(rows, meta, out)
    error_vs_samples(rows, meta, out)
    compression(rows, meta, out)
    images(meta, out)


if __name__ == "__main__":
    main()
