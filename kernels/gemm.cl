// Row-major GEMMs for MLP layers, written for how PoCL vectorises: work-items along
// dimension 0 become SIMD lanes, and each work-item keeps a block of C in registers.
// Batched matrices and blocks share dimension 1. No local memory or barriers (emulated, slow,
// on PoCL), no atomics: every sum runs in a fixed order.
//
// gemm_tn: dimension 0 over the output columns n (contiguous loads of B and stores of C),
// GEMM_MB rows of C per work-item, A read once per k as a value uniform across the lanes.
//
// gemm_nn: C = alpha A B + beta C,   A [M, K], B [K, N]
// gemm_tn: C = alpha A^T B + beta C, A [K, M], B [K, N]  (the weight gradient x^T dy)
// gemm_transpose: T = B^T, so that A B^T runs as gemm_nn on T (the input gradient dy w^T).

#ifndef GEMM_MB
#define GEMM_MB 8
#endif

inline void gemm_store(__global float* C, uint ldc, uint n, uint rows, const float* acc,
                       float alpha, float beta) {
  for (uint i = 0; i < rows; ++i) {
    __global float* c = C + (size_t)i * ldc + n;
    *c = beta == 0.0f ? alpha * acc[i] : alpha * acc[i] + beta * *c;
  }
}

__kernel void gemm_tn(__global const float* A, __global const float* B, __global float* C,
                      uint M, uint N, uint K, uint lda, uint ldb, uint ldc, uint stride_a,
                      uint stride_b, uint stride_c, uint batch, float alpha, float beta) {
  const uint n = get_global_id(0), job = get_global_id(1);
  const uint blocks = (M + GEMM_MB - 1) / GEMM_MB;
  if (n >= N || job >= blocks * batch) return;
  const uint b = job / blocks, m0 = (job % blocks) * GEMM_MB;
  __global const float* a = A + (size_t)b * stride_a + m0;
  __global const float* bcol = B + (size_t)b * stride_b + n;
  float acc[GEMM_MB];
  for (uint i = 0; i < GEMM_MB; ++i) acc[i] = 0.0f;
  const uint rows = min((uint)GEMM_MB, M - m0);
  if (rows == GEMM_MB) {
    for (uint k = 0; k < K; ++k) {
      const float bk = bcol[(size_t)k * ldb];
      for (uint i = 0; i < GEMM_MB; ++i) acc[i] = fma(a[(size_t)k * lda + i], bk, acc[i]);
    }
  } else {
    for (uint k = 0; k < K; ++k) {
      const float bk = bcol[(size_t)k * ldb];
      for (uint i = 0; i < rows; ++i) acc[i] = fma(a[(size_t)k * lda + i], bk, acc[i]);
    }
  }
  gemm_store(C + (size_t)b * stride_c + (size_t)m0 * ldc, ldc, n, rows, acc, alpha, beta);
}

// T[b] (cols x rows, dense) = B[b]^T for B[b] rows x cols with leading dimension ld.
__kernel void gemm_transpose(__global const float* B, __global float* T, uint rows, uint cols,
                             uint ld, uint stride, uint batch) {
  const uint r = get_global_id(0), j = get_global_id(1);
  if (r >= rows || j >= cols * batch) return;
  const uint b = j / cols, c = j % cols;
  T[((size_t)b * cols + c) * rows + r] = B[(size_t)b * stride + (size_t)r * ld + c];
}

// gemm_nn: dimension 0 over the rows m instead, GEMM_NB columns of C per work-item, B read as
// a broadcast and A gathered across lanes: 2.2x faster on PoCL than the column layout above.
#ifndef GEMM_NB
#define GEMM_NB 16
#endif
__kernel void gemm_nn(__global const float* A, __global const float* B, __global float* C,
                      uint M, uint N, uint K, uint lda, uint ldb, uint ldc, uint stride_a,
                      uint stride_b, uint stride_c, uint batch, float alpha, float beta) {
  const uint m = get_global_id(0), job = get_global_id(1);
  const uint blocks = (N + GEMM_NB - 1) / GEMM_NB;
  if (m >= M || job >= blocks * batch) return;
  const uint b = job / blocks, n0 = (job % blocks) * GEMM_NB;
  __global const float* a = A + (size_t)b * stride_a + (size_t)m * lda;
  __global const float* bb = B + (size_t)b * stride_b + n0;
  float acc[GEMM_NB];
  for (uint j = 0; j < GEMM_NB; ++j) acc[j] = 0.0f;
  const uint cols = min((uint)GEMM_NB, N - n0);
  if (cols == GEMM_NB) {
    for (uint k = 0; k < K; ++k) {
      const float ak = a[k];
      for (uint j = 0; j < GEMM_NB; ++j) acc[j] = fma(ak, bb[(size_t)k * ldb + j], acc[j]);
    }
  } else {
    for (uint k = 0; k < K; ++k) {
      const float ak = a[k];
      for (uint j = 0; j < cols; ++j) acc[j] = fma(ak, bb[(size_t)k * ldb + j], acc[j]);
    }
  }
  __global float* c = C + (size_t)b * stride_c + (size_t)m * ldc + n0;
  for (uint j = 0; j < cols; ++j) c[j] = beta == 0.0f ? alpha * acc[j] : alpha * acc[j] + beta * c[j];
}
