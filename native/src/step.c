/* step.c: the learned contact step (container_contact_step.h): broad phase, candidate pairs'
 * poses, the force law, the held state. A port of the testbed's numba kernels (formerly
 * testbed/effects/learned_dynamics/kernels.py) with the same arithmetic in the same order,
 * so its answers equal theirs to rounding (tests/closed_loop/test_native_step.py). */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "container_contact_step.h"

#define ROW CC_STEP_ROW
#define BODY CC_STEP_BODY
#define CC_PI 3.141592653589793 /* numpy's pi */

struct cc_step {
  size_t m;
  /* the scene (copied; a fixed body's mass is INFINITY) */
  double *size, *half, *radius, *mass, *I_Bo;
  uint8_t *free;
  int64_t *type;
  cc_step_params par;
  double *kappa; /* (n_types, n_types), par.kappa points here */
  /* held state */
  size_t n_held, held_cap;
  int64_t *keys;
  double *rows;    /* (held_cap, ROW) */
  double *history; /* (m, BODY) */
  /* per-body workspace */
  double *p, *R; /* the poses of the latest cc_step_candidates */
  double *lo, *hi, *inv_m, *invI, *acc, *dacc, *history_next;
  double *box;      /* (m, 6) the world boxes (lo, hi) in the sweep's order */
  uint8_t *box_free; /* (m) free flags in the sweep's order */
  size_t *order, *order_tmp;
  uint8_t *need;
  /* the broad phase's candidates (keys ia * m + ib) */
  size_t n_cand, cand_cap;
  int64_t *cand, *cand_tmp;
  /* per-pair workspace, capacity cap */
  size_t k, cap;
  int have_pairs; /* the candidates are current (cc_step_candidates ran since the last law) */
  int64_t *ia, *ib;
  double *p_AB, *R_AB, *size_A, *size_B, *point_A, *normal_A, *fn, *f_W, *p_W, *n_W, *area;
  double *kap, *held, *anchors_next, *stuck_next, *F_el, *g, *W_rr, *vn0, *an_ext, *rA, *rB, *cA, *cB, *f;
  uint8_t *touch;
  /* sleeping (cc_step_set_sleep) */
  cc_step_sleep sleep;
  cc_step_sleep_counts counts;
  double *rest;          /* (m) [s] time at rest */
  uint8_t *asleep;       /* (m) in an asleep island */
  double *p_ref, *R_ref; /* (m, 3), (m, 3, 3) the pose where its island fell asleep */
  size_t *parent;        /* (m) union-find over the candidate pairs */
  uint8_t *island;       /* (m) per island root: SLEEP_* bits */
  size_t n_cache, cache_cap;
  int64_t *cache_keys;   /* the previous step's candidates' keys, ascending */
  double *cache_ans;     /* (cache_cap, 6) their answers: point_A, normal_A */
  double *cache_pose;    /* (cache_cap, 12) the pose each was asked at: p_AB (3), R_AB (9) */
  double *q_pose;        /* (k, 12) the pose this step's answer of each row was asked at */
  uint8_t *woken;        /* (m) woken by the host since the last plan (no pair reuse) */
  int planned;           /* cc_step_sleep_plan ran on the current candidates */
  uint8_t *ask;          /* (k) ask the predictor */
  double *q_p, *q_R, *q_sA, *q_sB, *q_pt, *q_nm; /* the asked rows, packed for cc_predict */
  size_t *q_row;         /* (k) each packed row's candidate row */
};

static int reserve_pairs(cc_step *s, size_t n);
static int reserve_held(cc_step *s, size_t n);

/* Python's max(a, b) / min(a, b): the first unless the second is strictly beyond it */
static inline double py_max(double a, double b) { return b > a ? b : a; }
static inline double py_min(double a, double b) { return b < a ? b : a; }

static int resize(void **ptr, size_t count, size_t elem) {
  void *q = realloc(*ptr, count * elem > 0 ? count * elem : 1);
  if (q == NULL) return 0;
  *ptr = q;
  return 1;
}

/* ------------------------------------------------------------------ create, free, params */

static int check_params(const cc_step_params *q, const int64_t *type, size_t m) {
  if (q == NULL) return 0;
  if (!(isfinite(q->h) && q->h > 0) || !(isfinite(q->margin) && q->margin >= 0) ||
      !(isfinite(q->dissipation) && q->dissipation >= 0) || !(isfinite(q->mu) && q->mu >= 0) ||
      !(isfinite(q->stick_hw) && q->stick_hw >= 0) || !(isfinite(q->stick_zeta) && q->stick_zeta >= 0) ||
      !(isfinite(q->slip) && q->slip > 0) || !(q->stiction >= 0 && q->stiction <= 1) || q->grid < 1 ||
      q->sweeps < 1 || q->n_types < 1 || q->kappa == NULL)
    return 0;
  size_t t2 = (size_t)q->n_types * (size_t)q->n_types;
  for (size_t i = 0; i < t2; ++i)
    if (!(isfinite(q->kappa[i]) && q->kappa[i] >= 0)) return 0;
  for (size_t i = 0; i < m; ++i)
    if (type[i] < 0 || type[i] >= q->n_types) return 0;
  return 1;
}

