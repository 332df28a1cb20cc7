/* prior.c: the improved predictor's geometric estimate and features, one pose at a time (the
 * C twin of learned_contact.model.prior.patch_estimate and model.encodings: canonicalise,
 * reflect, band_weight, features). Frames and units: see cc_internal.h. Polygons are
 * (CCI_MAX_VERTS x 3) arrays [m] in A's frame with a vertex count. */
#include <math.h>

#include "cc_internal.h"

/* Sutherland-Hodgman: poly (count vertices) clipped to sg * x[ax] <= lim, written to out;
 * returns the new count (vertices past the budget overwrite the last row). */
static int clip_axis(const double poly[][3], int count, int ax, double sg, double lim, double out[][3]) {
  int n_out = 0;
  for (int i = 0; i < count; ++i) {
    int j = i + 1 < count ? i + 1 : 0;
    double si = sg * poly[i][ax] - lim, sj = sg * poly[j][ax] - lim;
    if (si <= 0.0) {
      int r = n_out < CCI_MAX_VERTS - 1 ? n_out : CCI_MAX_VERTS - 1;
      for (int c = 0; c < 3; ++c) out[r][c] = poly[i][c];
      ++n_out;
    }
    if ((si <= 0.0) != (sj <= 0.0)) {
      double d = si - sj;
      double t = si / (d != 0.0 ? d : 1.0);
      int r = n_out < CCI_MAX_VERTS - 1 ? n_out : CCI_MAX_VERTS - 1;
      for (int c = 0; c < 3; ++c) out[r][c] = poly[i][c] + t * (poly[j][c] - poly[i][c]);
      ++n_out;
    }
  }
  return n_out < CCI_MAX_VERTS ? n_out : CCI_MAX_VERTS;
}

/* Fan-triangulated integral of the linear weight depth (count) over the polygon
 * (prior._weighted_centroid): fills centroid (3) [m] (the vertex mean where the integral is
 * ~0); returns the integral [m^3]. */
static double weighted_centroid(const double poly[][3], int count, const double depth[], double centroid[3]) {
  double total = 0.0, f0 = 0.0, f1 = 0.0, f2 = 0.0, d0 = depth[0];
  for (int j = 1; j < count - 1; ++j) {
    double e1x = poly[j][0] - poly[0][0], e1y = poly[j][1] - poly[0][1], e1z = poly[j][2] - poly[0][2];
    double e2x = poly[j + 1][0] - poly[0][0], e2y = poly[j + 1][1] - poly[0][1], e2z = poly[j + 1][2] - poly[0][2];
    double cx = e1y * e2z - e1z * e2y, cy = e1z * e2x - e1x * e2z, cz = e1x * e2y - e1y * e2x;
    double area = 0.5 * sqrt(cx * cx + cy * cy + cz * cz);
    double d1 = depth[j], d2 = depth[j + 1];
    total += area * (d0 + d1 + d2) / 3.0;
    double w0 = 2 * d0 + d1 + d2, w1 = d0 + 2 * d1 + d2, w2 = d0 + d1 + 2 * d2;
    double a = area / 12.0;
    f0 += a * (w0 * poly[0][0] + w1 * poly[j][0] + w2 * poly[j + 1][0]);
    f1 += a * (w0 * poly[0][1] + w1 * poly[j][1] + w2 * poly[j + 1][1]);
    f2 += a * (w0 * poly[0][2] + w1 * poly[j][2] + w2 * poly[j + 1][2]);
  }
  if (total > 1e-12) {
    centroid[0] = f0 / total;
    centroid[1] = f1 / total;
    centroid[2] = f2 / total;
  } else {
    int m = count > 1 ? count : 1;
    for (int c = 0; c < 3; ++c) {
      double s = 0.0;
      for (int v = 0; v < count; ++v) s += poly[v][c];
      centroid[c] = s / m;
    }
  }
  return total;
}

/* B's incident face clipped against A's face normal to `axis` (on B's side), its
 * depth-weighted centroid moved half the depth towards A's face (prior._face_patch):
 * fills point (3) [m] in A; returns the patch volume [m^3]. */
