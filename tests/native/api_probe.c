/* api_probe.c: prints what the C API says of itself (tests/native/test_c_api.py): the header's and the
 * library's versions, the version check, and the defaults functions' values, one "key value" per line;
 * given a weights file, also the predictor's answers and the exact static contact on three poses
 * ("predict i x y z nx ny nz depth", "static i Fx Fy Fz k"), the same program on Linux and, built with
 * MinGW-w64 against the DLL, under Wine.
 * With -DPROBE_OTHER_ABI it is built as a program from other headers would be (CC_ABI_VERSION changed
 * after the include): CC_CHECK_VERSION() must refuse the library. */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "container_contact_step.h"

#ifdef PROBE_OTHER_ABI
#undef CC_ABI_VERSION
#define CC_ABI_VERSION 9999
#endif

static void rpy(double r, double p, double y, double *R) {
  double cr = cos(r), sr = sin(r), cp = cos(p), sp = sin(p), cy = cos(y), sy = sin(y);
  double M[9] = {cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr, sy * cp, sy * sp * sr + cy * cr,
                 sy * sp * cr - cy * sr, -sp, cp * sr, cp * cr};
  for (int i = 0; i < 9; ++i) R[i] = M[i];
}

static int answers(const char *weights) {
  cc_model model;
  char err[512];
  if (cc_model_load(weights, &model, err, sizeof err) != CC_OK) {
    fprintf(stderr, "%s\n", err);
    return 2;
  }
  const double size[3] = {6.058, 2.438, 2.591};
  double p[9] = {0.01, 0.0, 2.589, 0.3, -0.1, 2.588, 1.2, 0.4, 2.585}, R[27], point[9], normal[9], depth[3];
  rpy(0, 0, 0, R);
  rpy(0.004, -0.002, 0.03, R + 9);
  rpy(0.02, 0.03, 0.6, R + 18);
  int status = cc_predict(&model, 3, p, R, size, 1, size, 1, point, normal, depth, NULL);
  for (int i = 0; status == CC_OK && i < 3; ++i) {
    printf("predict%d %.17g %.17g %.17g %.17g %.17g %.17g %.17g\n", i, point[3 * i], point[3 * i + 1], point[3 * i + 2],
           normal[3 * i], normal[3 * i + 1], normal[3 * i + 2], depth[i]);
    cc_field_contact c;
    cc_static_contact(p + 3 * i, R + 9 * i, (const double[3]){3.029, 1.219, 1.2955}, (const double[3]){3.029, 1.219, 1.2955},
                      1e8, 1e8, &c);
    printf("static%d %.17g %.17g %.17g %.17g\n", i, c.force[0], c.force[1], c.force[2], c.stiffness);
  }
  cc_model_free(&model);
  return status == CC_OK ? 0 : 1;
}

/* 1 where cc_status_name names every enumerator as the header spells it (the names made from the
 * enumerators themselves) and an unknown value as CC_UNKNOWN_STATUS, else 0. */
#define NAMED(x) {x, #x}
static int status_names_ok(void) {
  const struct { int value; const char *name; } all[] = {
      NAMED(CC_OK), NAMED(CC_BAD_POSE), NAMED(CC_SIZE_A_UNSUPPORTED), NAMED(CC_SIZE_B_UNSUPPORTED),
      NAMED(CC_SIZE_A_NOT_FINITE), NAMED(CC_SIZE_B_NOT_FINITE), NAMED(CC_BAD_ROTATION), NAMED(CC_BAD_ARGUMENT),
      NAMED(CC_FILE_ERROR)};
  for (size_t i = 0; i < sizeof all / sizeof all[0]; ++i)
    if (strcmp(cc_status_name(all[i].value), all[i].name) != 0) return 0;
  return strcmp(cc_status_name(-1), "CC_UNKNOWN_STATUS") == 0 && strcmp(cc_status_name(9), "CC_UNKNOWN_STATUS") == 0;
}

int main(int argc, char **argv) {
  printf("version_header %d\nversion_library %d\nabi_header %d\nabi_library %d\ncheck %d\n", CC_VERSION, cc_version(),
         CC_ABI_VERSION, cc_abi_version(), CC_CHECK_VERSION() ? 1 : 0);
  printf("status_names %d\n", status_names_ok());
  cc_step_params q = cc_step_default_params(0.001);
  printf("margin %.17g\nh %.17g\ndissipation %.17g\nmu %.17g\nstick_hw %.17g\nstick_zeta %.17g\nslip %.17g\n"
         "stiction %.17g\ntorsional %d\ngrid %d\nsweeps %d\nn_types %d\nkappa %.17g\n",
         q.margin, q.h, q.dissipation, q.mu, q.stick_hw, q.stick_zeta, q.slip, q.stiction, q.torsional, q.grid,
         q.sweeps, q.n_types, q.kappa[0]);
  cc_step_sleep s = cc_step_default_sleep();
  printf("sleep_enabled %d\nv_sleep %.17g\nw_sleep %.17g\nt_sleep %.17g\neps_p %.17g\neps_R %.17g\npair_reuse %d\n",
         s.enabled, s.v_sleep, s.w_sleep, s.t_sleep, s.eps_p, s.eps_R, s.pair_reuse);
  if (argc > 1 && answers(argv[1]) != 0) return 1;
  return CC_CHECK_VERSION() ? 0 : 3;
}
