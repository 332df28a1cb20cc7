/* step_elastic.c: the foundation integral of a box pair: the elastic force kappa x overlap volume
 * on the face pair of least overlap, the overlap area and the normal stiffness (ccs_elastic_stiff,
 * and cc_step_elastic for callers of the library). */
#include <math.h>

#include "step_internal.h"

/* (integral of max(0, a + b x) dx over [lo, hi] (exact), length of [lo, hi] where a + b x > 0) */
static void positive_integral(double a, double b, double lo, double hi, double *integral, double *length) {
  *integral = 0.0;
  *length = 0.0;
  if (b == 0.0) {
    if (a > 0) {
      *integral = a * (hi - lo);
      *length = hi - lo;
    }
    return;
  }
  double x0 = -a / b, x1, x2;
  if (b > 0) {
    x1 = py_max(lo, x0);
    x2 = hi;
  } else {
    x1 = lo;
    x2 = py_min(hi, x0);
  }
  if (x2 <= x1) return;
  *integral = a * (x2 - x1) + 0.5 * b * (x2 * x2 - x1 * x1);
  *length = x2 - x1;
}

/* The foundation integral over the overlap of A's face (axis k, side s = +-1) and B's facing
 * face: *vol [m^3], *area overlap [m^2], *wet where depth > 0 [m^2] (see the header of the
 * testbed's README for the quadrature: exact along one in-face axis, midpoint along the other). */
static void face_volume(const double *p, const double *R, const double *hA, const double *hB, int k, double s,
                        int grid, double *vol_out, double *area_out, double *wet_out) {
  int u = (k + 1) % 3, v = (k + 2) % 3, j = 0;
  for (int e = 1; e < 3; ++e)
    if (fabs(R[3 * k + e]) > fabs(R[3 * k + j])) j = e;
  double sigma = s * R[3 * k + j] >= 0 ? -1.0 : 1.0;
  double c_k = p[k] + sigma * hB[j] * R[3 * k + j];
  double c_u = p[u] + sigma * hB[j] * R[3 * u + j];
  double c_v = p[v] + sigma * hB[j] * R[3 * v + j];
  int j1 = (j + 1) % 3, j2 = (j + 2) % 3;
  double ru = fabs(R[3 * u + j1]) * hB[j1] + fabs(R[3 * u + j2]) * hB[j2];
  double rv = fabs(R[3 * v + j1]) * hB[j1] + fabs(R[3 * v + j2]) * hB[j2];
  double lo_u = py_max(-hA[u], c_u - ru), lo_v = py_max(-hA[v], c_v - rv);
  double w_u = py_max(py_min(hA[u], c_u + ru) - lo_u, 0.0);
  double w_v = py_max(py_min(hA[v], c_v + rv) - lo_v, 0.0);
  *vol_out = *area_out = *wet_out = 0.0;
  if (w_u == 0.0 || w_v == 0.0) return;
  double b_k = sigma * R[3 * k + j];
  if (fabs(b_k) < 1e-9) b_k = -s * 1e-9;
  double d0 = hA[k] - s * c_k;
  double g_u = s * sigma * R[3 * u + j] / b_k, g_v = s * sigma * R[3 * v + j] / b_k;
  double vol = 0.0, wet = 0.0, a, b;
  if (fabs(g_u) * w_u >= fabs(g_v) * w_v) { /* exact along u, midpoint rule along v */
    for (int q = 0; q < grid; ++q) {
      double vv = lo_v + w_v * (q + 0.5) / grid;
      positive_integral(d0 + g_v * (vv - c_v) - g_u * c_u, g_u, lo_u, lo_u + w_u, &a, &b);
      vol = vol + a;
      wet = wet + b;
    }
    vol = vol * w_v / grid;
    wet = wet * w_v / grid;
  } else {
    for (int q = 0; q < grid; ++q) {
      double uu = lo_u + w_u * (q + 0.5) / grid;
      positive_integral(d0 + g_u * (uu - c_u) - g_v * c_v, g_v, lo_v, lo_v + w_v, &a, &b);
      vol = vol + a;
      wet = wet + b;
    }
    vol = vol * w_u / grid;
    wet = wet * w_u / grid;
  }
  *vol_out = vol;
  *area_out = w_u * w_v;
  *wet_out = wet;
}

/* One pair's elastic force *F [N], overlap *area [m^2] and normal stiffness *k_n = kappa x
 * wetted area [N/m], on the face pair of least overlap (edge-on-edge treated as face contact). */
void ccs_elastic_stiff(const double *p, const double *R, const double *hA, const double *hB, double kappa,
                          int grid, double *F, double *area, double *k_n) {
  int owner, axis;
  double best = ccs_face_axis_overlap(p, R, hA, hB, &owner, &axis);
  *F = *area = *k_n = 0.0;
  if (best <= 0) return;
  double vol, ar, wet;
  if (owner == 0) {
    face_volume(p, R, hA, hB, axis, p[axis] >= 0 ? 1.0 : -1.0, grid, &vol, &ar, &wet);
  } else {
    double p_BA[3], R_BA[9];
    for (int a = 0; a < 3; ++a) p_BA[a] = -(R[0 + a] * p[0] + R[3 + a] * p[1] + R[6 + a] * p[2]);
    for (int a = 0; a < 3; ++a)
      for (int b = 0; b < 3; ++b) R_BA[3 * a + b] = R[3 * b + a];
    face_volume(p_BA, R_BA, hB, hA, axis, p_BA[axis] >= 0 ? 1.0 : -1.0, grid, &vol, &ar, &wet);
  }
  *F = kappa * vol;
  *area = ar;
  *k_n = kappa * wet;
}

void cc_step_elastic(const double p_AB[3], const double R_AB[9], const double hA[3], const double hB[3],
                     double kappa, int grid, double out[3]) {
  ccs_elastic_stiff(p_AB, R_AB, hA, hB, kappa, grid < 1 ? 1 : grid, &out[0], &out[1], &out[2]);
}
