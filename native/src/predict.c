/* predict.c: cc_predict and cc_depth (container_contact.h): input checks, the improved
 * predictor (exact face-on-face integral, geometric estimate, main network, resting expert,
 * octant-plane blend, clipping, hand-over) and the paper's predictor, one pose at a time.
 *
 * The C twin of learned_contact.predictors.improved.ContactPredictor._predict_numpy and
 * predictors.paper.PaperPredictor._predict_numpy with the checks of
 * learned_contact.interface.check_numpy; what each step computes and why is documented
 * there and in learned_contact.model (encodings, expert, quadrature). Frames and units: see
 * container_contact.h and cc_internal.h. */
#include <math.h>
#include <string.h>

#include "cc_internal.h"

/* rows x', y', z' of model.encodings.PAPER_FRAME: x' = (1, 1, 1) / sqrt(3), z' = (1, -1, 0) /
 * sqrt(2), y' = z' x x', exactly the numpy values */
const double cci_paper_frame[3][3] = {
    {0x1.279a74590331dp-1, 0x1.279a74590331dp-1, 0x1.279a74590331dp-1},
    {-0x1.a20bd700c2c3ep-2, -0x1.a20bd700c2c3ep-2, 0x1.a20bd700c2c3ep-1},
    {0x1.6a09e667f3bccp-1, -0x1.6a09e667f3bccp-1, 0.0},
};

/* ------------------------------------------------------------------ input checks */

/* The size rows (rows x 3) [m] against the supported sizes (interface.check_numpy, one
 * array): *bad_row and bad_value where a value is not finite (the first such row), else
 * *bad_row and bad_size where a row matches no supported size within SIZE_TOLERANCE on
 * every axis (the row farthest from its nearest supported size, as the numpy message names
 * it); else CC_OK. */
static int check_sizes(const double *s, size_t rows, const cc_model *model, int bad_size, int bad_value,
                       size_t *bad_row) {
  for (size_t r = 0; r < rows; ++r) {
    for (int c = 0; c < 3; ++c) {
      if (!isfinite(s[3 * r + c])) {
        *bad_row = r;
        return bad_value;
      }
    }
  }
  double worst = 0.0;
  int found = 0;
  for (size_t r = 0; r < rows; ++r) {
    double nearest = HUGE_VAL; /* min over the supported sizes of the largest axis difference */
    if (model->has_size_range) {
      const double *lo = model->size_range, *hi = model->size_range + 3;
      int inside = 1;
      for (int c = 0; c < 3; ++c)
        inside &= s[3 * r + c] >= lo[c] - CCI_SIZE_TOLERANCE && s[3 * r + c] <= hi[c] + CCI_SIZE_TOLERANCE;
      if (inside) nearest = 0.0;
    }
    for (int k = 0; k < model->n_sizes; ++k) {
      const double *t = model->supported_sizes + 3 * k;
      double d = fabs(s[3 * r] - t[0]);
      d = cci_max(d, fabs(s[3 * r + 1] - t[1]));
      d = cci_max(d, fabs(s[3 * r + 2] - t[2]));
      nearest = cci_min(nearest, d);
    }
    if (nearest > CCI_SIZE_TOLERANCE && (!found || nearest > worst)) {
      found = 1;
      worst = nearest;
      *bad_row = r;
    }
  }
  return found ? bad_size : CC_OK;
}

/* The checks of interface.check_numpy, in its order: non-finite poses (CC_BAD_POSE, the
 * first row), rotations (CC_BAD_ROTATION: |R^T R - I| > ROTATION_TOLERANCE or det < 0, the
 * first row), then size_A and size_B (check_sizes). */
