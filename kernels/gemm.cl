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

// The epilogue of a dense layer's forward, y = act(v + bias[column]), where v is the finished
// alpha op(A) op(B) + beta C (never a partial sum of a split reduction). GEMM_BIAS_ACT (a build
// option) turns it on and names the activation as bias_act.cl's ACT does: 0 identity,
// 1 ReLU, 2 sigmoid, 3 softplus, with the prelude's expressions as bias_act.cl's
// act_forward (test_dense checks that the fused and the two-pass results agree). The bias is added in a statement of its own so that the compiler cannot
// contract it with alpha * acc into one fma: the rounding stays that of the two-pass path.
// GEMM_ACT works on float and floatn alike.
#ifdef GEMM_BIAS_ACT
#if GEMM_BIAS_ACT == 1
#define GEMM_ACT(x) fmax(x, 0.0f)
#elif GEMM_BIAS_ACT == 2
#define GEMM_ACT(x) NOVA_SIGMOID(x)
#elif GEMM_BIAS_ACT == 3
#define GEMM_ACT(x) NOVA_SOFTPLUS(x)
#else
#define GEMM_ACT(x) (x)
#endif
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
                      uint stride_b, uint stride_c, uint batch, float alpha, float beta,
                      __global const float* bias, uint stride_bias) {
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
  for (uint j = 0; j < cols; ++j) {
    float v = beta == 0.0f ? alpha * acc[j] : alpha * acc[j] + beta * c[j];
#ifdef GEMM_BIAS_ACT
    v += bias[(size_t)b * stride_bias + n0 + j];
    v = GEMM_ACT(v);
#endif
    c[j] = v;
  }
}

// gemm_blk: register-blocked GEMM with explicit float8 vectors (PoCL leaves explicit vector
// code alone instead of vectorising across work-items; this is the textbook CPU micro-kernel).
// Each work-item keeps a GEMM_RM x (8 GEMM_VN) block of C in registers; per k it loads GEMM_VN
// vectors of op(B)'s row k and broadcasts GEMM_RM values of op(A)'s column k.
// Dimension 0 runs over column blocks, so the work-items of one work-group share op(A)'s rows
// (in L1) and sweep op(B) (in L2). op(A)[i, l] = A[i a_rs + l a_cs] covers A (a_rs = lda,
// a_cs = 1) and A^T (a_rs = 1, a_cs = lda); op(B) is row-major (B^T goes through
// gemm_transpose first).
// Split reduction (the weight gradient, K = the batch): dimension 1 also runs over `splits`
// chunks of kc values of k; with splits > 1 each chunk writes its partial block to P
// (at float offset poff, [splits][batch][M][N]) and gemm_reduce adds the chunks in order (no atomics: the sum order
// is fixed, runs are bit-reproducible).
#ifndef GEMM_RM
#define GEMM_RM 6
#endif
#ifndef GEMM_VN
#define GEMM_VN 2
#endif
#define GEMM_BN (8 * GEMM_VN)

