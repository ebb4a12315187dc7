// NeRF positional encoding of rows of D values: out row = [p, sin(2^0 p), cos(2^0 p), ...,
// sin(2^(L-1) p), cos(2^(L-1) p)], each block D wide. No pi factor, as the reference code.
// Scaling by 2^k is exact in float, so the only rounding is that of sin and cos. sincos shares
// one argument reduction between the two (PoCL: 35-45% less time than sin and cos, same bits).

__kernel void posenc_forward(__global const float* p, __global float* out, uint rows, uint dims,
                             uint freqs) {
  const uint i = get_global_id(0);
  if (i >= rows * dims) return;
  const uint r = i / dims, d = i % dims;
  const uint width = dims * (1 + 2 * freqs);
  __global float* o = out + (size_t)r * width + d;
  const float x = p[i];
  o[0] = x;
  float scale = 1.0f;
  for (uint k = 0; k < freqs; ++k, scale *= 2.0f) {
    float c;
    o[(1 + 2 * k) * dims] = sincos(scale * x, &c);
    o[(2 + 2 * k) * dims] = c;
  }
}

__kernel void posenc_backward(__global const float* p, __global const float* dout,
                              __global float* dp, uint rows, uint dims, uint freqs,
                              int accumulate) {
  const uint i = get_global_id(0);
  if (i >= rows * dims) return;
  const uint r = i / dims, d = i % dims;
  const uint width = dims * (1 + 2 * freqs);
  __global const float* g = dout + (size_t)r * width + d;
  const float x = p[i];
  float s = g[0];
  float scale = 1.0f;
  for (uint k = 0; k < freqs; ++k, scale *= 2.0f) {
    float c;
    const float sn = sincos(scale * x, &c);
    s += scale * (c * g[(1 + 2 * k) * dims] - sn * g[(2 + 2 * k) * dims]);
  }
  dp[i] = accumulate ? dp[i] + s : s;
}