static int check_inputs(const cc_model *model, size_t n, const double *p, const double *R, const double *sA,
                        size_t rows_A, const double *sB, size_t rows_B, size_t *bad_row) {
  for (size_t r = 0; r < n; ++r) {
    int ok = 1;
    for (int c = 0; c < 3; ++c) ok &= isfinite(p[3 * r + c]) != 0;
    for (int c = 0; c < 9; ++c) ok &= isfinite(R[9 * r + c]) != 0;
    if (!ok) {
      *bad_row = r;
      return CC_BAD_POSE;
    }
  }
  for (size_t r = 0; r < n; ++r) {
    const double *M = R + 9 * r;
    int bad = 0;
    for (int a = 0; a < 3; ++a) {
      for (int b = 0; b < 3; ++b) {
        double dot = M[a] * M[b] + M[3 + a] * M[3 + b] + M[6 + a] * M[6 + b];
        bad |= fabs(dot - (a == b ? 1.0 : 0.0)) > CCI_ROTATION_TOLERANCE;
      }
    }
    double det = M[0] * (M[4] * M[8] - M[5] * M[7]) - M[1] * (M[3] * M[8] - M[5] * M[6]) +
                 M[2] * (M[3] * M[7] - M[4] * M[6]);
    if (bad || det < 0.0) {
      *bad_row = r;
      return CC_BAD_ROTATION;
    }
  }
  int status = check_sizes(sA, rows_A, model, CC_SIZE_A_UNSUPPORTED, CC_SIZE_A_NOT_FINITE, bad_row);
  if (status != CC_OK) return status;
  return check_sizes(sB, rows_B, model, CC_SIZE_B_UNSUPPORTED, CC_SIZE_B_NOT_FINITE, bad_row);
}

int cci_check_inputs(const double *supported, int n_sizes, const double *size_range, size_t n, const double *p,
                     const double *R, const double *sA, size_t rows_A, const double *sB, size_t rows_B,
                     size_t *bad_row) {
  cc_model sizes_only;
  memset(&sizes_only, 0, sizeof sizes_only);
  sizes_only.n_sizes = n_sizes;
  sizes_only.supported_sizes = supported;
  if (size_range != NULL) {
    sizes_only.has_size_range = 1;
    memcpy(sizes_only.size_range, size_range, sizeof sizes_only.size_range);
  }
  return check_inputs(&sizes_only, n, p, R, sA, rows_A, sB, rows_B, bad_row);
}

/* The model's own consistency (what cc_model_load guarantees for a file it read; a model
 * built by hand is checked here): CC_OK or CC_BAD_ARGUMENT. */
static int check_model(const cc_model *model) {
  if (model == NULL || model->n_sizes < 1 || model->supported_sizes == NULL) return CC_BAD_ARGUMENT;
  if (model->kind == CC_KIND_IMPROVED) {
    if (cci_check_mlp(&model->main, CCI_N_FEATURES, CCI_IMPROVED_OUTPUTS) != CC_OK) return CC_BAD_ARGUMENT;
    if (model->has_expert) {
      if (cci_check_mlp(&model->expert, CCI_N_FEATURES, CCI_IMPROVED_OUTPUTS) != CC_OK) return CC_BAD_ARGUMENT;
      if (model->n_domain != 9 && model->n_domain != 11) return CC_BAD_ARGUMENT;
    }
    return CC_OK;
  }
  if (model->kind == CC_KIND_PAPER) return cci_check_mlp(&model->main, CCI_PAPER_INPUTS, CCI_PAPER_OUTPUTS);
  return CC_BAD_ARGUMENT;
}

/* The checks every entry point makes before its loop: arguments, the model, the inputs. */
static int check_call(const cc_model *model, size_t n, const double *p, const double *R, const double *sA,
                      size_t rows_A, const double *sB, size_t rows_B, size_t *bad_row) {
  size_t ignored;
  if (bad_row == NULL) bad_row = &ignored;
  *bad_row = 0;
  if (check_model(model) != CC_OK) return CC_BAD_ARGUMENT;
  if (n == 0) return CC_OK;
  if (p == NULL || R == NULL || sA == NULL || sB == NULL) return CC_BAD_ARGUMENT;
  if ((rows_A != 1 && rows_A != n) || (rows_B != 1 && rows_B != n)) return CC_BAD_ARGUMENT;
  return check_inputs(model, n, p, R, sA, rows_A, sB, rows_B, bad_row);
}