void cc_step_free(cc_step *s) {
  if (s == NULL) return;
  void *owned[] = {s->size, s->half, s->radius, s->mass, s->I_Bo, s->free, s->type, s->kappa, s->keys, s->rows,
                   s->history, s->p, s->R, s->lo, s->hi, s->box, s->box_free, s->inv_m, s->invI, s->acc, s->dacc, s->history_next,
                   s->order, s->order_tmp, s->need, s->cand, s->cand_tmp, s->ia, s->ib, s->p_AB, s->R_AB,
                   s->size_A, s->size_B, s->point_A, s->normal_A, s->fn, s->f_W, s->p_W, s->n_W, s->area, s->kap,
                   s->held, s->anchors_next, s->stuck_next, s->F_el, s->g, s->W_rr, s->vn0, s->an_ext, s->rA,
                   s->rB, s->cA, s->cB, s->f, s->touch, s->rest, s->asleep, s->p_ref, s->R_ref, s->parent,
                   s->island, s->cache_keys, s->cache_ans, s->cache_pose, s->q_pose, s->woken, s->ask, s->q_p, s->q_R, s->q_sA, s->q_sB, s->q_pt,
                   s->q_nm, s->q_row};
  for (size_t i = 0; i < sizeof owned / sizeof owned[0]; ++i) free(owned[i]);
  free(s);
}

size_t cc_step_n_bodies(const cc_step *s) { return s == NULL ? 0 : s->m; }

static int set_params(cc_step *s, const cc_step_params *q) {
  size_t t2 = (size_t)q->n_types * (size_t)q->n_types;
  if (!resize((void **)&s->kappa, t2, sizeof(double))) return CC_STEP_NO_MEMORY;
  memcpy(s->kappa, q->kappa, t2 * sizeof(double));
  s->par = *q;
  s->par.kappa = s->kappa;
  return CC_OK;
}

int cc_step_set_params(cc_step *s, const cc_step_params *q) {
  if (s == NULL || !check_params(q, s->type, s->m)) return CC_BAD_ARGUMENT;
  return set_params(s, q);
}

void cc_step_sleep_reset(cc_step *s) {
  if (s == NULL) return;
  memset(s->rest, 0, s->m * sizeof(double));
  memset(s->asleep, 0, s->m);
  memset(s->woken, 0, s->m);
  s->n_cache = 0;
}

void cc_step_forget(cc_step *s) {
  if (s == NULL) return;
  s->n_held = 0;
  for (size_t i = 0; i < s->m * BODY; ++i) s->history[i] = NAN;
  cc_step_sleep_reset(s);
}

cc_step *cc_step_create(const cc_step_scene *scene, const cc_step_params *params, int *status) {
  int dummy;
  if (status == NULL) status = &dummy;
  *status = CC_BAD_ARGUMENT;
  if (scene == NULL || params == NULL || scene->size == NULL || scene->free == NULL || scene->mass == NULL ||
      scene->I_Bo == NULL)
    return NULL;
  size_t m = scene->n_bodies;
  for (size_t i = 0; i < m; ++i) {
    for (int a = 0; a < 3; ++a)
      if (!(isfinite(scene->size[3 * i + a]) && scene->size[3 * i + a] > 0)) return NULL;
    if (scene->free[i]) {
      if (!(isfinite(scene->mass[i]) && scene->mass[i] > 0)) return NULL;
      for (int a = 0; a < 9; ++a)
        if (!isfinite(scene->I_Bo[9 * i + a])) return NULL;
    }
  }
  cc_step *s = calloc(1, sizeof *s);
  if (s == NULL) {
    *status = CC_STEP_NO_MEMORY;
    return NULL;
  }
  s->m = m;
  int ok = resize((void **)&s->size, 3 * m, sizeof(double)) && resize((void **)&s->half, 3 * m, sizeof(double)) &&
           resize((void **)&s->radius, m, sizeof(double)) && resize((void **)&s->mass, m, sizeof(double)) &&
           resize((void **)&s->I_Bo, 9 * m, sizeof(double)) && resize((void **)&s->free, m, 1) &&
           resize((void **)&s->type, m, sizeof(int64_t)) && resize((void **)&s->history, BODY * m, sizeof(double)) &&
           resize((void **)&s->history_next, BODY * m, sizeof(double)) &&
           resize((void **)&s->p, 3 * m, sizeof(double)) && resize((void **)&s->R, 9 * m, sizeof(double)) &&
           resize((void **)&s->lo, 3 * m, sizeof(double)) && resize((void **)&s->hi, 3 * m, sizeof(double)) &&
           resize((void **)&s->inv_m, m, sizeof(double)) && resize((void **)&s->invI, 9 * m, sizeof(double)) &&
           resize((void **)&s->acc, 6 * m, sizeof(double)) && resize((void **)&s->dacc, 6 * m, sizeof(double)) &&
           resize((void **)&s->order, m, sizeof(size_t)) && resize((void **)&s->order_tmp, m, sizeof(size_t)) &&
           resize((void **)&s->need, m, 1) && resize((void **)&s->box, 6 * m, sizeof(double)) &&
           resize((void **)&s->box_free, m, 1) && resize((void **)&s->rest, m, sizeof(double)) &&
           resize((void **)&s->asleep, m, 1) && resize((void **)&s->p_ref, 3 * m, sizeof(double)) &&
           resize((void **)&s->R_ref, 9 * m, sizeof(double)) && resize((void **)&s->parent, m, sizeof(size_t)) &&
           resize((void **)&s->island, m, 1) && resize((void **)&s->woken, m, 1);
  if (!ok) {
    cc_step_free(s);
    *status = CC_STEP_NO_MEMORY;
    return NULL;
  }
  for (size_t i = 0; i < m; ++i) {
    s->free[i] = scene->free[i] ? 1 : 0;
    s->type[i] = scene->type_index == NULL ? 0 : scene->type_index[i];
    s->mass[i] = s->free[i] ? scene->mass[i] : INFINITY;
    double r2 = 0.0;
    for (int a = 0; a < 3; ++a) {
      s->size[3 * i + a] = scene->size[3 * i + a];
      s->half[3 * i + a] = 0.5 * scene->size[3 * i + a];
      r2 += s->half[3 * i + a] * s->half[3 * i + a];
    }
    s->radius[i] = sqrt(r2);
    for (int a = 0; a < 9; ++a) s->I_Bo[9 * i + a] = s->free[i] ? scene->I_Bo[9 * i + a] : 0.0;
  }
  if (!check_params(params, s->type, m)) {
    cc_step_free(s);
    return NULL;
  }
  if (set_params(s, params) != CC_OK) {
    cc_step_free(s);
    *status = CC_STEP_NO_MEMORY;
    return NULL;
  }
  if (!reserve_pairs(s, 1) || !reserve_held(s, 1)) { /* every array non-null from here on */
    cc_step_free(s);
    *status = CC_STEP_NO_MEMORY;
    return NULL;
  }
  cc_step_forget(s);
  *status = CC_OK;
  return s;
}

