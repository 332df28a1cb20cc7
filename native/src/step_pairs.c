/* step_pairs.c: the step's candidate pairs: a sweep-and-prune broad phase over the world boxes,
 * then each near pair's pose of B in A (p_AB, R_AB) and sizes (cc_step_candidates). */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "step_internal.h"

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
        if (!ccs_resize((void **)&s->cand, cap, sizeof(int64_t)) || !ccs_resize((void **)&s->cand_tmp, cap, sizeof(int64_t)))
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
    if (ccs_face_axis_overlap(pn, Rn, s->half + 3 * i, s->half + 3 * j, &owner, &axis) > -margin) {
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
  if (!ccs_reserve_pairs(s, s->n_cand) || !ccs_reserve_held(s, s->n_cand)) return CC_STEP_NO_MEMORY;
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
