#!/usr/bin/python3
"""Writes a constant environment map of radiance 1 as a Radiance HDR (32 x 16
flat RGBE pixels: mantissa 128, exponent 129, 0.5 x 2^1): the map under which
SH transfer is exact in any band count, what the accuracy scripts use to
isolate an integral's own error.

    scripts/constant_map.py OUT.hdr
"""
import sys

if len(sys.argv) != 2:
    sys.exit(__doc__)
w, h = 32, 16
with open(sys.argv[1], "wb") as f:
    f.write(b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y %d +X %d\n" % (h, w) + bytes([128, 128, 128, 129]) * (w * h))