/* ------------------------------------------------------------------ the resting expert */

/* model.expert._ramp_off: 1 for t <= t_in, 0 for t >= t_out, smoothstep (C1) between. */
static inline double ramp_off(double t, double t_in, double t_out) {
  double u = cci_clamp((t - t_in) / (t_out - t_in), 0.0, 1.0);
  return 1.0 - u * u * (3.0 - 2.0 * u);
}

/* model.expert.gate for one canonical pose: p_c (3) [m], R_c (9), half extents hA, hB [m],
 * depth [m]; domain: DOMAIN_FIELDS (11: offsets as fractions of the edge of support) or
 * DOMAIN_FIELDS_V2 (9: one offset bound [m]). */
static double expert_gate(const double p_c[3], const double R_c[9], const double hA[3], const double hB[3],
                          double depth, const double *d, int n_domain) {
  double sin_tilt = hypot(R_c[2], R_c[5]);
  double g = ramp_off(depth, d[0], d[1]) * ramp_off(sin_tilt, d[2], d[3]) * ramp_off(fabs(R_c[3]), d[4], d[5]);
  if (n_domain == 9) return g * ramp_off(fabs(p_c[0]), d[6], d[7]) * ramp_off(fabs(p_c[1]), d[6], d[7]);
  double u_x = fabs(p_c[0]) / cci_max(hA[0], hB[0]);
  double u_y = fabs(p_c[1]) / cci_max(hA[1], hB[1]);
  return g * ramp_off(u_x, d[6], d[7]) * ramp_off(u_y, d[8], d[9]);
}

/* model.expert.slab_ratio on the faces that meet (expert.slab_axes of the overlaps (15) [m])
 * for one canonical pose: the rise of B's face over the shared footprint / depth, +inf where
 * depth <= 0. */
static double slab_ratio(const double R_c[9], const double hA[3], const double hB[3], double depth,
                         const double overlap[15]) {
  int face = 0, j, k;
  double best = overlap[0];
  for (int f = 1; f < 6; ++f) {
    if (overlap[f] < best) {
      face = f;
      best = overlap[f];
    }
  }
  if (face < 3) { /* A's face k: j = B's axis most aligned with A's k */
    k = face;
    j = 0;
    for (int m = 1; m < 3; ++m)
      if (fabs(R_c[3 * face + m]) > fabs(R_c[3 * face + j])) j = m;
  } else { /* B's face j: k = A's axis most aligned with B's j */
    j = face - 3;
    k = 0;
    for (int i = 1; i < 3; ++i)
      if (fabs(R_c[3 * i + j]) > fabs(R_c[3 * k + j])) k = i;
  }
  double rise = 0.0;
  for (int i = 0; i < 3; ++i) {
    int m = -1; /* B's axis other than j most aligned with A's i */
    for (int q = 0; q < 3; ++q)
      if (q != j && (m < 0 || fabs(R_c[3 * i + q]) > fabs(R_c[3 * i + m]))) m = q;
    rise = rise + (i == k ? 0.0 : fabs(R_c[3 * i + j]) * cci_min(hA[i], hB[m]));
  }
  rise = 2.0 * rise;
  return depth > 0.0 ? rise / depth : HUGE_VAL;
}

void cci_expert_weights(const double p_c[3], const double R_c[9], const double hA[3], const double hB[3],
                        double depth, const double overlap[15], const double *domain, int n_domain, int has_expert,
                        double *w_main, double *w_expert) {
  double g = has_expert ? expert_gate(p_c, R_c, hA, hB, depth, domain, n_domain) : 0.0;
  double r_slab = has_expert ? domain[n_domain - 1] : CCI_R_SLAB;
  double s = 1.0 - ramp_off(slab_ratio(R_c, hA, hB, depth, overlap), 0.0, r_slab);
  *w_main = (1.0 - g) * s;
  *w_expert = g * s;
}

