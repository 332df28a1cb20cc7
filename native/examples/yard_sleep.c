/* yard_sleep.c: what the native step's sleeping saves on a resting yard (cc_contact_step, awake and asleep).
 *
 *   make -C native yard_sleep && native/build/yard_sleep learned_contact/shipped/weights.npz [N ...] [-steps K]
 *
 * For each N (default 200 and 1000): a static yard of N free 40 ft boxes (1AA, 12.192 x 2.438 x 2.591 m,
 * 20 t each) in 5-high stacks, N / 5 stacks in rows 0.4 m apart and bays 0.6 m apart (the scale study's
 * gaps, testbed/studies/scale/settings.py), each stack standing on one fixed 40 ft box (the step has no
 * quay: the fixed box stands in for it). Every interface is pressed by the weight above it (penetration
 * W / (kappa A) at the default kappa), every velocity is zero, and the poses are not integrated: each
 * call sees the same resting yard, so the two steps compared differ by sleeping alone:
 *   awake:  sleeping off (cc_step_set_sleep(NULL)): every candidate pair asked every step;
 *   asleep: the testbed's defaults (cc_step_default_sleep), after 1.2 t_sleep of steps at rest: every
 *           island asleep, its pairs reusing their last answers while the force law still runs.
 * Both steps are timed side by side, round by round (best of 7 rounds of K calls, default K = 100), wall and
 * process CPU time. Prints one "key value ..." line per figure (tests/native/test_yard_sleep.py reads them):
 *   yard N stacks pairs                   the yard and its candidate pairs (one per interface)
 *   awake_us WALL CPU / asleep_us WALL CPU   microseconds per cc_contact_step
 *   ratio WALL CPU                        asleep over awake
 *   asked AWAKE ASLEEP / bodies_asleep B  the sleeping counts of the last timed calls
 *   wrench_rel R                          the largest wrench difference asleep vs awake over the largest wrench */
#define _POSIX_C_SOURCE 199309L
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "container_contact_step.h"

#define TIERS 5
#define ROUNDS 7
static const double H = 1e-3, G = 9.81, MASS = 20000.0, SIZE[3] = {12.192, 2.438, 2.591};
static const double ROW_GAP = 0.4, BAY_GAP = 0.6, KAPPA = 4.1017e7; /* [m], [m], [Pa/m] cc_step_default_params' */

static double clock_us(clockid_t which) {
  struct timespec t;
  clock_gettime(which, &t);
  return 1e6 * (double)t.tv_sec + 1e-3 * (double)t.tv_nsec;
}

typedef struct {
  size_t m; /* bodies: N free, then N / TIERS fixed */
  double *size, *mass, *I, *p, *R, *w, *v, *wa, *wb;
  uint8_t *free_;
} yard;

static int yard_make(yard *y, size_t n) {
  size_t stacks = n / TIERS, rows = 1, m = n + stacks;
  for (size_t d = 1; d * d <= stacks; ++d)
    if (stacks % d == 0) rows = d;
  y->m = m;
  y->size = calloc(3 * m, sizeof(double)), y->mass = calloc(m, sizeof(double)), y->I = calloc(9 * m, sizeof(double));
  y->p = calloc(3 * m, sizeof(double)), y->R = calloc(9 * m, sizeof(double)), y->w = calloc(3 * m, sizeof(double));
  y->v = calloc(3 * m, sizeof(double)), y->wa = calloc(6 * m, sizeof(double)), y->wb = calloc(6 * m, sizeof(double));
  y->free_ = calloc(m, 1);
  if (!y->size || !y->mass || !y->I || !y->p || !y->R || !y->w || !y->v || !y->wa || !y->wb || !y->free_) return 0;
  const double area = SIZE[0] * SIZE[1];
  for (size_t s = 0; s < stacks; ++s) {
    double x = (double)(s / rows) * (SIZE[0] + BAY_GAP), yy = (double)(s % rows) * (SIZE[1] + ROW_GAP);
    double z = -0.5 * SIZE[2]; /* the fixed stand-in's centre: its top at z = 0 */
    for (size_t t = 0; t <= TIERS; ++t) {
      size_t i = t == 0 ? n + s : s * TIERS + (t - 1); /* free bodies first, stack by stack */
      if (t > 0) z += SIZE[2] - (double)(TIERS - t + 1) * MASS * G / (KAPPA * area); /* pressed by the tiers above */
      memcpy(y->size + 3 * i, SIZE, sizeof SIZE);
      y->free_[i] = t > 0;
      y->mass[i] = t > 0 ? MASS : INFINITY;
      y->I[9 * i] = MASS / 12 * (SIZE[1] * SIZE[1] + SIZE[2] * SIZE[2]);
      y->I[9 * i + 4] = MASS / 12 * (SIZE[0] * SIZE[0] + SIZE[2] * SIZE[2]);
      y->I[9 * i + 8] = MASS / 12 * (SIZE[0] * SIZE[0] + SIZE[1] * SIZE[1]);
      y->R[9 * i] = y->R[9 * i + 4] = y->R[9 * i + 8] = 1.0;
      y->p[3 * i] = x, y->p[3 * i + 1] = yy, y->p[3 * i + 2] = z;
    }
  }
  return 1;
}

