// The prelude of every kernel family: the runtime compiles it ahead of each family's own
// source (Runtime::build_program), so the per-sample maths that the render, loss and layer
// kernels must agree on is written once. Macros where a kernel applies them to vector types.

// Logistic sigmoid and softplus, log(1 + e^x) without overflow for large x or underflow to 0
// for very negative x; on float and floatn alike.
#define NOVA_SIGMOID(x) (1.0f / (1.0f + exp(-(x))))
#define NOVA_SOFTPLUS(x) (fmax(x, 0.0f) + log1p(exp(-fabs(x))))

// Opacity of a sample of raw density s (ReLU'd) over a step delta: 1 - exp(-sigma delta),
// as -expm1 so that it stays exact for tiny products.
inline float nova_alpha(float s, float delta) { return -expm1(-fmax(s, 0.0f) * delta); }

// The same sample's transmittance exp(-sigma delta), which is also d alpha / d (sigma delta):
// callers form d alpha / d s = delta exp(-sigma delta) above the ReLU and take 0 once the
// exponential underflows (never 0 * inf, whatever delta is).
inline float nova_transmittance(float s, float delta) { return exp(-fmax(s, 0.0f) * delta); }

// A blend channel that may still need its sigmoid (act != 0), and its slope in terms of the
// activated value b.
inline float nova_blend(float raw, int act) { return act ? NOVA_SIGMOID(raw) : raw; }
inline float nova_blend_slope(float b, int act) { return act ? b * (1.0f - b) : 1.0f; }
