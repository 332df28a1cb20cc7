/* api_probe.c: prints what the C API says of itself (tests/native/test_c_api.py): the header's and the
 * library's versions, the version check, and the defaults functions' values, one "key value" per line.
 * With -DPROBE_OTHER_ABI it is built as a program from other headers would be (CC_ABI_VERSION changed
 * after the include): CC_CHECK_VERSION() must refuse the library. */
#include <stdio.h>

#include "container_contact_step.h"

#ifdef PROBE_OTHER_ABI
#undef CC_ABI_VERSION
#define CC_ABI_VERSION 9999
#endif

int main(void) {
  printf("version_header %d\nversion_library %d\nabi_header %d\nabi_library %d\ncheck %d\n", CC_VERSION, cc_version(),
         CC_ABI_VERSION, cc_abi_version(), CC_CHECK_VERSION() ? 1 : 0);
  cc_step_params q = cc_step_default_params(0.001);
  printf("margin %.17g\nh %.17g\ndissipation %.17g\nmu %.17g\nstick_hw %.17g\nstick_zeta %.17g\nslip %.17g\n"
         "stiction %.17g\ntorsional %d\ngrid %d\nsweeps %d\nn_types %d\nkappa %.17g\n",
         q.margin, q.h, q.dissipation, q.mu, q.stick_hw, q.stick_zeta, q.slip, q.stiction, q.torsional, q.grid,
         q.sweeps, q.n_types, q.kappa[0]);
  cc_step_sleep s = cc_step_default_sleep();
  printf("sleep_enabled %d\nv_sleep %.17g\nw_sleep %.17g\nt_sleep %.17g\neps_p %.17g\neps_R %.17g\npair_reuse %d\n",
         s.enabled, s.v_sleep, s.w_sleep, s.t_sleep, s.eps_p, s.eps_R, s.pair_reuse);
  return CC_CHECK_VERSION() ? 0 : 3;
}
