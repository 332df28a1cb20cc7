/* step_hosts.c: body state from Drake's and MuJoCo's arrays, wrenches back to MuJoCo
 * (container_contact_step.h's host helpers; formerly numba kernels of the testbed's hosts). */
#include "container_contact_step.h"

void cc_step_bodies_from_drake(size_t m, const double *x, const int64_t *q_start, const int64_t *v_start,
                               const double *fixed_p, const double *fixed_R, const uint8_t *free,
                               double *p, double *R, double *w, double *v) {
  for (size_t i = 0; i < m; ++i) {
    double *Ri = R + 9 * i;
    for (int a = 0; a < 3; ++a) {
      p[3 * i + a] = fixed_p[3 * i + a];
      w[3 * i + a] = 0.0;
      v[3 * i + a] = 0.0;
    }
    for (int a = 0; a < 9; ++a) Ri[a] = fixed_R[9 * i + a];
    if (!free[i]) continue;
    const double *q = x + q_start[i];
    double a = q[0], b = q[1], c = q[2], d = q[3];
    double s = 1.0 / (a * a + b * b + c * c + d * d);
    Ri[0] = 1 - 2 * s * (c * c + d * d);
    Ri[1] = 2 * s * (b * c - a * d);
    Ri[2] = 2 * s * (b * d + a * c);
    Ri[3] = 2 * s * (b * c + a * d);
    Ri[4] = 1 - 2 * s * (b * b + d * d);
    Ri[5] = 2 * s * (c * d - a * b);
    Ri[6] = 2 * s * (b * d - a * c);
    Ri[7] = 2 * s * (c * d + a * b);
    Ri[8] = 1 - 2 * s * (b * b + c * c);
    for (int k = 0; k < 3; ++k) {
      p[3 * i + k] = q[4 + k];
      w[3 * i + k] = x[v_start[i] + k];
      v[3 * i + k] = x[v_start[i] + 3 + k];
    }
  }
}

void cc_step_bodies_from_mujoco(size_t m, const double *xpos, const double *xmat, const double *qvel,
                                const int64_t *body, const int64_t *dof, const uint8_t *free,
                                double *p, double *R, double *w, double *v) {
  for (size_t i = 0; i < m; ++i) {
    int64_t b = body[i];
    for (int a = 0; a < 3; ++a) {
      p[3 * i + a] = xpos[3 * b + a];
      for (int c = 0; c < 3; ++c) R[9 * i + 3 * a + c] = xmat[9 * b + 3 * a + c];
      w[3 * i + a] = 0.0;
      v[3 * i + a] = 0.0;
    }
    if (!free[i]) continue;
    const double *qv = qvel + dof[i];
    for (int a = 0; a < 3; ++a) {
      v[3 * i + a] = qv[a];
      double acc = 0.0;
      for (int c = 0; c < 3; ++c) acc += R[9 * i + 3 * a + c] * qv[3 + c];
      w[3 * i + a] = acc;
    }
  }
}

void cc_step_wrench_to_mujoco(size_t m, size_t nbody, const double *out, const int64_t *body, const uint8_t *free,
                              const double *xpos, const double *xipos, double *xfrc) {
  for (size_t i = 0; i < 6 * nbody; ++i) xfrc[i] = 0.0;
  for (size_t i = 0; i < m; ++i) {
    if (!free[i]) continue;
    int64_t b = body[i];
    const double *o = out + 6 * i;
    double f0 = o[3], f1 = o[4], f2 = o[5];
    double r0 = xipos[3 * b] - xpos[3 * b], r1 = xipos[3 * b + 1] - xpos[3 * b + 1],
           r2 = xipos[3 * b + 2] - xpos[3 * b + 2];
    double *x = xfrc + 6 * b;
    x[0] = f0;
    x[1] = f1;
    x[2] = f2;
    x[3] = o[0] - (r1 * f2 - r2 * f1);
    x[4] = o[1] - (r2 * f0 - r0 * f2);
    x[5] = o[2] - (r0 * f1 - r1 * f0);
  }
}
