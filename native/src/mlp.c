/* mlp.c: a multilayer perceptron for one row (the C twin of learned_contact.model.mlp.NumpyMLP):
 * y = L_last(act(... act(L_0((x - x_mean) / x_std)))), L_i(h) = h @ W_i + b_i, W_i (in, out)
 * row-major; hidden layers use tanh, silu (x * sigmoid(x) written with tanh, as the numpy
 * path) or relu, the output layer is linear.
 *
 * Each output of a layer is summed as b_j + x_0 W_0j + x_1 W_1j + ... (inputs in order);
 * the numpy path's matrix product (BLAS) sums in its own order, which differs by rounding
 * only (~1e-16 relative per layer).
 *
 * The tanh (cci_tanh) is plain arithmetic, the former numba kernels' fast_tanh, not libm's: libm's
 * tanh costs ~18 ns a call here, 2.3 us per evaluation of the shipped 91-64-64-6 network's
 * 128 units, more than its 10,304 multiply-adds; in plain arithmetic, many values at a
 * time, it costs a few ns each. exp(-2|x|) = exp(-|x|/32)^64: a degree-16 Taylor polynomial
 * on [-0.625, 0] (truncation < 1e-18) squared 6 times (relative error < 64 ulp); |x| is
 * capped at 20, where tanh is 1 in float64. It agrees with np.tanh to a few 1e-15
 * (tests/learned/test_native_core.py measures it, and the predictors' answers, against the
 * numpy reference).
 *
 * Speed: the two loops that take the network's time (the affine maps and the activations) are
 * written twice: plain C in blocks of independent sums (which compilers keep in registers and
 * vectorise as they can), and, where GCC or clang build for x86, with 4-lane vectors for CPUs
 * with AVX, chosen at run time (__builtin_cpu_supports). Every lane does the IEEE operations
 * of the plain code in its order (no fused multiply-adds: -ffp-contract=off), so both give the
 * same bits (tests/learned/test_native_core.py compares them). */
#include <math.h>
#include <string.h>

#include "cc_internal.h"

#if (defined(__GNUC__) || defined(__clang__)) && (defined(__x86_64__) || defined(__i386__))
#define CCI_AVX_PATH 1
#endif

/* 1/k! for k = 16 .. 0: the Taylor coefficients of exp, highest first (Horner); each the
 * exact quotient 1.0 / k! (k! < 2^53), as the former numba kernels' _EXP_TAYLOR */
static const double EXP_TAYLOR[17] = {
    1.0 / 20922789888000.0, 1.0 / 1307674368000.0, 1.0 / 87178291200.0, 1.0 / 6227020800.0, 1.0 / 479001600.0,
    1.0 / 39916800.0, 1.0 / 3628800.0, 1.0 / 362880.0, 1.0 / 40320.0, 1.0 / 5040.0, 1.0 / 720.0, 1.0 / 120.0,
    1.0 / 24.0, 1.0 / 6.0, 1.0 / 2.0, 1.0 / 1.0, 1.0 / 1.0};

double cci_tanh(double x) {
  double z = cci_min(fabs(x), 20.0) * (-1.0 / 32.0);
  double e = EXP_TAYLOR[0];
  for (int k = 1; k < 17; ++k) e = e * z + EXP_TAYLOR[k];
  for (int k = 0; k < 6; ++k) e = e * e; /* exp(-2 |x|) */
  return copysign((1.0 - e) / (1.0 + e), x);
}

/* ------------------------------------------------------------------ plain C */

/* out = x @ W + b for W (n_in, n_out) row-major: 8 outputs at a time (eight independent
 * sums), then one; each output summed b_j + x_0 W_0j + x_1 W_1j + ... in input order. */