/* ------------------------------------------------------------------ the improved predictor */

/* ContactPredictor._learned for one pose: the geometric estimate corrected by the networks
 * in the octant frames of encodings.frame_blend (own frame, then the sign flips in FLIPS
 * order, each where its weight is not 0), normalised (the SAT normal where that fails),
 * clipped into A's box grown by CLIP_MARGIN where `out`. sat_n (3) the SAT normal, depth [m]. */
static void learned(const cc_model *model, const double p[3], const double R[9], const double hA[3],
                    const double hB[3], const double sat_n[3], double depth, int out, double point[3],
                    double normal[3]) {
  double S[3], p_c[3], R_c[9], half[3], sigma[3], x[CCI_N_FEATURES], pe[3], ne[3], overlap[15];
  double y[CCI_IMPROVED_OUTPUTS], ye[CCI_IMPROVED_OUTPUTS], h0[CCI_MAX_WIDTH], h1[CCI_MAX_WIDTH];
  double l_point[3] = {0.0, 0.0, 0.0}, l_normal[3] = {0.0, 0.0, 0.0};
  cci_canonicalise(p, R, S, p_c, R_c);
  cci_band_half_weights(p, CCI_SYMMETRY_BAND, half);
  for (int f = 0; f < 8; ++f) {
    double coef = 1.0;
    for (int c = 0; c < 3; ++c) {
      int flip = (f >> (2 - c)) & 1;
      coef = coef * (flip ? half[c] : 1.0 - half[c]);
      sigma[c] = flip ? -S[c] : S[c];
    }
    if (!(coef > 0.0)) continue;
    cci_reflect(p, R, sigma, p_c, R_c);
    cci_features(p_c, R_c, hA, hB, x, pe, ne, overlap);
    double w_main, w_expert; /* with the pose's depth, as the numpy path */
    cci_expert_weights(p_c, R_c, hA, hB, depth, overlap, model->domain, model->n_domain, model->has_expert, &w_main,
                       &w_expert);
    if (w_main > 0.0) {
      cci_mlp_forward(&model->main, x, y, h0, h1);
      for (int c = 0; c < CCI_IMPROVED_OUTPUTS; ++c) y[c] = w_main * y[c];
    } else {
      for (int c = 0; c < CCI_IMPROVED_OUTPUTS; ++c) y[c] = 0.0;
    }
    if (w_expert > 0.0) {
      cci_mlp_forward(&model->expert, x, ye, h0, h1);
      for (int c = 0; c < CCI_IMPROVED_OUTPUTS; ++c) y[c] += w_expert * ye[c];
    }
    for (int c = 0; c < 3; ++c) {
      l_point[c] += coef * (sigma[c] * (pe[c] + CCI_POINT_STEP * y[c]));
      l_normal[c] += coef * (sigma[c] * (ne[c] + y[3 + c]));
    }
  }
  double length2 = 0.0;
  for (int c = 0; c < 3; ++c) length2 += l_normal[c] * l_normal[c];
  double length = sqrt(length2);
  int ok = isfinite(length) && length > 1e-9;
  for (int c = 0; c < 3; ++c) {
    normal[c] = ok ? l_normal[c] / length : sat_n[c];
    double v = l_point[c];
    if (out) {
      double bound = hA[c] + CCI_CLIP_MARGIN;
      v = cci_clamp(v, -bound, bound);
    }
    point[c] = v;
  }
}