static double face_patch(const double p[3], const double R[9], const double hA[3], const double hB[3], int axis,
                         double point[3]) {
  double buf0[CCI_MAX_VERTS][3], buf1[CCI_MAX_VERTS][3], depth[CCI_MAX_VERTS];
  double(*poly)[3] = buf0, (*tmp)[3] = buf1, (*swap)[3];
  double sigma = p[axis] >= 0.0 ? 1.0 : -1.0;
  int m = 0;
  double best = fabs(R[3 * axis] * sigma);
  for (int mm = 1; mm < 3; ++mm) {
    double v = fabs(R[3 * axis + mm] * sigma);
    if (v > best) {
      m = mm;
      best = v;
    }
  }
  double s_m = R[3 * axis + m] * sigma > 0.0 ? -1.0 : 1.0;
  int u = (m + 1) % 3, w = (m + 2) % 3;
  for (int c = 0; c < 3; ++c) {
    double centre = p[c] + (s_m * hB[m]) * R[3 * c + m];
    double du = hB[u] * R[3 * c + u], dv = hB[w] * R[3 * c + w];
    poly[0][c] = centre + du + dv;
    poly[1][c] = centre - du + dv;
    poly[2][c] = centre - du - dv;
    poly[3][c] = centre + du - dv;
  }
  int count = 4;
  for (int k = 1; k < 3; ++k) {
    int ax = (axis + k) % 3;
    for (int s = 0; s < 2; ++s) {
      count = clip_axis((const double(*)[3])poly, count, ax, s == 0 ? 1.0 : -1.0, hA[ax], tmp);
      swap = poly; poly = tmp; tmp = swap;
    }
  }
  count = clip_axis((const double(*)[3])poly, count, axis, sigma, hA[axis], tmp);
  swap = poly; poly = tmp; tmp = swap;
  double top = hA[axis];
  for (int v = 0; v < count; ++v) depth[v] = cci_max(top - sigma * poly[v][axis], 0.0);
  double weight = weighted_centroid((const double(*)[3])poly, count, depth, point);
  point[axis] = 0.5 * (point[axis] + sigma * top);
  return weight;
}

/* Midpoint of the closest points of A's and B's edges along the SAT edge axis k (6..14)
 * for the contact normal (3) A->B (prior._edge_patch): fills point (3) [m] in A. */
static void edge_patch(const double p[3], const double R[9], const double hA[3], const double hB[3], int k,
                       const double normal[3], double point[3]) {
  int i = (k - 6) / 3, j = (k - 6) % 3;
  double cA[3], cB[3], sB[3];
  for (int c = 0; c < 3; ++c) cA[c] = (normal[c] >= 0.0 ? 1.0 : -1.0) * hA[c];
  cA[i] = 0.0;
  for (int jj = 0; jj < 3; ++jj) {
    double nB = normal[0] * R[jj] + normal[1] * R[3 + jj] + normal[2] * R[6 + jj];
    sB[jj] = (nB >= 0.0 ? -1.0 : 1.0) * hB[jj];
  }
  sB[j] = 0.0;
  for (int c = 0; c < 3; ++c) cB[c] = p[c] + (R[3 * c] * sB[0] + R[3 * c + 1] * sB[1] + R[3 * c + 2] * sB[2]);
  double b = R[3 * i + j];
  double d = cA[i] - cB[i];
  double e = 0.0;
  for (int c = 0; c < 3; ++c) e += R[3 * c + j] * (cA[c] - cB[c]);
  double den = cci_max(1.0 - b * b, 1e-9);
  double s = cci_clamp((b * e - d) / den, -hA[i], hA[i]);
  double t = cci_clamp((e - b * d) / den, -hB[j], hB[j]);
  for (int c = 0; c < 3; ++c) point[c] = 0.5 * (cA[c] + (c == i ? s : 0.0) + cB[c] + t * R[3 * c + j]);
}

double cci_patch_estimate(const double p[3], const double R[9], const double hA[3], const double hB[3],
                          double overlap[15], double point[3], double normal[3], int *axis, double *weight) {
  double axes[15][3];
  cci_sat_overlap(p, R, hA, hB, axes, overlap);
  int k;
  double pen = cci_sat_normal(p, (const double(*)[3])axes, overlap, normal, &k);
  int face = 0;
  double best = overlap[0];
  for (int f = 1; f < 6; ++f) {
    if (overlap[f] < best) {
      face = f;
      best = overlap[f];
    }
  }
  double w;
  if (face < 3) {
    w = face_patch(p, R, hA, hB, face, point);
  } else { /* B's face: the pose of A in B, the patch found there and mapped back */
    double p_BA[3], R_BA[9], q[3];
    for (int a = 0; a < 3; ++a) {
      p_BA[a] = -(R[a] * p[0] + R[3 + a] * p[1] + R[6 + a] * p[2]);
      for (int b = 0; b < 3; ++b) R_BA[3 * a + b] = R[3 * b + a];
    }
    w = face_patch(p_BA, R_BA, hB, hA, face - 3, q);
    for (int c = 0; c < 3; ++c) point[c] = p[c] + (R[3 * c] * q[0] + R[3 * c + 1] * q[1] + R[3 * c + 2] * q[2]);
  }
  if (w <= 1e-12 && k >= 6) edge_patch(p, R, hA, hB, k, normal, point);
  *axis = k;
  *weight = w;
  return pen;
}