__kernel void gemm_blk(__global const float* A, __global const float* B, __global float* C,
                       __global float* P, uint poff, uint M, uint N, uint K, uint a_rs, uint a_cs, uint ldb,
                       uint ldc, uint stride_a, uint stride_b, uint stride_c, uint batch,
                       uint kc, uint splits, float alpha, float beta,
                       __global const float* bias, uint stride_bias) {
  const uint nb = get_global_id(0), job = get_global_id(1);
  const uint nblocks = (N + GEMM_BN - 1) / GEMM_BN, mblocks = (M + GEMM_RM - 1) / GEMM_RM;
  if (nb >= nblocks || job >= mblocks * batch * splits) return;
  // The chunk varies slowest, so work-groups running at once share a chunk of A and B.
  const uint s = job / (mblocks * batch), rest = job % (mblocks * batch);
  const uint b = rest / mblocks, m0 = (rest % mblocks) * GEMM_RM, n0 = nb * GEMM_BN;
  const uint k0 = s * kc, k1 = min(K, k0 + kc);
  __global const float* a = A + (size_t)b * stride_a + (size_t)m0 * a_rs + (size_t)k0 * a_cs;
  __global const float* bp = B + (size_t)b * stride_b + (size_t)k0 * ldb + n0;
  __global float* c;
  float cscale = alpha, cbeta = beta;
  uint ldo = ldc;
  if (splits > 1) {  // partial sums: plain stores, alpha and beta applied by gemm_reduce
    c = P + poff + (((size_t)s * batch + b) * M + m0) * N + n0;
    cscale = 1.0f;
    cbeta = 0.0f;
    ldo = N;
  } else {
    c = C + (size_t)b * stride_c + (size_t)m0 * ldc + n0;
  }
  const uint rows = min((uint)GEMM_RM, M - m0), cols = min((uint)GEMM_BN, N - n0);
#ifdef GEMM_BIAS_ACT
  // With a split the epilogue waits for gemm_reduce's sum.
  const bool epilogue = splits == 1;
  __global const float* bv_row = bias + (size_t)b * stride_bias + n0;
#endif
  if (rows == GEMM_RM && cols == GEMM_BN) {
    float8 acc[GEMM_RM][GEMM_VN];
#pragma unroll
    for (uint i = 0; i < GEMM_RM; ++i)
#pragma unroll
      for (uint j = 0; j < GEMM_VN; ++j) acc[i][j] = (float8)(0.0f);
    for (uint k = k0; k < k1; ++k) {
      float8 bv[GEMM_VN];
#pragma unroll
      for (uint j = 0; j < GEMM_VN; ++j) bv[j] = vload8(j, bp);
#pragma unroll
      for (uint i = 0; i < GEMM_RM; ++i) {
        const float8 av = (float8)(a[(size_t)i * a_rs]);
#pragma unroll
        for (uint j = 0; j < GEMM_VN; ++j) acc[i][j] = fma(av, bv[j], acc[i][j]);
      }
      a += a_cs;
      bp += ldb;
    }
#pragma unroll
    for (uint i = 0; i < GEMM_RM; ++i)
#pragma unroll
      for (uint j = 0; j < GEMM_VN; ++j) {
        __global float* o = c + (size_t)i * ldo;
        const float8 r = cscale * acc[i][j];
        float8 v = cbeta == 0.0f ? r : r + cbeta * vload8(j, o);
#ifdef GEMM_BIAS_ACT
        if (epilogue) {
          v += vload8(j, bv_row);
          v = GEMM_ACT(v);
        }
#endif
        vstore8(v, j, o);
      }
  } else {  // a ragged edge block: scalar, one column at a time
    for (uint j = 0; j < cols; ++j) {
      float acc[GEMM_RM];
      for (uint i = 0; i < GEMM_RM; ++i) acc[i] = 0.0f;
      __global const float* aa = a;
      __global const float* bb = bp + j;
      for (uint k = k0; k < k1; ++k) {
        const float bk = *bb;
        for (uint i = 0; i < rows; ++i) acc[i] = fma(aa[(size_t)i * a_rs], bk, acc[i]);
        aa += a_cs;
        bb += ldb;
      }
      for (uint i = 0; i < rows; ++i) {
        __global float* o = c + (size_t)i * ldo + j;
        float v = cbeta == 0.0f ? cscale * acc[i] : cscale * acc[i] + cbeta * *o;
#ifdef GEMM_BIAS_ACT
        if (epilogue) {
          v += bv_row[j];
          v = GEMM_ACT(v);
        }
#endif
        *o = v;
      }
    }
  }
}

// C[b] = alpha sum_s P[s][b] + beta C[b], the chunks added in order s = 0, 1, ..., then the
// epilogue (with GEMM_BIAS_ACT) on the finished sum.
__kernel void gemm_reduce(__global const float* P, uint poff, __global float* C, uint M, uint N,
                          uint ldc, uint stride_c, uint batch, uint splits, float alpha,
                          float beta, __global const float* bias, uint stride_bias) {
  const uint n = get_global_id(0), job = get_global_id(1);
  if (n >= N || job >= M * batch) return;
  const uint b = job / M, m = job % M;
  const size_t plane = (size_t)batch * M * N;
  __global const float* p = P + poff + ((size_t)b * M + m) * N + n;
  float s = 0.0f;
  for (uint i = 0; i < splits; ++i) s += p[i * plane];
  __global float* c = C + (size_t)b * stride_c + (size_t)m * ldc + n;
  float v = beta == 0.0f ? alpha * s : alpha * s + beta * *c;
#ifdef GEMM_BIAS_ACT
  v += bias[(size_t)b * stride_bias + n];
  v = GEMM_ACT(v);
#endif
  *c = v;
}
