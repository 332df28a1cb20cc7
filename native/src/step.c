/* step.c: the learned contact step (container_contact_step.h): create, free, parameters and the
 * held state, and the order of one step's work (candidates, sleeping, the predictor, the law).
 * The concepts it calls live beside it (step_internal.h lists them). A port of the testbed's
 * numba kernels (formerly testbed/effects/learned_dynamics/kernels.py) with the same arithmetic
 * in the same order, so its answers equal theirs to rounding (tests/closed_loop/test_native_step.py). */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#if defined(_WIN32)
#include <windows.h>
#endif

#include "step_internal.h"

int ccs_resize(void **ptr, size_t count, size_t elem) {
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
      !(isfinite(q->slip) && q->slip > 0) || !(q->stiction >= 0 && q->stiction <= 1) || q->grid < 0 ||
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
                   s->history, s->p, s->R, s->lo, s->hi, s->box, s->box_free, s->inv_m, s->invI, s->n_touch, s->Jd, s->acc,
                   s->dacc, s->history_next,
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
  if (!ccs_resize((void **)&s->kappa, t2, sizeof(double))) return CC_STEP_NO_MEMORY;
  memcpy(s->kappa, q->kappa, t2 * sizeof(double));
  s->par = *q;
  s->par.kappa = s->kappa;
  return CC_OK;
}

int cc_step_set_params(cc_step *s, const cc_step_params *q) {
  if (s == NULL || !check_params(q, s->type, s->m)) return CC_BAD_ARGUMENT;
  return set_params(s, q);
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
  int ok = ccs_resize((void **)&s->size, 3 * m, sizeof(double)) && ccs_resize((void **)&s->half, 3 * m, sizeof(double)) &&
           ccs_resize((void **)&s->radius, m, sizeof(double)) && ccs_resize((void **)&s->mass, m, sizeof(double)) &&
           ccs_resize((void **)&s->I_Bo, 9 * m, sizeof(double)) && ccs_resize((void **)&s->free, m, 1) &&
           ccs_resize((void **)&s->type, m, sizeof(int64_t)) && ccs_resize((void **)&s->history, BODY * m, sizeof(double)) &&
           ccs_resize((void **)&s->history_next, BODY * m, sizeof(double)) &&
           ccs_resize((void **)&s->p, 3 * m, sizeof(double)) && ccs_resize((void **)&s->R, 9 * m, sizeof(double)) &&
           ccs_resize((void **)&s->lo, 3 * m, sizeof(double)) && ccs_resize((void **)&s->hi, 3 * m, sizeof(double)) &&
           ccs_resize((void **)&s->inv_m, m, sizeof(double)) && ccs_resize((void **)&s->invI, 9 * m, sizeof(double)) &&
           ccs_resize((void **)&s->n_touch, m, sizeof(double)) &&
           ccs_resize((void **)&s->acc, 6 * m, sizeof(double)) && ccs_resize((void **)&s->dacc, 6 * m, sizeof(double)) &&
           ccs_resize((void **)&s->order, m, sizeof(size_t)) && ccs_resize((void **)&s->order_tmp, m, sizeof(size_t)) &&
           ccs_resize((void **)&s->need, m, 1) && ccs_resize((void **)&s->box, 6 * m, sizeof(double)) &&
           ccs_resize((void **)&s->box_free, m, 1) && ccs_resize((void **)&s->rest, m, sizeof(double)) &&
           ccs_resize((void **)&s->asleep, m, 1) && ccs_resize((void **)&s->p_ref, 3 * m, sizeof(double)) &&
           ccs_resize((void **)&s->R_ref, 9 * m, sizeof(double)) && ccs_resize((void **)&s->parent, m, sizeof(size_t)) &&
           ccs_resize((void **)&s->island, m, 1) && ccs_resize((void **)&s->woken, m, 1);
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
  if (!ccs_reserve_pairs(s, 1) || !ccs_reserve_held(s, 1)) { /* every array non-null from here on */
    cc_step_free(s);
    *status = CC_STEP_NO_MEMORY;
    return NULL;
  }
  cc_step_forget(s);
  *status = CC_OK;
  return s;
}

/* the per-pair arrays hold n pairs */
int ccs_reserve_pairs(cc_step *s, size_t n) {
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
      {(void **)&s->q_pose, 12 * sizeof(double)}, {(void **)&s->Jd, 9 * sizeof(double)},
  };
  for (size_t i = 0; i < sizeof arrays / sizeof arrays[0]; ++i)
    if (!ccs_resize(arrays[i].ptr, cap, arrays[i].elem)) return 0;
  s->cap = cap;
  return 1;
}

int ccs_reserve_held(cc_step *s, size_t n) {
  if (n <= s->held_cap && s->held_cap > 0) return 1;
  size_t cap = s->held_cap ? s->held_cap : 64;
  while (cap < n) cap *= 2;
  if (!ccs_resize((void **)&s->keys, cap, sizeof(int64_t)) || !ccs_resize((void **)&s->rows, cap, ROW * sizeof(double)))
    return 0;
  s->held_cap = cap;
  return 1;
}

