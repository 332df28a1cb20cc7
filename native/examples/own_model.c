/* own_model.c: a model the testbed did not ship, through the native contact step (cc_contact_step_with).
 *
 *   make -C native own_model && native/build/own_model learned_contact/shipped/weights.npz
 *
 * Two predictors behind the same step, a 20 ft box dropped on a 3-high column of 20 ft boxes (the lowest
 * fixed), at 1 kHz for 1 s:
 *   1. the shipped model wrapped in a cc_predict_fn (what an ONNX session or any network looks like to the
 *      step): run in lock-step with the fused cc_contact_step on the same states, their wrenches compared
 *      every step, then both timed per call on one state;
 *   2. a model of your own written in C (here the exact static contact's centre of pressure and force
 *      direction, cc_static_contact), timed the same way, then driving the drop.
 * Prints one "key value ..." line per figure (tests/native/test_own_model.py reads them). */
#define _POSIX_C_SOURCE 199309L
#include <math.h>
#include <stdio.h>
#include <string.h>
#include <time.h>

#include "container_contact_step.h"

#define M 5
#define STEPS 1000
static const double H = 1e-3, G = 9.81, SIZE[3] = {6.058, 2.438, 2.591};

/* the shipped model behind the callback: user is its cc_model */
static int shipped(void *user, size_t n, const double *p, const double *R, const double *sA, const double *sB,
                   double *point, double *normal, size_t *bad) {
  return cc_predict((const cc_model *)user, n, p, R, sA, n, sB, n, point, normal, NULL, bad);
}

/* a model of one's own, written in C: the exact static contact's centre of pressure and force direction
 * (cc_static_contact, the truth's own answer at the pose), and where the boxes do not touch, the centre of
 * their overlap on A's face that B's centre lies beyond, with that face's normal */
static int exact_cop(void *user, size_t n, const double *p, const double *R, const double *sA, const double *sB,
                     double *point, double *normal, size_t *bad) {
  (void)user, (void)bad;
  for (size_t r = 0; r < n; ++r) {
    const double *q = p + 3 * r, *a = sA + 3 * r, *b = sB + 3 * r;
    const double hA[3] = {0.5 * a[0], 0.5 * a[1], 0.5 * a[2]}, hB[3] = {0.5 * b[0], 0.5 * b[1], 0.5 * b[2]};
    cc_field_contact c;
    cc_static_contact(q, R + 9 * r, hA, hB, 1e8, 1e8, &c);
    double F = sqrt(c.force[0] * c.force[0] + c.force[1] * c.force[1] + c.force[2] * c.force[2]);
    if (F > 0) {
      for (int k = 0; k < 3; ++k) point[3 * r + k] = c.cop[k], normal[3 * r + k] = c.force[k] / F;
      continue;
    }
    int axis = 0;
    double best = -1.0;
    for (int k = 0; k < 3; ++k)
      if (fabs(q[k]) / a[k] > best) best = fabs(q[k]) / a[k], axis = k;
    for (int k = 0; k < 3; ++k) {
      double lo = fmax(-hA[k], q[k] - hB[k]), hi = fmin(hA[k], q[k] + hB[k]), side = q[k] >= 0 ? 1.0 : -1.0;
      point[3 * r + k] = k == axis ? side * hA[k] : 0.5 * (lo + hi);
      normal[3 * r + k] = k == axis ? side : 0.0;
    }
  }
  return CC_OK;
}

typedef struct {
  double p[3 * M], R[9 * M], v[3 * M], w[3 * M];
} state;

static void start(state *x) {
  memset(x, 0, sizeof *x);
  for (int i = 0; i < M; ++i) {
    x->R[9 * i] = x->R[9 * i + 4] = x->R[9 * i + 8] = 1.0;
    x->p[3 * i + 2] = SIZE[2] * (i + 0.5) - 2e-4 * i; /* the column settled a little */
  }
  x->p[3 * 4 + 0] = 0.3, x->p[3 * 4 + 2] += 0.05;    /* the top box 5 cm up, 0.3 m off centre */
  double t = 0.004, c = cos(t), s = sin(t);          /* and rolled 0.23 deg */
  double *Rt = x->R + 36;
  Rt[4] = c, Rt[5] = -s, Rt[7] = s, Rt[8] = c;
}

/* semi-implicit Euler of the free bodies (1..M-1): velocities from the wrenches, then the poses */
static void advance(state *x, const double *wrench, const double *mass, const double *I) {
  for (int i = 1; i < M; ++i) {
    for (int a = 0; a < 3; ++a) x->v[3 * i + a] += H * wrench[6 * i + 3 + a] / mass[i];
    x->v[3 * i + 2] -= H * G;
    for (int a = 0; a < 3; ++a) x->w[3 * i + a] += H * wrench[6 * i + a] / I[9 * i + 4 * a]; /* small rotations */
    for (int a = 0; a < 3; ++a) x->p[3 * i + a] += H * x->v[3 * i + a];
    double *R = x->R + 9 * i, wx = H * x->w[3 * i], wy = H * x->w[3 * i + 1], wz = H * x->w[3 * i + 2], N[9];
    const double D[9] = {1, -wz, wy, wz, 1, -wx, -wy, wx, 1};
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) N[3 * r + c] = D[3 * r] * R[c] + D[3 * r + 1] * R[3 + c] + D[3 * r + 2] * R[6 + c];
    for (int c = 0; c < 3; ++c) { /* Gram-Schmidt on the columns */
      double len = 0;
      for (int b = 0; b < c; ++b) {
        double d = N[b] * N[c] + N[3 + b] * N[3 + c] + N[6 + b] * N[6 + c];
        for (int r = 0; r < 3; ++r) N[3 * r + c] -= d * N[3 * r + b];
      }
      for (int r = 0; r < 3; ++r) len += N[3 * r + c] * N[3 * r + c];
      for (int r = 0; r < 3; ++r) N[3 * r + c] /= sqrt(len);
    }
    memcpy(R, N, sizeof N);
  }
}

