/* defaults.c: the library's version, its status names and the testbed's defaults for the step's
 * configuration (container_contact.h: cc_version, cc_abi_version, cc_status_name;
 * container_contact_step.h: cc_step_default_params,
 * cc_step_default_sleep). The values are the testbed's LearnedDynamicsConfig and SleepingConfig
 * defaults (testbed/effects/learned_dynamics/); tests/native/test_c_api.py holds them equal. */
#include "container_contact_step.h"

int cc_version(void) { return CC_VERSION; }

int cc_abi_version(void) { return CC_ABI_VERSION; }

const char *cc_status_name(int status) {
  static const char *const names[] = {"CC_OK", "CC_BAD_POSE", "CC_SIZE_A_UNSUPPORTED", "CC_SIZE_B_UNSUPPORTED",
                                      "CC_SIZE_A_NOT_FINITE", "CC_SIZE_B_NOT_FINITE", "CC_BAD_ROTATION",
                                      "CC_BAD_ARGUMENT", "CC_FILE_ERROR"};
  if (status < 0 || status >= (int)(sizeof names / sizeof names[0])) return "CC_UNKNOWN_STATUS";
  return names[status];
}

/* [Pa/m] the fitted pressure stiffness of every shipped type pair at 1e8 Pa (force_law.FITTED_KAPPA) */
static const double DEFAULT_KAPPA = 4.1017e7;

cc_step_params cc_step_default_params(double h) {
  cc_step_params q;
  q.margin = 0.05;
  q.h = h;
  q.dissipation = 5.0;
  q.mu = 0.4;
  q.stick_hw = 0.3;
  q.stick_zeta = 0.5;
  q.slip = 1e-4;
  q.stiction = 0.5;
  q.torsional = 1;
  q.grid = 0;
  q.sweeps = 4;
  q.n_types = 1;
  q.kappa = &DEFAULT_KAPPA;
  return q;
}

cc_step_sleep cc_step_default_sleep(void) {
  cc_step_sleep s;
  s.enabled = 1;
  s.v_sleep = 1e-3;
  s.w_sleep = 1e-3;
  s.t_sleep = 0.3;
  s.eps_p = 1e-4;
  s.eps_R = 1e-6;
  s.pair_reuse = 0;
  return s;
}