static void yard_free(yard *y) {
  free(y->size), free(y->mass), free(y->I), free(y->p), free(y->R), free(y->w), free(y->v), free(y->wa), free(y->wb);
  free(y->free_);
}

static int bench(const cc_model *model, size_t n, int calls) {
  yard y;
  if (n < TIERS || n % TIERS) return fprintf(stderr, "yard_sleep: N = %zu is not a multiple of %d\n", n, TIERS), 2;
  if (!yard_make(&y, n)) return fprintf(stderr, "yard_sleep: out of memory\n"), 1;
  const cc_step_scene scene = {y.m, y.size, y.free_, y.mass, y.I, NULL};
  const cc_step_params params = cc_step_default_params(H);
  const cc_step_sleep sleep = cc_step_default_sleep();
  int status;
  cc_step *awake = cc_step_create(&scene, &params, &status), *asleep = cc_step_create(&scene, &params, &status);
  if (!awake || !asleep) return fprintf(stderr, "yard_sleep: cc_step_create: %d\n", status), 1;
  cc_step_set_sleep(awake, NULL);
  cc_step_set_sleep(asleep, &sleep);
  int warm = (int)ceil(1.2 * sleep.t_sleep / H) + 1; /* both steps alike: the asleep one falls asleep */
  for (int k = 0; k < warm; ++k)
    if (cc_contact_step(model, awake, y.p, y.R, y.w, y.v, y.wa, NULL) != CC_OK ||
        cc_contact_step(model, asleep, y.p, y.R, y.w, y.v, y.wb, NULL) != CC_OK)
      return fprintf(stderr, "yard_sleep: a step failed at %d\n", k), 1;
  double best[2][2] = {{INFINITY, INFINITY}, {INFINITY, INFINITY}}; /* [awake, asleep][wall, cpu] */
  for (int round = 0; round < ROUNDS; ++round)
    for (int which = 0; which < 2; ++which) {
      cc_step *step = which ? asleep : awake;
      double *wrench = which ? y.wb : y.wa;
      double t0 = clock_us(CLOCK_MONOTONIC), c0 = clock_us(CLOCK_PROCESS_CPUTIME_ID);
      for (int k = 0; k < calls; ++k) cc_contact_step(model, step, y.p, y.R, y.w, y.v, wrench, NULL);
      double wall = (clock_us(CLOCK_MONOTONIC) - t0) / calls, cpu = (clock_us(CLOCK_PROCESS_CPUTIME_ID) - c0) / calls;
      best[which][0] = fmin(best[which][0], wall), best[which][1] = fmin(best[which][1], cpu);
    }
  cc_step_sleep_counts ca, cb;
  cc_step_sleep_get_counts(awake, &ca);
  cc_step_sleep_get_counts(asleep, &cb);
  cc_step_pairs pairs;
  cc_step_view(awake, &pairs);
  double worst = 0.0, scale = 0.0;
  for (size_t j = 0; j < 6 * y.m; ++j) worst = fmax(worst, fabs(y.wa[j] - y.wb[j])), scale = fmax(scale, fabs(y.wa[j]));
  printf("yard %zu %zu %zu\n", n, n / TIERS, pairs.n);
  printf("awake_us %.3f %.3f\nasleep_us %.3f %.3f\n", best[0][0], best[0][1], best[1][0], best[1][1]);
  printf("ratio %.4f %.4f\n", best[1][0] / best[0][0], best[1][1] / best[0][1]);
  printf("asked %zu %zu\nbodies_asleep %zu\nwrench_rel %.3g\n", ca.asked, cb.asked, cb.bodies_asleep,
         scale > 0 ? worst / scale : 0.0);
  cc_step_free(awake), cc_step_free(asleep), yard_free(&y);
  return 0;
}

int main(int argc, char **argv) {
  if (!CC_CHECK_VERSION()) return fprintf(stderr, "yard_sleep: library ABI %d, header %d\n", cc_abi_version(), CC_ABI_VERSION), 3;
  cc_model model;
  char err[512];
  if (argc < 2 || cc_model_load(argv[1], &model, err, sizeof err) != CC_OK)
    return fprintf(stderr, "yard_sleep: %s\n", argc < 2 ? "usage: yard_sleep WEIGHTS.npz [N ...] [-steps K]" : err), 2;
  int calls = 100, done = 0;
  for (int a = 2; a < argc; ++a)
    if (!strcmp(argv[a], "-steps") && a + 1 < argc) calls = atoi(argv[++a]);
  if (calls < 1) return fprintf(stderr, "yard_sleep: -steps expects a positive count\n"), 2;
  for (int a = 2; a < argc; ++a) {
    if (!strcmp(argv[a], "-steps")) {
      ++a;
      continue;
    }
    int rc = bench(&model, (size_t)strtoul(argv[a], NULL, 10), calls);
    if (rc) return rc;
    done = 1;
  }
  if (!done) {
    int rc = bench(&model, 200, calls);
    if (rc || (rc = bench(&model, 1000, calls))) return rc;
  }
  cc_model_free(&model);
  return 0;
}
