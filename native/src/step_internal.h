/* step_internal.h: what the learned contact step's source files share (not installed; the
 * public API is container_contact_step.h). The step is split by concept:
 *   step.c          create, free, parameters, held state, and one step's order of work
 *   step_pairs.c    broad phase and the candidate pairs' poses
 *   step_elastic.c  the foundation integral: a pair's elastic force, area and stiffness (the old law)
 *   step_field.c    the exact field contact at any pose: the law's force, area and stiffness
 *   step_damping.c  Hunt-Crossley's torque from the field contact's pressure spread
 *   step_law.c      the force law: normal and friction impulses, the pairs' wrenches
 *   step_sleep.c    sleeping islands and pair reuse (which candidates the predictor is asked)
 * Internal functions are prefixed ccs_. */
#ifndef CC_STEP_INTERNAL_H
#define CC_STEP_INTERNAL_H

#include <math.h>
#include <stddef.h>
#include <stdint.h>

#include "container_contact_step.h"

#define ROW CC_STEP_ROW
#define BODY CC_STEP_BODY
#define CC_PI 3.141592653589793 /* numpy's pi */

/* the step: its scene, parameters, held state and workspace (opaque to the public API) */
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
  double *n_touch; /* (m) the touching pairs each body is in (the damping torque's share) */
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
  const double *given; /* (k, 3) the caller's elastic answers (F [N], dF/dd [N/m], area [m^2]) for one
                          law (cc_step_force_law_given), else NULL: the law's own (par.grid) */
  int64_t *ia, *ib;
  double *p_AB, *R_AB, *size_A, *size_B, *point_A, *normal_A, *fn, *f_W, *p_W, *n_W, *area;
  double *kap, *held, *anchors_next, *stuck_next, *F_el, *g, *W_rr, *vn0, *an_ext, *rA, *rB, *cA, *cB, *f;
  double *Jd; /* (cap, 9) the exact field contact's damping inertia, A's frame (grid 0) */
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

/* Python's max(a, b) / min(a, b): the first unless the second is strictly beyond it */
static inline double py_max(double a, double b) { return b > a ? b : a; }
static inline double py_min(double a, double b) { return b < a ? b : a; }

/* step.c */
int ccs_resize(void **ptr, size_t count, size_t elem); /* realloc to count elements; 0 when out of memory */
int ccs_reserve_pairs(cc_step *s, size_t n);            /* the per-pair arrays hold n pairs; 0 when out of memory */
int ccs_reserve_held(cc_step *s, size_t n);             /* the held rows hold n pairs; 0 when out of memory */

/* step_elastic.c */
void ccs_elastic_stiff(const double *p, const double *R, const double *hA, const double *hB, double kappa, int grid,
                       double *F, double *area, double *k_n);

/* step_field.c */
void ccs_field_stiff(const double *p, const double *R, const double *hA, const double *hB, double kappa, double *F,
                     double *area, double *k_n, double *J);

/* step_damping.c: tau += pair r's Hunt-Crossley torque on B (backward Euler in its relative rate) */
void ccs_damping_torque(const cc_step *s, size_t r, size_t i, size_t j, const double *wi, const double *wj, double d,
                        double h, double *tau);

/* step_law.c */
void ccs_gather_pairs(cc_step *s);
void ccs_pair_wrenches(cc_step *s, const double *w, const double *v, double *out);
void ccs_commit_held(cc_step *s);

/* step_sleep.c */
int ccs_keep_answers(cc_step *s); /* 0 when out of memory */

/* The separating-axis test on the 6 face axes (A's 3, B's 3): the least overlap [m]
 * (negative: separated by at least that); *owner 0 = A / 1 = B, *axis its index. */
static inline double ccs_face_axis_overlap(const double *p, const double *R, const double *hA, const double *hB,
                                           int *owner, int *axis) {
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

#endif
