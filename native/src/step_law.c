/* step_law.c: the force law over the step's pairs: each pair's held row and kappa, the normal
 * and friction impulses solved over the pairs, the bodies' wrenches, and the held state the next
 * step reads (anchors, stuck flags, forces). */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "step_internal.h"

/* ------------------------------------------------------------------ the force law */

/* acc[i] += sign M_i^-1 (wrench of a force f along unit n with moment term c = r x n) */
static inline void apply_force(double *acc, size_t i, double sign, const double *inv_m, const double *invI, double f,
                               const double *n, const double *c) {
  const double *I = invI + 9 * i;
  for (int a = 0; a < 3; ++a) {
    acc[6 * i + 3 + a] += sign * inv_m[i] * f * n[a];
    acc[6 * i + a] += sign * f * (I[3 * a + 0] * c[0] + I[3 * a + 1] * c[1] + I[3 * a + 2] * c[2]);
  }
}

/* (a_B + alpha_B x r_B - a_A - alpha_A x r_A) . n of A = i and B = j */
static inline double normal_rate(const double *acc, size_t i, size_t j, const double *r_A, const double *r_B,
                                 const double *n) {
  double out = 0.0;
  const double *ai = acc + 6 * i, *aj = acc + 6 * j;
  for (int a = 0; a < 3; ++a) {
    int b = (a + 1) % 3, c = (a + 2) % 3;
    out += n[a] * (aj[3 + a] + aj[b] * r_B[c] - aj[c] * r_B[b] - ai[3 + a] - (ai[b] * r_A[c] - ai[c] * r_A[b]));
  }
  return out;
}

/* inv_m [1/kg] and R I_Bo^-1 R^T for the bodies marked need with finite mass; zeros elsewhere */
static void inverse_inertias(cc_step *s) {
  size_t m = s->m;
  memset(s->inv_m, 0, m * sizeof(double));
  memset(s->invI, 0, 9 * m * sizeof(double));
  for (size_t i = 0; i < m; ++i) {
    if (!s->need[i] || !isfinite(s->mass[i])) continue;
    s->inv_m[i] = 1.0 / s->mass[i];
    const double *I = s->I_Bo + 9 * i;
#define I_(r, c) I[3 * (r) + (c)]
    double c00 = I_(1, 1) * I_(2, 2) - I_(1, 2) * I_(2, 1);
    double c01 = I_(1, 2) * I_(2, 0) - I_(1, 0) * I_(2, 2);
    double c02 = I_(1, 0) * I_(2, 1) - I_(1, 1) * I_(2, 0);
    double det = I_(0, 0) * c00 + I_(0, 1) * c01 + I_(0, 2) * c02;
    double B[9];
    B[0] = c00 / det;
    B[3] = c01 / det;
    B[6] = c02 / det;
    B[1] = (I_(0, 2) * I_(2, 1) - I_(0, 1) * I_(2, 2)) / det;
    B[2] = (I_(0, 1) * I_(1, 2) - I_(0, 2) * I_(1, 1)) / det;
    B[4] = (I_(0, 0) * I_(2, 2) - I_(0, 2) * I_(2, 0)) / det;
    B[5] = (I_(0, 2) * I_(1, 0) - I_(0, 0) * I_(1, 2)) / det;
    B[7] = (I_(0, 1) * I_(2, 0) - I_(0, 0) * I_(2, 1)) / det;
    B[8] = (I_(0, 0) * I_(1, 1) - I_(0, 1) * I_(1, 0)) / det;
#undef I_
    /* invI[a][b] = sum over (c, e), c-major, of (Ri[a][c] B[c][e]) Ri[b][e]: the nine sums
     * advance together (the same terms in the same order as one sum at a time, without its
     * chain of 81 dependent additions) */
    const double *Ri = s->R + 9 * i;
    double a00 = 0.0, a01 = 0.0, a02 = 0.0, a10 = 0.0, a11 = 0.0, a12 = 0.0, a20 = 0.0, a21 = 0.0, a22 = 0.0;
    for (int c = 0; c < 3; ++c)
      for (int e = 0; e < 3; ++e) {
        double Bce = B[3 * c + e];
        double x0 = Ri[c] * Bce, x1 = Ri[3 + c] * Bce, x2 = Ri[6 + c] * Bce; /* Ri[a][c] B[c][e] */
        double r0 = Ri[e], r1 = Ri[3 + e], r2 = Ri[6 + e];                    /* Ri[b][e] */
        a00 += x0 * r0;
        a01 += x0 * r1;
        a02 += x0 * r2;
        a10 += x1 * r0;
        a11 += x1 * r1;
        a12 += x1 * r2;
        a20 += x2 * r0;
        a21 += x2 * r1;
        a22 += x2 * r2;
      }
    double *out = s->invI + 9 * i;
    out[0] = a00;
    out[1] = a01;
    out[2] = a02;
    out[3] = a10;
    out[4] = a11;
    out[5] = a12;
    out[6] = a20;
    out[7] = a21;
    out[8] = a22;
  }
}