static void affine_plain(const double *x, int n_in, const double *W, const double *b, int n_out, double *out) {
  int j0 = 0;
  for (; j0 + 8 <= n_out; j0 += 8) {
    double s0 = b[j0], s1 = b[j0 + 1], s2 = b[j0 + 2], s3 = b[j0 + 3];
    double s4 = b[j0 + 4], s5 = b[j0 + 5], s6 = b[j0 + 6], s7 = b[j0 + 7];
    const double *w = W + j0;
    for (int i = 0; i < n_in; ++i, w += n_out) {
      double xi = x[i];
      s0 += xi * w[0];
      s1 += xi * w[1];
      s2 += xi * w[2];
      s3 += xi * w[3];
      s4 += xi * w[4];
      s5 += xi * w[5];
      s6 += xi * w[6];
      s7 += xi * w[7];
    }
    out[j0] = s0; out[j0 + 1] = s1; out[j0 + 2] = s2; out[j0 + 3] = s3;
    out[j0 + 4] = s4; out[j0 + 5] = s5; out[j0 + 6] = s6; out[j0 + 7] = s7;
  }
  for (; j0 < n_out; ++j0) {
    double s0 = b[j0];
    const double *w = W + j0;
    for (int i = 0; i < n_in; ++i, w += n_out) s0 += x[i] * w[0];
    out[j0] = s0;
  }
}

/* v[j] = tanh(v[j] * scale) * a + b for j < n (tanh: scale 1, a 1, b 0; silu's sigmoid:
 * 0.5, 0.5, 0.5): four values at a time (their polynomials overlap), each value's operations
 * cci_tanh's in its order. */
static void tanh_plain(double *v, int n, double scale, double a, double b) {
  int j = 0;
  for (; j + 4 <= n; j += 4) {
    double x0 = v[j] * scale, x1 = v[j + 1] * scale, x2 = v[j + 2] * scale, x3 = v[j + 3] * scale;
    double z0 = cci_min(fabs(x0), 20.0) * (-1.0 / 32.0), z1 = cci_min(fabs(x1), 20.0) * (-1.0 / 32.0);
    double z2 = cci_min(fabs(x2), 20.0) * (-1.0 / 32.0), z3 = cci_min(fabs(x3), 20.0) * (-1.0 / 32.0);
    double e0 = EXP_TAYLOR[0], e1 = e0, e2 = e0, e3 = e0;
    for (int k = 1; k < 17; ++k) {
      double c = EXP_TAYLOR[k];
      e0 = e0 * z0 + c;
      e1 = e1 * z1 + c;
      e2 = e2 * z2 + c;
      e3 = e3 * z3 + c;
    }
    for (int k = 0; k < 6; ++k) {
      e0 = e0 * e0;
      e1 = e1 * e1;
      e2 = e2 * e2;
      e3 = e3 * e3;
    }
    v[j] = copysign((1.0 - e0) / (1.0 + e0), x0) * a + b;
    v[j + 1] = copysign((1.0 - e1) / (1.0 + e1), x1) * a + b;
    v[j + 2] = copysign((1.0 - e2) / (1.0 + e2), x2) * a + b;
    v[j + 3] = copysign((1.0 - e3) / (1.0 + e3), x3) * a + b;
  }
  for (; j < n; ++j) v[j] = cci_tanh(v[j] * scale) * a + b;
}

#ifdef CCI_AVX_PATH
/* ------------------------------------------------------------------ AVX (x86, chosen at run time) */
typedef double v4d __attribute__((vector_size(32)));
/* (macros, not functions: a vector passed by value would change the ABI between targets) */
#define LOAD4(v, p) memcpy(&(v), (p), sizeof(v4d))
#define STORE4(p, v) memcpy((p), &(v), sizeof(v4d))
#define SPLAT(x) ((v4d){(x), (x), (x), (x)})
#define CCI_AVX __attribute__((target("avx")))

/* affine_plain on 4-lane vectors: 32 outputs at a time (eight 4-lane sums in registers,
 * enough to hide the adds' latency), then 4, then one; inputs in order. */