/* the per-pair arrays hold n pairs */
static int reserve_pairs(cc_step *s, size_t n) {
  if (n <= s->cap && s->cap > 0) return 1;
  size_t cap = s->cap ? s->cap : 64;
  while (cap < n) cap *= 2;
  struct {
    void **ptr;
    size_t elem;
  } arrays[] = {
      {(void **)&s->ia, sizeof(int64_t)},       {(void **)&s->ib, sizeof(int64_t)},
      {(void **)&s->p_AB, 3 * sizeof(double)},  {(void **)&s->R_AB, 9 * sizeof(double)},
      {(void **)&s->size_A, 3 * sizeof(double)}, {(void **)&s->size_B, 3 * sizeof(double)},
      {(void **)&s->point_A, 3 * sizeof(double)}, {(void **)&s->normal_A, 3 * sizeof(double)},
      {(void **)&s->fn, sizeof(double)},        {(void **)&s->f_W, 3 * sizeof(double)},
      {(void **)&s->p_W, 3 * sizeof(double)},   {(void **)&s->n_W, 3 * sizeof(double)},
      {(void **)&s->area, sizeof(double)},      {(void **)&s->kap, sizeof(double)},
      {(void **)&s->held, ROW * sizeof(double)}, {(void **)&s->anchors_next, 6 * sizeof(double)},
      {(void **)&s->stuck_next, sizeof(double)}, {(void **)&s->F_el, sizeof(double)},
      {(void **)&s->g, sizeof(double)},         {(void **)&s->W_rr, sizeof(double)},
      {(void **)&s->vn0, sizeof(double)},       {(void **)&s->an_ext, sizeof(double)},
      {(void **)&s->rA, 3 * sizeof(double)},    {(void **)&s->rB, 3 * sizeof(double)},
      {(void **)&s->cA, 3 * sizeof(double)},    {(void **)&s->cB, 3 * sizeof(double)},
      {(void **)&s->f, sizeof(double)},         {(void **)&s->touch, 1},
      {(void **)&s->ask, 1},                    {(void **)&s->q_row, sizeof(size_t)},
      {(void **)&s->q_p, 3 * sizeof(double)},   {(void **)&s->q_R, 9 * sizeof(double)},
      {(void **)&s->q_sA, 3 * sizeof(double)},  {(void **)&s->q_sB, 3 * sizeof(double)},
      {(void **)&s->q_pt, 3 * sizeof(double)},  {(void **)&s->q_nm, 3 * sizeof(double)},
      {(void **)&s->q_pose, 12 * sizeof(double)},
  };
  for (size_t i = 0; i < sizeof arrays / sizeof arrays[0]; ++i)
    if (!resize(arrays[i].ptr, cap, arrays[i].elem)) return 0;
  s->cap = cap;
  return 1;
}

static int reserve_held(cc_step *s, size_t n) {
  if (n <= s->held_cap && s->held_cap > 0) return 1;
  size_t cap = s->held_cap ? s->held_cap : 64;
  while (cap < n) cap *= 2;
  if (!resize((void **)&s->keys, cap, sizeof(int64_t)) || !resize((void **)&s->rows, cap, ROW * sizeof(double)))
    return 0;
  s->held_cap = cap;
  return 1;
}

/* ------------------------------------------------------------------ sorting (stable merge sorts) */

static void sort_by_key(size_t *idx, size_t *tmp, size_t n, const double *key, size_t stride) {
  for (size_t i = 0; i < n; ++i) idx[i] = i;
  for (size_t width = 1; width < n; width *= 2) {
    for (size_t lo = 0; lo < n; lo += 2 * width) {
      size_t mid = lo + width < n ? lo + width : n, hi = lo + 2 * width < n ? lo + 2 * width : n;
      size_t a = lo, b = mid, o = lo;
      while (a < mid && b < hi) tmp[o++] = key[idx[b] * stride] < key[idx[a] * stride] ? idx[b++] : idx[a++];
      while (a < mid) tmp[o++] = idx[a++];
      while (b < hi) tmp[o++] = idx[b++];
    }
    memcpy(idx, tmp, n * sizeof *idx);
  }
}

static void sort_int64(int64_t *v, int64_t *tmp, size_t n) {
  for (size_t width = 1; width < n; width *= 2) {
    for (size_t lo = 0; lo < n; lo += 2 * width) {
      size_t mid = lo + width < n ? lo + width : n, hi = lo + 2 * width < n ? lo + 2 * width : n;
      size_t a = lo, b = mid, o = lo;
      while (a < mid && b < hi) tmp[o++] = v[b] < v[a] ? v[b++] : v[a++];
      while (a < mid) tmp[o++] = v[a++];
      while (b < hi) tmp[o++] = v[b++];
    }
    memcpy(v, tmp, n * sizeof *v);
  }
}