/* ContactPredictor._predict_numpy for one pose (outside = clip): the exact face-on-face centre
 * of pressure where two faces meet (depth >= DOMAIN_DEPTH[0] and a weight > 0), handed over by
 * the tilt between them (POINT_TILT for the point, NORMAL_TILT for the normal) to the learned
 * answer, which is evaluated only where a hand-over weight is below 1; the quadrature runs
 * only where its weights can be above 0 (elsewhere the numpy path's 0 x q is 0). Returns the
 * separating-axis depth [m]. */
static double improved_one(const cc_model *model, const double p[3], const double R[9], const double sA[3],
                           const double sB[3], double point[3], double normal[3]) {
  double hA[3], hB[3], axes[15][3], overlap[15], sat_n[3], q_point[3], q_normal[3];
  for (int c = 0; c < 3; ++c) {
    hA[c] = 0.5 * sA[c];
    hB[c] = 0.5 * sB[c];
  }
  int k;
  cci_sat_overlap(p, R, hA, hB, axes, overlap);
  double pen = cci_sat_normal(p, (const double(*)[3])axes, overlap, sat_n, &k);
  int out = pen < CCI_DOMAIN_DEPTH_LO || pen > CCI_DOMAIN_DEPTH_HI;
  double f_point = 0.0, f_normal = 0.0, q_weight = 0.0;
  double tilt = cci_face_tilt(R, sat_n);
  if (pen < CCI_DOMAIN_DEPTH_LO || tilt >= CCI_POINT_TILT_1) {
    for (int c = 0; c < 3; ++c) q_point[c] = q_normal[c] = 0.0;
  } else {
    q_weight = cci_face_on_face(p, R, hA, hB, sat_n, q_point, q_normal, &tilt);
  }
  if (q_weight > 0.0) { /* the faces meet (from DOMAIN_DEPTH[0] on; no upper bound) */
    f_point = cci_hand_over(tilt, CCI_POINT_TILT_0, CCI_POINT_TILT_1);
    f_normal = cci_hand_over(tilt, CCI_NORMAL_TILT_0, CCI_NORMAL_TILT_1);
  }
  if (!(f_point < 1.0 || f_normal < 1.0)) { /* the quadrature alone: no network runs */
    for (int c = 0; c < 3; ++c) {
      point[c] = q_point[c];
      normal[c] = q_normal[c];
    }
    return pen;
  }
  double l_point[3], l_normal[3];
  learned(model, p, R, hA, hB, sat_n, pen, out, l_point, l_normal);
  double length2 = 0.0;
  for (int c = 0; c < 3; ++c) {
    point[c] = f_point * q_point[c] + (1.0 - f_point) * l_point[c];
    normal[c] = f_normal * q_normal[c] + (1.0 - f_normal) * l_normal[c];
    length2 += normal[c] * normal[c];
  }
  double length = sqrt(length2);
  for (int c = 0; c < 3; ++c) normal[c] = normal[c] / length;
  return pen;
}

/* ------------------------------------------------------------------ the paper's predictor */

/* out = S * (the unit vector of [azimuth, elevation] [rad] in PAPER_FRAME) (encodings.from_spherical). */
static void from_spherical(double az, double el, const double S[3], double out[3]) {
  double w0 = cos(el) * cos(az), w1 = cos(el) * sin(az), w2 = sin(el);
  for (int k = 0; k < 3; ++k)
    out[k] = S[k] * (w0 * cci_paper_frame[0][k] + w1 * cci_paper_frame[1][k] + w2 * cci_paper_frame[2][k]);
}

/* PaperPredictor._predict_numpy for one pose: canonical position and roll-pitch-yaw in,
 * spherical angles of the point direction and of the force out; the point is where its ray
 * leaves A. */