static int run_law(cc_step *s, const double *w_WB, const double *v_WB, double *wrench_W) {
  ccs_gather_pairs(s);
  ccs_pair_wrenches(s, w_WB, v_WB, wrench_W);
  ccs_commit_held(s);
  if (s->sleep.enabled && !ccs_keep_answers(s)) return CC_STEP_NO_MEMORY;
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

int cc_step_force_law_given(cc_step *s, const double *w_WB, const double *v_WB, const double *point_A,
                            const double *normal_A, const double *elastic, double *wrench_W) {
  if (s != NULL && s->k > 0 && elastic == NULL) return CC_BAD_ARGUMENT;
  if (s != NULL && elastic != NULL)
    for (size_t i = 0; i < 3 * s->k; ++i)
      if (!isfinite(elastic[i])) return CC_BAD_ARGUMENT;
  if (s != NULL) s->given = elastic;
  int status = cc_step_force_law(s, w_WB, v_WB, point_A, normal_A, wrench_W);
  if (s != NULL) s->given = NULL;
  return status;
}

/* The predictor on n rows: the shipped model's cc_predict, or the caller's function. */
static int predict_rows(const cc_model *model, cc_predict_fn fn, void *user, size_t n, const double *p, const double *R,
                        const double *sA, const double *sB, double *point, double *normal, size_t *bad) {
  if (model != NULL) return cc_predict(model, n, p, R, sA, n, sB, n, point, normal, NULL, bad);
  return fn(user, n, p, R, sA, sB, point, normal, bad);
}

/* the predictor on the asked rows only (packed), the answers put back in their rows */
static int predict_asked(const cc_model *model, cc_predict_fn fn, void *user, cc_step *s, size_t n_ask,
                         size_t *bad_row) {
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
  int status = predict_rows(model, fn, user, n, s->q_p, s->q_R, s->q_sA, s->q_sB, s->q_pt, s->q_nm, &bad);
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

#if defined(_WIN32) /* MinGW-w64's C runtime (msvcrt) has no timespec_get */
static double now_s(void) {
  LARGE_INTEGER f, c;
  if (!QueryPerformanceFrequency(&f) || !QueryPerformanceCounter(&c)) return 0.0;
  return (double)c.QuadPart / (double)f.QuadPart;
}
#else
static double now_s(void) {
  struct timespec t;
  if (timespec_get(&t, TIME_UTC) != TIME_UTC) return 0.0;
  return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}
#endif

/* The fused step with the predictor either the model (fn NULL) or fn (model NULL). */
static int fused_step(const cc_model *model, cc_predict_fn fn, void *user, cc_step *s, const double *p_WB,
                      const double *R_WB, const double *w_WB, const double *v_WB, double *wrench_W, size_t *bad_row,
                      double seconds[3]) {
  if ((model == NULL) == (fn == NULL) || s == NULL || (s->m > 0 && (w_WB == NULL || v_WB == NULL || wrench_W == NULL)))
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
      size_t bad = k;
      status = predict_rows(model, fn, user, k, s->p_AB, s->R_AB, s->size_A, s->size_B, s->point_A, s->normal_A, &bad);
      if (bad_row != NULL) *bad_row = bad;
    } else {
      status = predict_asked(model, fn, user, s, n_ask, bad_row);
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

int cc_contact_step_timed(const cc_model *model, cc_step *s, const double *p_WB, const double *R_WB,
                          const double *w_WB, const double *v_WB, double *wrench_W, size_t *bad_row,
                          double seconds[3]) {
  if (model == NULL) return CC_BAD_ARGUMENT;
  return fused_step(model, NULL, NULL, s, p_WB, R_WB, w_WB, v_WB, wrench_W, bad_row, seconds);
}

int cc_contact_step(const cc_model *model, cc_step *s, const double *p_WB, const double *R_WB, const double *w_WB,
                    const double *v_WB, double *wrench_W, size_t *bad_row) {
  return cc_contact_step_timed(model, s, p_WB, R_WB, w_WB, v_WB, wrench_W, bad_row, NULL);
}

int cc_contact_step_with(cc_predict_fn predict, void *user, cc_step *s, const double *p_WB, const double *R_WB,
                         const double *w_WB, const double *v_WB, double *wrench_W, size_t *bad_row) {
  if (predict == NULL) return CC_BAD_ARGUMENT;
  return fused_step(NULL, predict, user, s, p_WB, R_WB, w_WB, v_WB, wrench_W, bad_row, NULL);
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
  if (!ccs_reserve_held(s, n)) return CC_STEP_NO_MEMORY;
  memcpy(s->keys, keys, n * sizeof(int64_t));
  memcpy(s->rows, rows, ROW * n * sizeof(double));
  s->n_held = n;
  if (history != NULL)
    memcpy(s->history, history, BODY * s->m * sizeof(double));
  else
    for (size_t i = 0; i < s->m * BODY; ++i) s->history[i] = NAN;
  return CC_OK;
}