CCI_AVX static void affine_avx(const double *x, int n_in, const double *W, const double *b, int n_out, double *out) {
  int j0 = 0;
  for (; j0 + 32 <= n_out; j0 += 32) {
    v4d s0, s1, s2, s3, s4, s5, s6, s7, w0, w1, w2, w3, w4, w5, w6, w7;
    LOAD4(s0, b + j0);
    LOAD4(s1, b + j0 + 4);
    LOAD4(s2, b + j0 + 8);
    LOAD4(s3, b + j0 + 12);
    LOAD4(s4, b + j0 + 16);
    LOAD4(s5, b + j0 + 20);
    LOAD4(s6, b + j0 + 24);
    LOAD4(s7, b + j0 + 28);
    const double *w = W + j0;
    for (int i = 0; i < n_in; ++i, w += n_out) {
      v4d xi = SPLAT(x[i]);
      LOAD4(w0, w);
      LOAD4(w1, w + 4);
      LOAD4(w2, w + 8);
      LOAD4(w3, w + 12);
      LOAD4(w4, w + 16);
      LOAD4(w5, w + 20);
      LOAD4(w6, w + 24);
      LOAD4(w7, w + 28);
      s0 += xi * w0;
      s1 += xi * w1;
      s2 += xi * w2;
      s3 += xi * w3;
      s4 += xi * w4;
      s5 += xi * w5;
      s6 += xi * w6;
      s7 += xi * w7;
    }
    STORE4(out + j0, s0);
    STORE4(out + j0 + 4, s1);
    STORE4(out + j0 + 8, s2);
    STORE4(out + j0 + 12, s3);
    STORE4(out + j0 + 16, s4);
    STORE4(out + j0 + 20, s5);
    STORE4(out + j0 + 24, s6);
    STORE4(out + j0 + 28, s7);
  }
  for (; j0 + 4 <= n_out; j0 += 4) {
    v4d s0, w0;
    LOAD4(s0, b + j0);
    const double *w = W + j0;
    for (int i = 0; i < n_in; ++i, w += n_out) {
      LOAD4(w0, w);
      s0 += SPLAT(x[i]) * w0;
    }
    STORE4(out + j0, s0);
  }
  for (; j0 < n_out; ++j0) {
    double s0 = b[j0];
    const double *w = W + j0;
    for (int i = 0; i < n_in; ++i, w += n_out) s0 += x[i] * w[0];
    out[j0] = s0;
  }
}

/* tanh_plain on 4-lane vectors, 16 values at a time (four polynomials overlap). */
CCI_AVX static void tanh_avx(double *v, int n, double scale, double a, double b) {
  int j = 0;
  for (; j + 16 <= n; j += 16) {
    double xs[16], zs[16], r[16];
    for (int l = 0; l < 16; ++l) {
      xs[l] = v[j + l] * scale;
      zs[l] = cci_min(fabs(xs[l]), 20.0) * (-1.0 / 32.0);
    }
    v4d z0, z1, z2, z3, e0 = SPLAT(EXP_TAYLOR[0]), e1 = e0, e2 = e0, e3 = e0;
    LOAD4(z0, zs);
    LOAD4(z1, zs + 4);
    LOAD4(z2, zs + 8);
    LOAD4(z3, zs + 12);
    for (int k = 1; k < 17; ++k) {
      v4d c = SPLAT(EXP_TAYLOR[k]);
      e0 = e0 * z0 + c;
      e1 = e1 * z1 + c;
      e2 = e2 * z2 + c;
      e3 = e3 * z3 + c;
    }
    for (int k = 0; k < 6; ++k) {
      e0 = e0 * e0;
      e1 = e1 * e1;
      e2 = e2 * e2;
      e3 = e3 * e3;
    }
    v4d one = SPLAT(1.0);
    e0 = (one - e0) / (one + e0);
    e1 = (one - e1) / (one + e1);
    e2 = (one - e2) / (one + e2);
    e3 = (one - e3) / (one + e3);
    STORE4(r, e0);
    STORE4(r + 4, e1);
    STORE4(r + 8, e2);
    STORE4(r + 12, e3);
    for (int l = 0; l < 16; ++l) v[j + l] = copysign(r[l], xs[l]) * a + b;
  }
  for (; j < n; ++j) v[j] = cci_tanh(v[j] * scale) * a + b;
}