static void paper_one(const cc_model *model, const double p[3], const double R[9], const double sA[3],
                      double point[3], double normal[3]) {
  double S[3], p_c[3], R_c[9], x[CCI_PAPER_INPUTS], y[CCI_PAPER_OUTPUTS], d[3], h0[CCI_MAX_WIDTH], h1[CCI_MAX_WIDTH];
  cci_canonicalise(p, R, S, p_c, R_c);
  double det = R_c[0] * (R_c[4] * R_c[8] - R_c[5] * R_c[7]) - R_c[1] * (R_c[3] * R_c[8] - R_c[5] * R_c[6]) +
               R_c[2] * (R_c[3] * R_c[7] - R_c[4] * R_c[6]);
  double flip = det < 0.0 ? -1.0 : 1.0; /* encodings.proper: the third column flipped where improper */
  x[0] = p_c[0];
  x[1] = p_c[1];
  x[2] = p_c[2];
  x[3] = atan2(R_c[7], R_c[8] * flip); /* testbed.geometry.rotations.rpy_from_rotation */
  x[4] = asin(cci_clamp(-R_c[6], -1.0, 1.0));
  x[5] = atan2(R_c[3], R_c[0]);
  cci_mlp_forward(&model->main, x, y, h0, h1);
  from_spherical(y[0], y[1], S, d);
  double reach = 0.0;
  for (int k = 0; k < 3; ++k) reach = cci_max(reach, fabs(d[k]) / (0.5 * sA[k]));
  for (int k = 0; k < 3; ++k) point[k] = d[k] / reach;
  from_spherical(y[2], y[3], S, d);
  double length = sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
  for (int k = 0; k < 3; ++k) normal[k] = d[k] / length;
}

/* ------------------------------------------------------------------ the public API */

int cc_predict(const cc_model *model, size_t n, const double *p_AB, const double *R_AB, const double *size_A,
               size_t rows_A, const double *size_B, size_t rows_B, double *point_A, double *normal_A, double *depth,
               size_t *bad_row) {
  int status = check_call(model, n, p_AB, R_AB, size_A, rows_A, size_B, rows_B, bad_row);
  if (status != CC_OK || n == 0) return status;
  if (point_A == NULL || normal_A == NULL) return CC_BAD_ARGUMENT;
  for (size_t r = 0; r < n; ++r) {
    const double *sA = size_A + (rows_A == 1 ? 0 : 3 * r), *sB = size_B + (rows_B == 1 ? 0 : 3 * r);
    const double *p = p_AB + 3 * r, *R = R_AB + 9 * r;
    if (model->kind == CC_KIND_IMPROVED) {
      double pen = improved_one(model, p, R, sA, sB, point_A + 3 * r, normal_A + 3 * r);
      if (depth != NULL) depth[r] = pen;
    } else {
      paper_one(model, p, R, sA, point_A + 3 * r, normal_A + 3 * r);
      if (depth != NULL) {
        double hA[3] = {0.5 * sA[0], 0.5 * sA[1], 0.5 * sA[2]}, hB[3] = {0.5 * sB[0], 0.5 * sB[1], 0.5 * sB[2]};
        depth[r] = cci_sat_depth(p, R, hA, hB);
      }
    }
  }
  return CC_OK;
}

int cc_depth(const cc_model *model, size_t n, const double *p_AB, const double *R_AB, const double *size_A,
             size_t rows_A, const double *size_B, size_t rows_B, double *depth, size_t *bad_row) {
  int status = check_call(model, n, p_AB, R_AB, size_A, rows_A, size_B, rows_B, bad_row);
  if (status != CC_OK || n == 0) return status;
  if (depth == NULL) return CC_BAD_ARGUMENT;
  for (size_t r = 0; r < n; ++r) {
    const double *sA = size_A + (rows_A == 1 ? 0 : 3 * r), *sB = size_B + (rows_B == 1 ? 0 : 3 * r);
    double hA[3] = {0.5 * sA[0], 0.5 * sA[1], 0.5 * sA[2]}, hB[3] = {0.5 * sB[0], 0.5 * sB[1], 0.5 * sB[2]};
    depth[r] = cci_sat_depth(p_AB + 3 * r, R_AB + 9 * r, hA, hB);
  }
  return CC_OK;
}