/* ------------------------------------------------------------------ geometry */

/* The separating-axis test on the 6 face axes (A's 3, B's 3): the least overlap [m]
 * (negative: separated by at least that); *owner 0 = A / 1 = B, *axis its index. */
static double face_axis_overlap(const double *p, const double *R, const double *hA, const double *hB, int *owner,
                                int *axis) {
  double p_BA[3];
  for (int j = 0; j < 3; ++j) p_BA[j] = -(R[0 + j] * p[0] + R[3 + j] * p[1] + R[6 + j] * p[2]);
  double best = INFINITY;
  *owner = 0;
  *axis = 0;
  for (int k = 0; k < 3; ++k) {
    double o = hA[k] - fabs(p[k]);
    for (int j = 0; j < 3; ++j) o += fabs(R[3 * k + j]) * hB[j];
    if (o < best) {
      best = o;
      *owner = 0;
      *axis = k;
    }
  }
  for (int j = 0; j < 3; ++j) {
    double o = hB[j] - fabs(p_BA[j]);
    for (int k = 0; k < 3; ++k) o += fabs(R[3 * k + j]) * hA[k];
    if (o < best - 1e-9) { /* A's face on ties (aligned stacks) */
      best = o;
      *owner = 1;
      *axis = j;
    }
  }
  return best;
}

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
static void elastic_stiff(const double *p, const double *R, const double *hA, const double *hB, double kappa,
                          int grid, double *F, double *area, double *k_n) {
  int owner, axis;
  double best = face_axis_overlap(p, R, hA, hB, &owner, &axis);
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
  elastic_stiff(p_AB, R_AB, hA, hB, kappa, grid < 1 ? 1 : grid, &out[0], &out[1], &out[2]);
}

/* ------------------------------------------------------------------ candidates */

static int broad_phase(cc_step *s) {
  size_t m = s->m;
  const double *p = s->p, *R = s->R, *half = s->half;
  double margin = s->par.margin;
  s->n_cand = 0;
  if (m < 2) return CC_OK;
  for (size_t i = 0; i < m; ++i)
    for (int a = 0; a < 3; ++a) {
      double e = 0.5 * margin;
      for (int c = 0; c < 3; ++c) e += fabs(R[9 * i + 3 * a + c]) * half[3 * i + c];
      s->lo[3 * i + a] = p[3 * i + a] - e;
      s->hi[3 * i + a] = p[3 * i + a] + e;
    }
  int axis = 0;
  double best = -1.0;
  for (int a = 0; a < 3; ++a) {
    double width = 0.0, top = p[a], bottom = p[a];
    for (size_t i = 0; i < m; ++i) {
      width += s->hi[3 * i + a] - s->lo[3 * i + a];
      if (p[3 * i + a] > top) top = p[3 * i + a];
      if (p[3 * i + a] < bottom) bottom = p[3 * i + a];
    }
    double score = (top - bottom) * (double)m / py_max(width, 1e-12);
    if (score > best) {
      axis = a;
      best = score;
    }
  }
  sort_by_key(s->order, s->order_tmp, m, s->lo + axis, 3);
  /* the boxes copied in the sweep's order: the inner loop reads consecutive memory */
  for (size_t o = 0; o < m; ++o) {
    size_t i = s->order[o];
    double *b = s->box + 6 * o;
    for (int a = 0; a < 3; ++a) {
      b[a] = s->lo[3 * i + a];
      b[3 + a] = s->hi[3 * i + a];
    }
    s->box_free[o] = s->free[i];
  }
  const double *box = s->box;
  for (size_t o = 0; o < m; ++o) {
    const double *bi = box + 6 * o;
    double reach = bi[3 + axis];
    for (size_t t = o + 1; t < m; ++t) {
      const double *bj = box + 6 * t;
      if (bj[axis] > reach) break;
      if (!(s->box_free[o] || s->box_free[t])) continue;
      /* apart along a world axis (the box's lo beyond the other's hi) */
      if (bj[0] > bi[3] || bi[0] > bj[3] || bj[1] > bi[4] || bi[1] > bj[4] || bj[2] > bi[5] || bi[2] > bj[5]) continue;
      if (s->n_cand == s->cand_cap) {
        size_t cap = s->cand_cap ? 2 * s->cand_cap : 256;
        if (!resize((void **)&s->cand, cap, sizeof(int64_t)) || !resize((void **)&s->cand_tmp, cap, sizeof(int64_t)))
          return CC_STEP_NO_MEMORY;
        s->cand_cap = cap;
      }
      size_t i = s->order[o], j = s->order[t];
      size_t a = i < j ? i : j, b = i < j ? j : i;
      s->cand[s->n_cand++] = (int64_t)(a * m + b);
    }
  }
  sort_int64(s->cand, s->cand_tmp, s->n_cand);
  return CC_OK;
}