void cci_reflect(const double p[3], const double R[9], const double S[3], double p_c[3], double R_c[9]) {
  for (int i = 0; i < 3; ++i) p_c[i] = S[i] * p[i];
  for (int j = 0; j < 3; ++j) {
    double col = S[0] * R[j] + S[1] * R[3 + j] + S[2] * R[6 + j] >= 0.0 ? 1.0 : -1.0;
    for (int i = 0; i < 3; ++i) R_c[3 * i + j] = S[i] * R[3 * i + j] * col;
  }
}

void cci_canonicalise(const double p[3], const double R[9], double S[3], double p_c[3], double R_c[9]) {
  for (int i = 0; i < 3; ++i) S[i] = p[i] >= 0.0 ? 1.0 : -1.0;
  cci_reflect(p, R, S, p_c, R_c);
}

void cci_band_half_weights(const double p[3], double band, double half[3]) {
  for (int k = 0; k < 3; ++k) {
    double u = cci_clamp(fabs(p[k]) / band, 0.0, 1.0);
    half[k] = 0.5 * (1.0 - u * u * (3.0 - 2.0 * u));
  }
}

double cci_features(const double p_c[3], const double R_c[9], const double hA[3], const double hB[3],
                    double x[CCI_N_FEATURES], double point_est[3], double normal_est[3], double overlap[15]) {
  int k;
  double weight;
  double pen = cci_patch_estimate(p_c, R_c, hA, hB, overlap, point_est, normal_est, &k, &weight);
  const double s = CCI_LENGTH_SCALE;
  for (int i = 0; i < 3; ++i) {
    x[i] = p_c[i] * s;
    x[3 + i] = hA[i] * s;
    x[6 + i] = hB[i] * s;
  }
  int o = 9;
  for (int a = 0; a < 3; ++a) /* b_a b_a^T, upper triangle, per axis of B */
    for (int i = 0; i < 3; ++i)
      for (int j = i; j < 3; ++j) x[o++] = R_c[3 * i + a] * R_c[3 * j + a];
  for (int i = 0; i < 15; ++i) x[27 + i] = cci_min(overlap[i], 0.5) * 10.0;
  for (int i = 0; i < 3; ++i) {
    x[42 + i] = normal_est[i];
    x[45 + i] = point_est[i] * s;
  }
  x[48] = log10(weight + 1e-9);
  x[49] = pen * 30.0;
  x[50] = k >= 6 ? 1.0 : 0.0;
  for (int c = 0; c < 8; ++c) { /* testbed.geometry.boxes.CORNER_SIGNS order */
    double sx = (c & 4) ? 1.0 : -1.0, sy = (c & 2) ? 1.0 : -1.0, sz = (c & 1) ? 1.0 : -1.0;
    double lx = sx * hB[0], ly = sy * hB[1], lz = sz * hB[2];
    double dB = HUGE_VAL;
    for (int i = 0; i < 3; ++i) { /* B's corner c in A, and how deep inside A it lies */
      double corner = p_c[i] + (lx * R_c[3 * i] + ly * R_c[3 * i + 1] + lz * R_c[3 * i + 2]);
      x[51 + 3 * c + i] = corner * s;
      dB = cci_min(dB, hA[i] - fabs(corner));
    }
    x[75 + c] = cci_clamp(dB, -0.5, 0.5) * 10.0;
    double ax = sx * hA[0] - p_c[0], ay = sy * hA[1] - p_c[1], az = sz * hA[2] - p_c[2];
    double dA = HUGE_VAL;
    for (int j = 0; j < 3; ++j) /* A's corner c in B */
      dA = cci_min(dA, hB[j] - fabs(ax * R_c[j] + ay * R_c[3 + j] + az * R_c[6 + j]));
    x[83 + c] = cci_clamp(dA, -0.5, 0.5) * 10.0;
  }
  return pen;
}