/* 1 where the CPU runs AVX (looked up once; a race between threads writes the same value). */
static int avx_available(void) {
  static int known = -1;
  if (known < 0) known = __builtin_cpu_supports("avx") ? 1 : 0;
  return known;
}
#endif

/* Which of the two forms runs: 0 plain, 1 AVX where available (the tests force 0 to compare). */
static int use_vectors = 1;

void cci_set_vector_path(int on) { use_vectors = on; }

static void affine(const double *x, int n_in, const double *W, const double *b, int n_out, double *out) {
#ifdef CCI_AVX_PATH
  if (use_vectors && avx_available()) {
    affine_avx(x, n_in, W, b, n_out, out);
    return;
  }
#endif
  affine_plain(x, n_in, W, b, n_out, out);
}

static void tanh_all(double *v, int n, double scale, double a, double b) {
#ifdef CCI_AVX_PATH
  if (use_vectors && avx_available()) {
    tanh_avx(v, n, scale, a, b);
    return;
  }
#endif
  tanh_plain(v, n, scale, a, b);
}

int cci_check_mlp(const cc_mlp *mlp, int n_in, int n_out) {
  if (mlp == NULL || mlp->n_layers < 1 || mlp->n_layers > CC_MAX_LAYERS) return CC_BAD_ARGUMENT;
  if (mlp->activation != CC_TANH && mlp->activation != CC_SILU && mlp->activation != CC_RELU) return CC_BAD_ARGUMENT;
  if (mlp->dims[0] != n_in || mlp->dims[mlp->n_layers] != n_out) return CC_BAD_ARGUMENT;
  if (mlp->x_mean == NULL || mlp->x_std == NULL) return CC_BAD_ARGUMENT;
  for (int i = 0; i < mlp->n_layers; ++i) {
    if (mlp->dims[i + 1] < 1 || mlp->dims[i + 1] > CCI_MAX_WIDTH) return CC_BAD_ARGUMENT;
    if (mlp->W[i] == NULL || mlp->b[i] == NULL) return CC_BAD_ARGUMENT;
  }
  return n_in >= 1 && n_in <= CCI_MAX_WIDTH ? CC_OK : CC_BAD_ARGUMENT;
}

void cci_mlp_forward(const cc_mlp *mlp, const double *x, double *y, double *h0, double *h1) {
  int d0 = mlp->dims[0];
  for (int i = 0; i < d0; ++i) h0[i] = (x[i] - mlp->x_mean[i]) / mlp->x_std[i];
  double *cur = h0, *nxt = h1, *swap;
  int last = mlp->n_layers - 1;
  for (int layer = 0; layer <= last; ++layer) {
    int n_in = mlp->dims[layer], n_out = mlp->dims[layer + 1];
    double *out = layer == last ? y : nxt;
    affine(cur, n_in, mlp->W[layer], mlp->b[layer], n_out, out);
    if (layer < last) {
      if (mlp->activation == CC_TANH) {
        tanh_all(out, n_out, 1.0, 1.0, 0.0);
      } else if (mlp->activation == CC_SILU) { /* v (0.5 + 0.5 tanh(0.5 v)) */
        double s[CCI_MAX_WIDTH];
        memcpy(s, out, (size_t)n_out * sizeof *s);
        tanh_all(s, n_out, 0.5, 0.5, 0.5);
        for (int j = 0; j < n_out; ++j) out[j] = out[j] * s[j];
      } else {
        for (int j = 0; j < n_out; ++j) out[j] = cci_max(out[j], 0.0);
      }
    }
    swap = cur;
    cur = nxt;
    nxt = swap;
  }
}