/* near_pairs: bounding spheres within margin, no face axis separating by more than margin */
static void near_pairs(cc_step *s) {
  size_t m = s->m, n = 0;
  const double *p = s->p, *R = s->R;
  double margin = s->par.margin;
  for (size_t c = 0; c < s->n_cand; ++c) {
    size_t i = (size_t)s->cand[c] / m, j = (size_t)s->cand[c] % m;
    if (!(s->free[i] || s->free[j])) continue;
    double d2 = 0.0;
    for (int a = 0; a < 3; ++a) d2 += (p[3 * j + a] - p[3 * i + a]) * (p[3 * j + a] - p[3 * i + a]);
    double reach = s->radius[i] + s->radius[j] + margin;
    if (d2 >= reach * reach) continue;
    double *pn = s->p_AB + 3 * n, *Rn = s->R_AB + 9 * n;
    for (int a = 0; a < 9; ++a) Rn[a] = 0.0;
    for (int a = 0; a < 3; ++a) {
      double acc = 0.0;
      for (int c2 = 0; c2 < 3; ++c2) {
        acc += R[9 * i + 3 * c2 + a] * (p[3 * j + c2] - p[3 * i + c2]);
        for (int e = 0; e < 3; ++e) Rn[3 * a + e] += R[9 * i + 3 * c2 + a] * R[9 * j + 3 * c2 + e];
      }
      pn[a] = acc;
    }
    int owner, axis;
    if (face_axis_overlap(pn, Rn, s->half + 3 * i, s->half + 3 * j, &owner, &axis) > -margin) {
      s->ia[n] = (int64_t)i;
      s->ib[n] = (int64_t)j;
      for (int a = 0; a < 3; ++a) {
        s->size_A[3 * n + a] = s->size[3 * i + a];
        s->size_B[3 * n + a] = s->size[3 * j + a];
      }
      ++n;
    }
  }
  s->k = n;
}

