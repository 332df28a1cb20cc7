/* sat.c: the separating-axis test of two boxes, one pose at a time (the C twin of
 * testbed.geometry.boxes.sat_axes / sat_overlap / sat_normal). Frames and units: see
 * cc_internal.h (A's frame; p [m]; R row-major, column j = B's axis j in A; half extents [m]). */
#include <math.h>

#include "cc_internal.h"

void cci_sat_overlap(const double p[3], const double R[9], const double hA[3], const double hB[3],
                     double axes[15][3], double overlap[15]) {
  for (int k = 0; k < 15; ++k) axes[k][0] = axes[k][1] = axes[k][2] = 0.0;
  for (int i = 0; i < 3; ++i) {
    axes[i][i] = 1.0;
    for (int c = 0; c < 3; ++c) axes[3 + i][c] = R[3 * c + i];
  }
  /* the 9 edge axes e_i x b_j, normalised; zero where the edges are parallel (norm <= 1e-6) */
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) {
      double bx = R[j], by = R[3 + j], bz = R[6 + j], cx, cy, cz;
      if (i == 0) {
        cx = 0.0; cy = -bz; cz = by;
      } else if (i == 1) {
        cx = bz; cy = 0.0; cz = -bx;
      } else {
        cx = -by; cy = bx; cz = 0.0;
      }
      double norm = sqrt(cx * cx + cy * cy + cz * cz);
      int k = 6 + 3 * i + j;
      if (norm > 1e-6) {
        double d = cci_max(norm, 1e-12);
        axes[k][0] = cx / d;
        axes[k][1] = cy / d;
        axes[k][2] = cz / d;
      }
    }
  }
  for (int k = 0; k < 15; ++k) {
    double a0 = axes[k][0], a1 = axes[k][1], a2 = axes[k][2];
    if (a0 * a0 + a1 * a1 + a2 * a2 < 0.25) {
      overlap[k] = HUGE_VAL;
      continue;
    }
    double rA = fabs(a0) * hA[0] + fabs(a1) * hA[1] + fabs(a2) * hA[2];
    double rB = 0.0;
    for (int j = 0; j < 3; ++j) rB += fabs(a0 * R[j] + a1 * R[3 + j] + a2 * R[6 + j]) * hB[j];
    overlap[k] = rA + rB - fabs(a0 * p[0] + a1 * p[1] + a2 * p[2]);
  }
}

/* The axis of least overlap, edge axes biased by EDGE_BIAS (first on ties, as np.argmin). */
static int least_axis(const double overlap[15]) {
  double best = HUGE_VAL;
  int k = 0;
  for (int i = 0; i < 15; ++i) {
    double v = overlap[i] + (i >= 6 ? CCI_EDGE_BIAS : 0.0);
    if (v < best) {
      best = v;
      k = i;
    }
  }
  return k;
}

double cci_sat_normal(const double p[3], const double axes[15][3], const double overlap[15], double normal[3],
                      int *axis) {
  int k = least_axis(overlap);
  double dot = axes[k][0] * p[0] + axes[k][1] * p[1] + axes[k][2] * p[2];
  double sign = dot < 0.0 ? -1.0 : 1.0;
  for (int c = 0; c < 3; ++c) normal[c] = axes[k][c] * sign;
  *axis = k;
  return overlap[k];
}

double cci_sat_depth(const double p[3], const double R[9], const double hA[3], const double hB[3]) {
  double axes[15][3], overlap[15];
  cci_sat_overlap(p, R, hA, hB, axes, overlap);
  return overlap[least_axis(overlap)];
}
