/* step_sleep.c: sleeping islands and pair reuse: which of the step's candidates the predictor is
 * asked (cc_step_sleep_plan), the answers kept for the next step, and the sleep state's settings
 * and counts. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "step_internal.h"

void cc_step_sleep_reset(cc_step *s) {
  if (s == NULL) return;
  memset(s->rest, 0, s->m * sizeof(double));
  memset(s->asleep, 0, s->m);
  memset(s->woken, 0, s->m);
  s->n_cache = 0;
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
int ccs_keep_answers(cc_step *s) {
  if (s->k > s->cache_cap) {
    size_t cap = s->cache_cap ? s->cache_cap : 64;
    while (cap < s->k) cap *= 2;
    if (!ccs_resize((void **)&s->cache_keys, cap, sizeof(int64_t)) || !ccs_resize((void **)&s->cache_ans, cap, 6 * sizeof(double)) ||
        !ccs_resize((void **)&s->cache_pose, cap, 12 * sizeof(double)))
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
