/* step_damping.c: Hunt-Crossley's damping torque of a pair whose force is the exact field contact
 * (grid 0): the damping pressure spread over the surface, from the field contact's damping inertia. */
#include <math.h>
#include <string.h>

#include "step_internal.h"

/* tau += Hunt-Crossley's torque on B of pair r from the pressure spread over its surface: the damping
 * pressure d p v_n(x) at each point, v_n(x) = v_n(c) + (w_B - w_A) . (r x m), sums to the force's
 * d F v_n(c) at the centre of pressure c and to the torque -d J (w_B - w_A) about it (J the field
 * contact's damping inertia, rotated to W). Backward Euler in the relative rate with the two bodies'
 * inverse inertias K: w' = (1 + h d K J)^-1 w, tau = -d J w' (an explicit torque is unstable where
 * h d |J| / I > 2: a 20 t box landing flat, 2.1). The tension the linear form would put on the patch's
 * rising side (where d v_n(x) < -1) is not clipped. */
void ccs_damping_torque(const cc_step *s, size_t r, size_t i, size_t j, const double *wi, const double *wj,
                           double d, double h, double *tau) {
  const double *JA = s->Jd + 9 * r, *Ri = s->R + 9 * i;
  double RJ[9], J[9], K[9], A[9], w[3];
  for (int a = 0; a < 3; ++a) /* J_W = R_WA J_A R_WA^T, A = body i */
    for (int b = 0; b < 3; ++b) RJ[3 * a + b] = Ri[3 * a] * JA[b] + Ri[3 * a + 1] * JA[3 + b] + Ri[3 * a + 2] * JA[6 + b];
  for (int a = 0; a < 3; ++a)
    for (int b = 0; b < 3; ++b) J[3 * a + b] = RJ[3 * a] * Ri[3 * b] + RJ[3 * a + 1] * Ri[3 * b + 1] + RJ[3 * a + 2] * Ri[3 * b + 2];
  /* each body's inverse inertia times the touching pairs it is in: the pairs' torques are solved one
   * at a time, and a light box between two contacts that each removed their whole relative rate in
   * one step got twice its due (heavy_on_empty at 1e9 Pa diverged at t = 0.24 s) */
  const double *Ii = s->invI + 9 * i, *Ij = s->invI + 9 * j;
  double ni = py_max(1.0, s->n_touch[i]), nj = py_max(1.0, s->n_touch[j]);
  for (int a = 0; a < 9; ++a) K[a] = ni * Ii[a] + nj * Ij[a];
  for (int a = 0; a < 3; ++a) {
    w[a] = wj[a] - wi[a];
    for (int b = 0; b < 3; ++b)
      A[3 * a + b] = (a == b ? 1.0 : 0.0) + h * d * (K[3 * a] * J[b] + K[3 * a + 1] * J[3 + b] + K[3 * a + 2] * J[6 + b]);
  }
  /* solve A w' = w (Cramer's rule; A is I + a positive semi-definite product, never singular) */
  double det = A[0] * (A[4] * A[8] - A[5] * A[7]) - A[1] * (A[3] * A[8] - A[5] * A[6]) + A[2] * (A[3] * A[7] - A[4] * A[6]);
  if (!(fabs(det) > 0)) return;
  double x[3];
  for (int c = 0; c < 3; ++c) {
    double B[9];
    memcpy(B, A, sizeof B);
    for (int a = 0; a < 3; ++a) B[3 * a + c] = w[a];
    x[c] = (B[0] * (B[4] * B[8] - B[5] * B[7]) - B[1] * (B[3] * B[8] - B[5] * B[6]) + B[2] * (B[3] * B[7] - B[4] * B[6])) / det;
  }
  for (int a = 0; a < 3; ++a) tau[a] -= d * (J[3 * a] * x[0] + J[3 * a + 1] * x[1] + J[3 * a + 2] * x[2]);
}