/* the held rows and kappa of each pair (gather_pairs): a merge of two ascending key lists */
void ccs_gather_pairs(cc_step *s) {
  size_t m = s->m, h = 0;
  int T = s->par.n_types;
  for (size_t r = 0; r < s->k; ++r) {
    int64_t key = s->ia[r] * (int64_t)m + s->ib[r];
    s->kap[r] = s->kappa[s->type[s->ia[r]] * T + s->type[s->ib[r]]];
    while (h < s->n_held && s->keys[h] < key) ++h;
    if (h < s->n_held && s->keys[h] == key)
      memcpy(s->held + ROW * r, s->rows + ROW * h, ROW * sizeof(double));
    else
      memset(s->held + ROW * r, 0, ROW * sizeof(double));
  }
}

/* pair_wrenches: out (m, 6); the per-pair records; anchors_next, stuck_next, history_next */
void ccs_pair_wrenches(cc_step *s, const double *w, const double *v, double *out) {
  const size_t m = s->m, k = s->k;
  const double *p = s->p, *R = s->R, *mass = s->mass, *I_Bo = s->I_Bo;
  const int64_t *ia = s->ia, *ib = s->ib;
  const cc_step_params *q = &s->par;
  const double dissipation = q->dissipation, mu = q->mu, slip = q->slip, stiction = q->stiction, h = q->h;
  const double stick_hw = q->stick_hw, stick_zeta = q->stick_zeta;
  memset(out, 0, 6 * m * sizeof(double));
  memset(s->fn, 0, k * sizeof(double));
  memset(s->f_W, 0, 3 * k * sizeof(double));
  memset(s->p_W, 0, 3 * k * sizeof(double));
  memset(s->n_W, 0, 3 * k * sizeof(double));
  memset(s->area, 0, k * sizeof(double));
  memset(s->anchors_next, 0, 6 * k * sizeof(double));
  memset(s->stuck_next, 0, k * sizeof(double));
  memset(s->history_next, 0, BODY * m * sizeof(double));
  for (size_t i = 0; i < m; ++i)
    for (int a = 0; a < 3; ++a) {
      s->history_next[BODY * i + a] = v[3 * i + a];
      s->history_next[BODY * i + 3 + a] = w[3 * i + a];
    }
  memset(s->touch, 0, k);
  memset(s->need, 0, m);
  memset(s->F_el, 0, k * sizeof(double));
  memset(s->g, 0, k * sizeof(double));
  memset(s->W_rr, 0, k * sizeof(double));
  memset(s->vn0, 0, k * sizeof(double));
  memset(s->an_ext, 0, k * sizeof(double));
  memset(s->rA, 0, 3 * k * sizeof(double));
  memset(s->rB, 0, 3 * k * sizeof(double));
  memset(s->cA, 0, 3 * k * sizeof(double));
  memset(s->cB, 0, 3 * k * sizeof(double));
  /* pass 1: geometry, the free normal rate, the implicit gains */
  double hA[3], hB[3];
  for (size_t r = 0; r < k; ++r) {
    for (int a = 0; a < 3; ++a) {
      hA[a] = 0.5 * s->size_A[3 * r + a];
      hB[a] = 0.5 * s->size_B[3 * r + a];
    }
    double F, area, k_n;
    double *Jd = s->Jd + 9 * r;
    memset(Jd, 0, 9 * sizeof(double));
    if (s->given != NULL) { /* the caller's own model's answer (cc_step_force_law_given) */
      F = s->given[3 * r];
      k_n = py_max(0.0, s->given[3 * r + 1]);
      area = py_max(0.0, s->given[3 * r + 2]);
    } else if (q->grid == 0) /* the exact field contact, any pose (step_field.c) */
      ccs_field_stiff(s->p_AB + 3 * r, s->R_AB + 9 * r, hA, hB, s->kap[r], &F, &area, &k_n, Jd);
    else /* the Winkler foundation on the face overlap (step_elastic.c) */
      ccs_elastic_stiff(s->p_AB + 3 * r, s->R_AB + 9 * r, hA, hB, s->kap[r], q->grid, &F, &area, &k_n);
    if (F <= 0) continue;
    size_t i = (size_t)ia[r], j = (size_t)ib[r];
    s->touch[r] = 1;
    s->need[i] = 1;
    s->need[j] = 1;
    s->F_el[r] = F;
    s->area[r] = area;
    s->g[r] = k_n * h + dissipation * F;
    const double *Ri = R + 9 * i, *pA = s->point_A + 3 * r, *nA = s->normal_A + 3 * r;
    for (int a = 0; a < 3; ++a) {
      s->p_W[3 * r + a] = p[3 * i + a] + Ri[3 * a + 0] * pA[0] + Ri[3 * a + 1] * pA[1] + Ri[3 * a + 2] * pA[2];
      s->n_W[3 * r + a] = Ri[3 * a + 0] * nA[0] + Ri[3 * a + 1] * nA[1] + Ri[3 * a + 2] * nA[2];
    }
    for (int a = 0; a < 3; ++a) {
      s->rA[3 * r + a] = s->p_W[3 * r + a] - p[3 * i + a];
      s->rB[3 * r + a] = s->p_W[3 * r + a] - p[3 * j + a];
    }
  }
  inverse_inertias(s);
  double *acc = s->acc, *dacc = s->dacc;
  const double *inv_m = s->inv_m, *invI = s->invI, *history = s->history;
  memset(acc, 0, 6 * m * sizeof(double));
  for (size_t i = 0; i < m; ++i) {
    if (s->need[i] && isfinite(mass[i]) && isfinite(history[BODY * i])) {
      const double *hi = history + BODY * i, *I = invI + 9 * i;
      for (int a = 0; a < 3; ++a) {
        acc[6 * i + 3 + a] = (v[3 * i + a] - hi[a]) / h - inv_m[i] * hi[9 + a];
        acc[6 * i + a] = (w[3 * i + a] - hi[3 + a]) / h -
                         (I[3 * a + 0] * hi[6] + I[3 * a + 1] * hi[7] + I[3 * a + 2] * hi[8]);
      }
    }
  }
  for (size_t r = 0; r < k; ++r) {
    if (!s->touch[r]) continue;
    size_t i = (size_t)ia[r], j = (size_t)ib[r];
    const double *n = s->n_W + 3 * r, *rA = s->rA + 3 * r, *rB = s->rB + 3 * r;
    double *cA = s->cA + 3 * r, *cB = s->cB + 3 * r;
    const double *wi = w + 3 * i, *wj = w + 3 * j, *vi = v + 3 * i, *vj = v + 3 * j;
    double vn = 0.0;
    for (int a = 0; a < 3; ++a) {
      int b = (a + 1) % 3, c = (a + 2) % 3;
      cA[a] = rA[b] * n[c] - rA[c] * n[b];
      cB[a] = rB[b] * n[c] - rB[c] * n[b];
      vn += n[a] * (vj[a] + wj[b] * rB[c] - wj[c] * rB[b] - vi[a] - (wi[b] * rA[c] - wi[c] * rA[b]));
    }
    s->vn0[r] = vn;
    s->an_ext[r] = normal_rate(acc, i, j, rA, rB, n);
    double wr = inv_m[i] + inv_m[j];
    const double *Ii = invI + 9 * i, *Ij = invI + 9 * j;
    for (int a = 0; a < 3; ++a)
      for (int b = 0; b < 3; ++b) wr += cA[a] * Ii[3 * a + b] * cA[b] + cB[a] * Ij[3 * a + b] * cB[b];
    s->W_rr[r] = wr;
  }
  /* projected Gauss-Seidel on f_r = max(0, F_el - g (vn + h an)), an through every pair's f */
  double *f = s->f;
  memset(f, 0, k * sizeof(double));
  memset(dacc, 0, 6 * m * sizeof(double));
  for (size_t r = 0; r < k; ++r) {
    double fn_prev = s->held[ROW * r + 7];
    if (s->touch[r] && fn_prev > 0) {
      f[r] = fn_prev;
      apply_force(dacc, (size_t)ib[r], 1.0, inv_m, invI, f[r], s->n_W + 3 * r, s->cB + 3 * r);
      apply_force(dacc, (size_t)ia[r], -1.0, inv_m, invI, f[r], s->n_W + 3 * r, s->cA + 3 * r);
    }
  }
  for (int sweep = 0; sweep < q->sweeps; ++sweep) {
    for (size_t r = 0; r < k; ++r) {
      if (!s->touch[r]) continue;
      size_t i = (size_t)ia[r], j = (size_t)ib[r];
      double an = s->an_ext[r] + normal_rate(dacc, i, j, s->rA + 3 * r, s->rB + 3 * r, s->n_W + 3 * r);
      double residual = s->F_el[r] - s->g[r] * (s->vn0[r] + h * an) - f[r];
      double f_new = py_max(0.0, f[r] + residual / (1.0 + s->g[r] * h * s->W_rr[r]));
      double df = f_new - f[r];
      if (df != 0.0) {
        apply_force(dacc, j, 1.0, inv_m, invI, df, s->n_W + 3 * r, s->cB + 3 * r);
        apply_force(dacc, i, -1.0, inv_m, invI, df, s->n_W + 3 * r, s->cA + 3 * r);
        f[r] = f_new;
      }
    }
  }
  /* pass 2: friction on the solved normal force, the wrenches */
  memset(s->n_touch, 0, m * sizeof(double));
  for (size_t r = 0; r < k; ++r)
    if (s->touch[r]) {
      s->n_touch[ia[r]] += 1.0;
      s->n_touch[ib[r]] += 1.0;
    }
  for (size_t r = 0; r < k; ++r) {
    if (!s->touch[r]) continue;
    size_t i = (size_t)ia[r], j = (size_t)ib[r];
    double fn = f[r];
    const double *nw = s->n_W + 3 * r, *rA = s->rA + 3 * r, *rB = s->rB + 3 * r;
    const double *cA = s->cA + 3 * r, *cB = s->cB + 3 * r;
    double *hj = s->history_next + BODY * j, *hi = s->history_next + BODY * i;
    for (int a = 0; a < 3; ++a) {
      hj[6 + a] += fn * cB[a];
      hj[9 + a] += fn * nw[a];
      hi[6 + a] -= fn * cA[a];
      hi[9 + a] -= fn * nw[a];
    }
    const double *wi = w + 3 * i, *wj = w + 3 * j, *vi = v + 3 * i, *vj = v + 3 * j;
    double vrel[3];
    for (int a = 0; a < 3; ++a) {
      int b = (a + 1) % 3, c = (a + 2) % 3;
      vrel[a] = vj[a] + wj[b] * rB[c] - wj[c] * rB[b] - vi[a] - (wi[b] * rA[c] - wi[c] * rA[b]);
    }
    double vn = s->vn0[r];
    double fv[3] = {fn * nw[0], fn * nw[1], fn * nw[2]};
    double m_red = 1.0 / (1.0 / mass[i] + 1.0 / mass[j]);
    double tau[3] = {0.0, 0.0, 0.0};
    if (mu > 0 && stick_hw > 0) {
      const double *anc = s->held + ROW * r, *Ri = R + 9 * i, *Rj = R + 9 * j;
      double vt[3], d[3] = {0.0, 0.0, 0.0}, ft[3];
      for (int a = 0; a < 3; ++a) vt[a] = vrel[a] - vn * nw[a];
      if (anc[6] > 0) {
        double dn = 0.0;
        for (int a = 0; a < 3; ++a) {
          d[a] = (p[3 * j + a] + Rj[3 * a + 0] * anc[3] + Rj[3 * a + 1] * anc[4] + Rj[3 * a + 2] * anc[5]) -
                 (p[3 * i + a] + Ri[3 * a + 0] * anc[0] + Ri[3 * a + 1] * anc[1] + Ri[3 * a + 2] * anc[2]);
          dn += d[a] * nw[a];
        }
        for (int a = 0; a < 3; ++a) d[a] -= dn * nw[a];
      }
      double k_t = stick_hw * stick_hw * m_red / (h * h);
      double c_t = 2.0 * stick_zeta * stick_hw * m_red / h;
      double mag2 = 0.0;
      for (int a = 0; a < 3; ++a) {
        ft[a] = -k_t * d[a] - c_t * vt[a];
        mag2 += ft[a] * ft[a];
      }
      double mag = sqrt(mag2), limit = mu * fn;
      if (mag > limit) { /* slip: the force at the cone, the spring re-anchored to carry it */
        for (int a = 0; a < 3; ++a) {
          ft[a] *= limit / mag;
          d[a] = -ft[a] / k_t;
        }
      }
      fv[0] = fv[0] + ft[0];
      fv[1] = fv[1] + ft[1];
      fv[2] = fv[2] + ft[2];
      double *an = s->anchors_next + 6 * r;
      for (int a = 0; a < 3; ++a) {
        an[a] = Ri[0 + a] * rA[0] + Ri[3 + a] * rA[1] + Ri[6 + a] * rA[2];
        an[3 + a] = Rj[0 + a] * (rB[0] + d[0]) + Rj[3 + a] * (rB[1] + d[1]) + Rj[6 + a] * (rB[2] + d[2]);
      }
      s->stuck_next[r] = 1.0;
    } else if (mu > 0) {
      double vt[3], speed2 = 0.0;
      for (int a = 0; a < 3; ++a) {
        vt[a] = vrel[a] - vn * nw[a];
        speed2 += vt[a] * vt[a];
      }
      double speed = sqrt(speed2), limit = mu * fn;
      double c = py_min(limit / slip, stiction * m_red / h);
      if (speed > 0) c = py_min(c, limit / speed);
      fv[0] = fv[0] - c * vt[0];
      fv[1] = fv[1] - c * vt[1];
      fv[2] = fv[2] - c * vt[2];
    }
    if (mu > 0 && q->torsional) {
      double rad = (2.0 / 3.0) * sqrt(s->area[r] / CC_PI);
      double wn = 0.0;
      for (int a = 0; a < 3; ++a) wn += (wj[a] - wi[a]) * nw[a];
      double inv_I = 0.0;
      size_t bodies[2] = {i, j};
      for (int t = 0; t < 2; ++t) {
        size_t body = bodies[t];
        if (!isfinite(mass[body])) continue;
        const double *Rb = R + 9 * body, *Ib = I_Bo + 9 * body;
        double nb[3], qq = 0.0;
        for (int a = 0; a < 3; ++a) nb[a] = Rb[0 + a] * nw[0] + Rb[3 + a] * nw[1] + Rb[6 + a] * nw[2];
        for (int a = 0; a < 3; ++a)
          for (int b = 0; b < 3; ++b) qq += nb[a] * Ib[3 * a + b] * nb[b];
        inv_I += 1.0 / qq;
      }
      double tlim = mu * fn * rad;
      double ct = py_min(tlim * rad / slip, stiction / (inv_I * h));
      if (wn != 0) ct = py_min(ct, tlim / fabs(wn));
      for (int a = 0; a < 3; ++a) tau[a] = -ct * wn * nw[a];
    }
    if (q->grid == 0 && dissipation > 0) {
      /* kept with the normal wrench in the bodies' history: the next step's estimate of the other
       * forces (an_ext) must not read this implicit damping as an outside push (lagged by a step, it
       * drove the normal solve: heavy_on_empty at 1e9 Pa diverged at 0.2 s) */
      double td[3] = {0.0, 0.0, 0.0};
      ccs_damping_torque(s, r, i, j, wi, wj, dissipation, h, td);
      for (int a = 0; a < 3; ++a) {
        tau[a] += td[a];
        hj[6 + a] += td[a];
        hi[6 + a] -= td[a];
      }
    }
    for (int a = 0; a < 3; ++a) {
      int b = (a + 1) % 3, c = (a + 2) % 3;
      double tB = rB[b] * fv[c] - rB[c] * fv[b] + tau[a];
      double tA = rA[b] * fv[c] - rA[c] * fv[b] + tau[a];
      out[6 * j + a] += tB;
      out[6 * j + 3 + a] += fv[a];
      out[6 * i + a] -= tA;
      out[6 * i + 3 + a] -= fv[a];
      s->f_W[3 * r + a] = fv[a];
    }
    s->fn[r] = fn;
  }
}

/* pack_anchors: the pairs stuck or pressing, in key order; then the history */
void ccs_commit_held(cc_step *s) {
  size_t n = 0, m = s->m;
  for (size_t r = 0; r < s->k; ++r) {
    if (!(s->stuck_next[r] > 0 || s->fn[r] > 0)) continue;
    s->keys[n] = s->ia[r] * (int64_t)m + s->ib[r];
    double *row = s->rows + ROW * n;
    memcpy(row, s->anchors_next + 6 * r, 6 * sizeof(double));
    row[6] = s->stuck_next[r];
    row[7] = s->fn[r];
    ++n;
  }
  s->n_held = n;
  memcpy(s->history, s->history_next, BODY * m * sizeof(double));
}