static double now_us(void) {
  struct timespec t;
  clock_gettime(CLOCK_MONOTONIC, &t);
  return 1e6 * (double)t.tv_sec + 1e-3 * (double)t.tv_nsec;
}

int main(int argc, char **argv) {
  if (!CC_CHECK_VERSION()) return fprintf(stderr, "own_model: library ABI %d, header %d\n", cc_abi_version(), CC_ABI_VERSION), 3;
  cc_model model;
  char err[512];
  if (argc < 2 || cc_model_load(argv[1], &model, err, sizeof err) != CC_OK)
    return fprintf(stderr, "own_model: %s\n", argc < 2 ? "usage: own_model WEIGHTS.npz" : err), 2;
  double size[3 * M], mass[M], I[9 * M];
  uint8_t free_[M];
  memset(I, 0, sizeof I);
  for (int i = 0; i < M; ++i) {
    memcpy(size + 3 * i, SIZE, sizeof SIZE);
    free_[i] = i > 0;
    mass[i] = i > 0 ? 12000.0 : INFINITY;
    I[9 * i] = mass[i] / 12 * (SIZE[1] * SIZE[1] + SIZE[2] * SIZE[2]);
    I[9 * i + 4] = mass[i] / 12 * (SIZE[0] * SIZE[0] + SIZE[2] * SIZE[2]);
    I[9 * i + 8] = mass[i] / 12 * (SIZE[0] * SIZE[0] + SIZE[1] * SIZE[1]);
  }
  const cc_step_scene scene = {M, size, free_, mass, I, NULL};
  const cc_step_params params = cc_step_default_params(H);
  int status;
  cc_step *fused = cc_step_create(&scene, &params, &status), *through = cc_step_create(&scene, &params, &status);
  cc_step *own = cc_step_create(&scene, &params, &status);
  if (!fused || !through || !own) return fprintf(stderr, "own_model: cc_step_create: %d\n", status), 1;

  /* 1. the shipped model through the callback, in lock-step with the fused step */
  state a, b;
  start(&a), start(&b);
  double wa[6 * M], wb[6 * M], worst = 0.0, scale = 0.0;
  for (int k = 0; k < STEPS; ++k) {
    if (cc_contact_step(&model, fused, a.p, a.R, a.w, a.v, wa, NULL) != CC_OK ||
        cc_contact_step_with(shipped, &model, through, b.p, b.R, b.w, b.v, wb, NULL) != CC_OK)
      return fprintf(stderr, "own_model: a step failed at %d\n", k), 1;
    for (int j = 0; j < 6 * M; ++j) worst = fmax(worst, fabs(wa[j] - wb[j])), scale = fmax(scale, fabs(wa[j]));
    advance(&a, wa, mass, I), advance(&b, wb, mass, I);
  }
  printf("lockstep_wrench_rel %.17g\nlockstep_top_z %.17g %.17g\n", worst / scale, a.p[14], b.p[14]);

  /* per-call cost on the settled state, each step alike (best of 5 rounds of 200 calls) */
  double cost[3] = {INFINITY, INFINITY, INFINITY};
  for (int round = 0; round < 5; ++round)
    for (int which = 0; which < 3; ++which) {
      double t0 = now_us();
      for (int k = 0; k < 200; ++k) {
        if (which == 0) cc_contact_step(&model, fused, a.p, a.R, a.w, a.v, wa, NULL);
        if (which == 1) cc_contact_step_with(shipped, &model, through, a.p, a.R, a.w, a.v, wa, NULL);
        if (which == 2) cc_contact_step_with(exact_cop, NULL, own, a.p, a.R, a.w, a.v, wa, NULL);
      }
      cost[which] = fmin(cost[which], (now_us() - t0) / 200);
    }
  printf("cost_us fused %.3f callback %.3f own %.3f\n", cost[0], cost[1], cost[2]);

  /* 2. the model of one's own drives the drop */
  state c;
  start(&c);
  cc_step_forget(own);
  for (int k = 0; k < STEPS; ++k) {
    if (cc_contact_step_with(exact_cop, NULL, own, c.p, c.R, c.w, c.v, wa, NULL) != CC_OK) return 1;
    advance(&c, wa, mass, I);
  }
  printf("own_top %.17g %.17g %.17g speed %.6e\n", c.p[12], c.p[13], c.p[14],
         sqrt(c.v[12] * c.v[12] + c.v[13] * c.v[13] + c.v[14] * c.v[14]));
  cc_step_free(fused), cc_step_free(through), cc_step_free(own);
  cc_model_free(&model);
  return 0;
}
