// Compressed (clustered PCA) rows, shared by relight.comp.glsl and
// glossy.comp.glsl when COMPRESSED is 1 (prt/compressed_transfer.h,
// docs/RUNTIME.md "Compressed transfer"); the renderer inserts this after
// the #defines. Per stored row, ROW_WORDS 32-bit words: the cluster index,
// then VECTORS weights: WEIGHT_BITS 16, two signed 16-bit integers q per
// word (low half first; the scale of each cluster and vector is folded into
// that vector's lighting products on the CPU), or WEIGHT_BITS 32, floats.
// The products of the pass (binding 1): per cluster k, VECTORS + 1 runs
// (the mean's, then each basis vector's) of PRODUCT_RUN vec4s, RGB.
layout(std430, binding = 0) readonly buffer RowBuffer { uint rows[]; };
layout(std430, binding = 1) readonly buffer ProductBuffer { vec4 products[]; };

uint row_cluster(uint row) { return rows[row * uint(ROW_WORDS)]; }

float row_weight(uint row, int j) {
#if WEIGHT_BITS == 16
  const uint word = rows[row * uint(ROW_WORDS) + 1u + uint(j >> 1)];
  return float(bitfieldExtract(int(word), 16 * (j & 1), 16));  // sign-extended
#else
  return uintBitsToFloat(rows[row * uint(ROW_WORDS) + 1u + uint(j)]);
#endif
}

// The first PRODUCT_RUN-vec4 run of row's cluster.
int cluster_run(uint row) { return int(row_cluster(row)) * (VECTORS + 1) * PRODUCT_RUN; }