int cc_step_candidates(cc_step *s, const double *p_WB, const double *R_WB, size_t *n_pairs) {
  if (s == NULL || (s->m > 0 && (p_WB == NULL || R_WB == NULL))) return CC_BAD_ARGUMENT;
  s->have_pairs = 0;
  s->planned = 0;
  s->k = 0;
  if (s->m > 0) {
    memcpy(s->p, p_WB, 3 * s->m * sizeof(double));
    memcpy(s->R, R_WB, 9 * s->m * sizeof(double));
  }
  int status = broad_phase(s);
  if (status != CC_OK) return status;
  if (!reserve_pairs(s, s->n_cand) || !reserve_held(s, s->n_cand)) return CC_STEP_NO_MEMORY;
  near_pairs(s);
  /* the force law's records start cleared */
  memset(s->fn, 0, s->k * sizeof(double));
  memset(s->area, 0, s->k * sizeof(double));
  memset(s->f_W, 0, 3 * s->k * sizeof(double));
  memset(s->p_W, 0, 3 * s->k * sizeof(double));
  memset(s->n_W, 0, 3 * s->k * sizeof(double));
  s->have_pairs = 1;
  if (n_pairs != NULL) *n_pairs = s->k;
  return CC_OK;
}

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
static void gather_pairs(cc_step *s) {
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
static void pair_wrenches(cc_step *s, const double *w, const double *v, double *out) {
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
    elastic_stiff(s->p_AB + 3 * r, s->R_AB + 9 * r, hA, hB, s->kap[r], q->grid, &F, &area, &k_n);
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
static void commit_held(cc_step *s) {
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

static int keep_answers(cc_step *s);

static int run_law(cc_step *s, const double *w_WB, const double *v_WB, double *wrench_W) {
  gather_pairs(s);
  pair_wrenches(s, w_WB, v_WB, wrench_W);
  commit_held(s);
  if (s->sleep.enabled && !keep_answers(s)) return CC_STEP_NO_MEMORY;
  s->have_pairs = 0; /* a second law on the same candidates would read the next held state */
  return CC_OK;
}

int cc_step_force_law(cc_step *s, const double *w_WB, const double *v_WB, const double *point_A,
                      const double *normal_A, double *wrench_W) {
  if (s == NULL || !s->have_pairs || (s->m > 0 && (w_WB == NULL || v_WB == NULL || wrench_W == NULL)) ||
      (s->k > 0 && (point_A == NULL || normal_A == NULL)))
    return CC_BAD_ARGUMENT;
  if (s->k > 0 && point_A != s->point_A) memcpy(s->point_A, point_A, 3 * s->k * sizeof(double));
  if (s->k > 0 && normal_A != s->normal_A) memcpy(s->normal_A, normal_A, 3 * s->k * sizeof(double));
  return run_law(s, w_WB, v_WB, wrench_W);
}

/* cc_predict on the asked rows only (packed), the answers put back in their rows */
static int predict_asked(const cc_model *model, cc_step *s, size_t n_ask, size_t *bad_row) {
  size_t n = 0;
  for (size_t r = 0; r < s->k; ++r) {
    if (!s->ask[r]) continue;
    memcpy(s->q_p + 3 * n, s->p_AB + 3 * r, 3 * sizeof(double));
    memcpy(s->q_R + 9 * n, s->R_AB + 9 * r, 9 * sizeof(double));
    memcpy(s->q_sA + 3 * n, s->size_A + 3 * r, 3 * sizeof(double));
    memcpy(s->q_sB + 3 * n, s->size_B + 3 * r, 3 * sizeof(double));
    s->q_row[n++] = r;
  }
  if (n == 0 || n != n_ask) return n == n_ask ? CC_OK : CC_BAD_ARGUMENT;
  size_t bad = 0;
  int status = cc_predict(model, n, s->q_p, s->q_R, s->q_sA, n, s->q_sB, n, s->q_pt, s->q_nm, NULL, &bad);
  if (status != CC_OK) {
    if (bad_row != NULL) *bad_row = bad < n ? s->q_row[bad] : bad;
    return status;
  }
  for (size_t q = 0; q < n; ++q) {
    memcpy(s->point_A + 3 * s->q_row[q], s->q_pt + 3 * q, 3 * sizeof(double));
    memcpy(s->normal_A + 3 * s->q_row[q], s->q_nm + 3 * q, 3 * sizeof(double));
  }
  return CC_OK;
}

static double now_s(void) {
  struct timespec t;
  if (timespec_get(&t, TIME_UTC) != TIME_UTC) return 0.0;
  return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

int cc_contact_step_timed(const cc_model *model, cc_step *s, const double *p_WB, const double *R_WB,
                          const double *w_WB, const double *v_WB, double *wrench_W, size_t *bad_row,
                          double seconds[3]) {
  if (model == NULL || s == NULL || (s->m > 0 && (w_WB == NULL || v_WB == NULL || wrench_W == NULL)))
    return CC_BAD_ARGUMENT;
  double t0 = seconds != NULL ? now_s() : 0.0, t1 = t0, t2 = t0;
  size_t k;
  int status = cc_step_candidates(s, p_WB, R_WB, &k);
  if (status != CC_OK) return status;
  size_t n_ask = k; /* the islands join the candidates' share of the time */
  status = cc_step_sleep_plan(s, w_WB, v_WB, s->ask, &n_ask); /* every row asked when sleeping is off */
  if (status != CC_OK) return status;
  if (seconds != NULL) t1 = now_s();
  if (k > 0) {
    if (n_ask == k) {
      status = cc_predict(model, k, s->p_AB, s->R_AB, s->size_A, k, s->size_B, k, s->point_A, s->normal_A, NULL,
                          bad_row);
    } else {
      status = predict_asked(model, s, n_ask, bad_row);
    }
    if (status != CC_OK) {
      memset(wrench_W, 0, 6 * s->m * sizeof(double));
      s->have_pairs = 0;
      return status;
    }
  }
  if (seconds != NULL) t2 = now_s();
  status = run_law(s, w_WB, v_WB, wrench_W);
  if (seconds != NULL) {
    double t3 = now_s();
    seconds[0] = t1 - t0;
    seconds[1] = t2 - t1;
    seconds[2] = t3 - t2;
  }
  return status;
}

int cc_contact_step(const cc_model *model, cc_step *s, const double *p_WB, const double *R_WB, const double *w_WB,
                    const double *v_WB, double *wrench_W, size_t *bad_row) {
  return cc_contact_step_timed(model, s, p_WB, R_WB, w_WB, v_WB, wrench_W, bad_row, NULL);
}

/* ------------------------------------------------------------------ views, held state */

void cc_step_view(const cc_step *s, cc_step_pairs *out) {
  if (out == NULL) return;
  memset(out, 0, sizeof *out);
  if (s == NULL) return;
  out->n = s->k;
  out->ia = s->ia;
  out->ib = s->ib;
  out->p_AB = s->p_AB;
  out->R_AB = s->R_AB;
  out->size_A = s->size_A;
  out->size_B = s->size_B;
  out->point_A = s->point_A;
  out->normal_A = s->normal_A;
  out->fn = s->fn;
  out->f_W = s->f_W;
  out->p_W = s->p_W;
  out->n_W = s->n_W;
  out->area = s->area;
  out->n_broad = s->n_cand;
}

size_t cc_step_held_count(const cc_step *s) { return s == NULL ? 0 : s->n_held; }

void cc_step_held_get(const cc_step *s, int64_t *keys, double *rows, double *history) {
  if (s == NULL) return;
  if (keys != NULL) memcpy(keys, s->keys, s->n_held * sizeof(int64_t));
  if (rows != NULL) memcpy(rows, s->rows, ROW * s->n_held * sizeof(double));
  if (history != NULL) memcpy(history, s->history, BODY * s->m * sizeof(double));
}

int cc_step_held_set(cc_step *s, size_t n, const int64_t *keys, const double *rows, const double *history) {
  if (s == NULL || (n > 0 && (keys == NULL || rows == NULL))) return CC_BAD_ARGUMENT;
  int64_t top = (int64_t)(s->m * s->m);
  for (size_t r = 0; r < n; ++r)
    if (keys[r] < 0 || keys[r] >= top || (r > 0 && keys[r] <= keys[r - 1])) return CC_BAD_ARGUMENT;
  if (!reserve_held(s, n)) return CC_STEP_NO_MEMORY;
  memcpy(s->keys, keys, n * sizeof(int64_t));
  memcpy(s->rows, rows, ROW * n * sizeof(double));
  s->n_held = n;
  if (history != NULL)
    memcpy(s->history, history, BODY * s->m * sizeof(double));
  else
    for (size_t i = 0; i < s->m * BODY; ++i) s->history[i] = NAN;
  return CC_OK;
}

/* ------------------------------------------------------------------ sleeping */

enum { SLEEP_REST = 1, SLEEP_ASLEEP = 2, SLEEP_NEAR = 4, SLEEP_KNOWN = 8, SLEEP_PAIRS = 16, SLEEP_STAYS = 32 };

int cc_step_set_sleep(cc_step *s, const cc_step_sleep *q) {
  if (s == NULL) return CC_BAD_ARGUMENT;
  cc_step_sleep off = {0, 0.0, 0.0, 0.0, 0.0, 0.0, 0};
  if (q == NULL) q = &off;
  const double x[5] = {q->v_sleep, q->w_sleep, q->t_sleep, q->eps_p, q->eps_R};
  for (int i = 0; i < 5; ++i)
    if (!(isfinite(x[i]) && x[i] >= 0)) return CC_BAD_ARGUMENT;
  s->sleep = *q;
  s->sleep.enabled = q->enabled ? 1 : 0;
  s->sleep.pair_reuse = q->pair_reuse ? 1 : 0;
  cc_step_sleep_reset(s);
  return CC_OK;
}

void cc_step_sleep_wake(cc_step *s, size_t n, const int64_t *bodies) {
  if (s == NULL || bodies == NULL) return;
  for (size_t t = 0; t < n; ++t)
    if (bodies[t] >= 0 && (size_t)bodies[t] < s->m) {
      s->rest[bodies[t]] = 0.0;
      s->woken[bodies[t]] = 1;
    }
}

void cc_step_sleep_get_counts(const cc_step *s, cc_step_sleep_counts *out) {
  if (out == NULL) return;
  if (s == NULL)
    memset(out, 0, sizeof *out);
  else
    *out = s->counts;
}

static size_t root_of(size_t *parent, size_t i) {
  while (parent[i] != i) {
    parent[i] = parent[parent[i]]; /* path halving */
    i = parent[i];
  }
  return i;
}

/* whether body i has left its sleeping pose: any point of its box moved by more than eps_p
 * (|dp| + angle x half diagonal, the angle from the skew part of R R_ref^T) or turned more than eps_R */
static int left_pose(const cc_step *s, size_t i) {
  const double *p = s->p + 3 * i, *R = s->R + 9 * i, *p0 = s->p_ref + 3 * i, *R0 = s->R_ref + 9 * i;
  double d2 = 0.0, M[9];
  for (int a = 0; a < 3; ++a) d2 += (p[a] - p0[a]) * (p[a] - p0[a]);
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) M[3 * r + c] = R[3 * r] * R0[3 * c] + R[3 * r + 1] * R0[3 * c + 1] + R[3 * r + 2] * R0[3 * c + 2];
  if (M[0] + M[4] + M[8] < 1.0) return 1; /* turned beyond 90 degrees */
  double sx = M[7] - M[5], sy = M[2] - M[6], sz = M[3] - M[1];
  double angle = asin(py_min(1.0, 0.5 * sqrt(sx * sx + sy * sy + sz * sz)));
  return angle > s->sleep.eps_R || sqrt(d2) + angle * s->radius[i] > s->sleep.eps_p;
}

/* whether row r's pose (B in A) is within eps_p at any point of B's box and eps_R in angle of
 * the pose its kept answer was asked at (q_pose, filled from the cache) */
static int near_asked_pose(const cc_step *s, size_t r) {
  const double *p = s->p_AB + 3 * r, *R = s->R_AB + 9 * r, *p0 = s->q_pose + 12 * r, *R0 = p0 + 3;
  double d2 = 0.0, M[9];
  for (int a = 0; a < 3; ++a) d2 += (p[a] - p0[a]) * (p[a] - p0[a]);
  for (int i = 0; i < 3; ++i)
    for (int c = 0; c < 3; ++c) M[3 * i + c] = R[3 * i] * R0[3 * c] + R[3 * i + 1] * R0[3 * c + 1] + R[3 * i + 2] * R0[3 * c + 2];
  if (M[0] + M[4] + M[8] < 1.0) return 0;
  double sx = M[7] - M[5], sy = M[2] - M[6], sz = M[3] - M[1];
  double angle = asin(py_min(1.0, 0.5 * sqrt(sx * sx + sy * sy + sz * sz)));
  return angle <= s->sleep.eps_R && sqrt(d2) + angle * s->radius[s->ib[r]] <= s->sleep.eps_p;
}

/* the island (root) a candidate row belongs to; m for a pair of two fixed bodies */
static size_t pair_island(cc_step *s, size_t r) {
  size_t i = (size_t)s->ia[r], j = (size_t)s->ib[r];
  if (s->free[i]) return root_of(s->parent, i);
  if (s->free[j]) return root_of(s->parent, j);
  return s->m;
}

int cc_step_sleep_plan(cc_step *s, const double *w, const double *v, uint8_t *ask, size_t *n_asked) {
  if (s == NULL || !s->have_pairs || ask == NULL || (s->m > 0 && (w == NULL || v == NULL))) return CC_BAD_ARGUMENT;
  const size_t m = s->m, k = s->k;
  const cc_step_sleep *q = &s->sleep;
  memset(&s->counts, 0, sizeof s->counts);
  if (!q->enabled) {
    memset(ask, 1, k);
    s->counts.asked = k;
    if (n_asked != NULL) *n_asked = k;
    return CC_OK;
  }
  const double h = s->par.h, v2 = q->v_sleep * q->v_sleep, w2 = q->w_sleep * q->w_sleep;
  for (size_t i = 0; i < m; ++i) {
    s->parent[i] = i;
    s->island[i] = SLEEP_REST | SLEEP_ASLEEP | SLEEP_NEAR | SLEEP_KNOWN;
    if (!s->free[i]) continue;
    const double *vi = v + 3 * i, *wi = w + 3 * i;
    double sv = vi[0] * vi[0] + vi[1] * vi[1] + vi[2] * vi[2], sw = wi[0] * wi[0] + wi[1] * wi[1] + wi[2] * wi[2];
    s->rest[i] = (sv < v2 && sw < w2) ? s->rest[i] + h : 0.0;
  }
  for (size_t r = 0; r < k; ++r) { /* islands: the pairs of two free bodies join them */
    size_t i = (size_t)s->ia[r], j = (size_t)s->ib[r];
    if (!(s->free[i] && s->free[j])) continue;
    size_t a = root_of(s->parent, i), b = root_of(s->parent, j);
    if (a != b) s->parent[a < b ? b : a] = a < b ? a : b;
  }
  for (size_t i = 0; i < m; ++i) {
    if (!s->free[i]) continue;
    size_t root = root_of(s->parent, i);
    if (s->rest[i] <= 0.0 || s->rest[i] < q->t_sleep - 0.5 * h) s->island[root] &= (uint8_t)~SLEEP_REST;
    if (!s->asleep[i])
      s->island[root] &= (uint8_t)~SLEEP_ASLEEP;
    else if (left_pose(s, i))
      s->island[root] &= (uint8_t)~SLEEP_NEAR;
  }
  /* the pairs not candidates at the previous step (a merge of two ascending key lists) */
  size_t c = 0;
  for (size_t r = 0; r < k; ++r) {
    size_t root = pair_island(s, r);
    if (root == m) continue;
    s->island[root] |= SLEEP_PAIRS;
    int64_t key = s->ia[r] * (int64_t)m + s->ib[r];
    while (c < s->n_cache && s->cache_keys[c] < key) ++c;
    ask[r] = 0; /* here: whether it has a kept answer */
    if (c < s->n_cache && s->cache_keys[c] == key) { /* its last answer, put in place if the island stays asleep */
      memcpy(s->q_pt + 3 * r, s->cache_ans + 6 * c, 3 * sizeof(double));
      memcpy(s->q_nm + 3 * r, s->cache_ans + 6 * c + 3, 3 * sizeof(double));
      memcpy(s->q_pose + 12 * r, s->cache_pose + 12 * c, 12 * sizeof(double));
      ask[r] = 1;
    } else {
      s->island[root] &= (uint8_t)~SLEEP_KNOWN;
    }
  }
  const uint8_t stays = SLEEP_REST | SLEEP_ASLEEP | SLEEP_NEAR | SLEEP_KNOWN;
  for (size_t i = 0; i < m; ++i) {
    if (!s->free[i]) continue;
    size_t root = root_of(s->parent, i);
    uint8_t f = s->island[root];
    if ((f & stays) == stays) {
      s->island[root] |= SLEEP_STAYS; /* asleep: the cached answers */
    } else if (f & SLEEP_REST) {      /* falls asleep: asked once more, at the sleeping pose */
      memcpy(s->p_ref + 3 * i, s->p + 3 * i, 3 * sizeof(double));
      memcpy(s->R_ref + 9 * i, s->R + 9 * i, 9 * sizeof(double));
    }
    s->asleep[i] = (f & SLEEP_REST) ? 1 : 0;
  }
  size_t n = 0;
  for (size_t r = 0; r < k; ++r) {
    size_t root = pair_island(s, r);
    int kept = ask[r] && root < m;
    int reuse = kept && (s->island[root] & SLEEP_STAYS);
    if (!reuse && kept && q->pair_reuse && !s->woken[s->ia[r]] && !s->woken[s->ib[r]]) reuse = near_asked_pose(s, r);
    ask[r] = !reuse;
    if (ask[r]) {
      ++n;
      memcpy(s->q_pose + 12 * r, s->p_AB + 3 * r, 3 * sizeof(double));
      memcpy(s->q_pose + 12 * r + 3, s->R_AB + 9 * r, 9 * sizeof(double));
    } else {
      memcpy(s->point_A + 3 * r, s->q_pt + 3 * r, 3 * sizeof(double));
      memcpy(s->normal_A + 3 * r, s->q_nm + 3 * r, 3 * sizeof(double));
    }
  }
  for (size_t i = 0; i < m; ++i) {
    if (!s->free[i]) continue;
    size_t root = root_of(s->parent, i);
    if ((s->island[root] & (SLEEP_STAYS | SLEEP_PAIRS)) == (SLEEP_STAYS | SLEEP_PAIRS)) ++s->counts.bodies_asleep;
    if (root == i && (s->island[i] & SLEEP_PAIRS)) {
      ++s->counts.islands;
      if (s->island[i] & SLEEP_STAYS) ++s->counts.islands_asleep;
    }
  }
  memset(s->woken, 0, m);
  s->planned = 1;
  s->counts.asked = n;
  s->counts.reused = k - n;
  if (n_asked != NULL) *n_asked = n;
  return CC_OK;
}

/* the step's answers kept for the next (asleep islands reuse them) */
static int keep_answers(cc_step *s) {
  if (s->k > s->cache_cap) {
    size_t cap = s->cache_cap ? s->cache_cap : 64;
    while (cap < s->k) cap *= 2;
    if (!resize((void **)&s->cache_keys, cap, sizeof(int64_t)) || !resize((void **)&s->cache_ans, cap, 6 * sizeof(double)) ||
        !resize((void **)&s->cache_pose, cap, 12 * sizeof(double)))
      return 0;
    s->cache_cap = cap;
  }
  for (size_t r = 0; r < s->k; ++r) {
    s->cache_keys[r] = s->ia[r] * (int64_t)s->m + s->ib[r];
    memcpy(s->cache_ans + 6 * r, s->point_A + 3 * r, 3 * sizeof(double));
    memcpy(s->cache_ans + 6 * r + 3, s->normal_A + 3 * r, 3 * sizeof(double));
    if (s->planned) { /* the pose its answer was asked at (this step's, or the kept one's) */
      memcpy(s->cache_pose + 12 * r, s->q_pose + 12 * r, 12 * sizeof(double));
    } else {
      memcpy(s->cache_pose + 12 * r, s->p_AB + 3 * r, 3 * sizeof(double));
      memcpy(s->cache_pose + 12 * r + 3, s->R_AB + 9 * r, 9 * sizeof(double));
    }
  }
  s->n_cache = s->k;
  return 1;
}
