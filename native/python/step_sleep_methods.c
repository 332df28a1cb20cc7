/* step_sleep_methods.c: the contact step's sleeping islands through CPython (cc_step_set_sleep,
 * cc_step_sleep_*), joined into learned_contact._native by module.c (step_bindings.h: what
 * they take). */
#include "step_bindings.h" /* first: Python.h before the standard headers */

/* step_set_sleep(step, (enabled, v_sleep, w_sleep, t_sleep, eps_p, eps_R[, pair_reuse])) (cc_step_set_sleep) */
static PyObject *py_step_set_sleep(PyObject *self, PyObject *const *args, Py_ssize_t nargs) {
  (void)self;
  ARGS(2, "step, (enabled, v_sleep, w_sleep, t_sleep, eps_p, eps_R[, pair_reuse])");
  cc_step *s = cc_py_step_of(args[0]);
  if (s == NULL) return NULL;
  PyObject *seq = PySequence_Fast(args[1], "sleep: expected a sequence of 6 or 7 numbers");
  if (seq == NULL) return NULL;
  Py_ssize_t count = PySequence_Fast_GET_SIZE(seq);
  if (count != 6 && count != 7) {
    Py_DECREF(seq);
    PyErr_SetString(PyExc_ValueError,
                    "sleep: expected 6 or 7 numbers (enabled, v_sleep, w_sleep, t_sleep, eps_p, eps_R[, pair_reuse])");
    return NULL;
  }
  double x[7] = {0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0};
  for (Py_ssize_t i = 0; i < count; ++i) {
    x[i] = PyFloat_AsDouble(PySequence_Fast_GET_ITEM(seq, i));
    if (x[i] == -1.0 && PyErr_Occurred()) {
      Py_DECREF(seq);
      return NULL;
    }
  }
  Py_DECREF(seq);
  cc_step_sleep q = {x[0] != 0.0, x[1], x[2], x[3], x[4], x[5], x[6] != 0.0};
  if (cc_step_set_sleep(s, &q) != CC_OK) {
    cc_py_status_error(CC_BAD_ARGUMENT, "step_set_sleep (v_sleep, w_sleep, t_sleep, eps_p, eps_R finite >= 0)");
    return NULL;
  }
  Py_RETURN_NONE;
}

static PyObject *py_step_sleep_reset(PyObject *self, PyObject *const *args, Py_ssize_t nargs) {
  (void)self;
  ARGS(1, "step");
  cc_step *s = cc_py_step_of(args[0]);
  if (s == NULL) return NULL;
  cc_step_sleep_reset(s);
  Py_RETURN_NONE;
}

/* step_sleep_wake(step, bodies (n) int64) */
static PyObject *py_step_sleep_wake(PyObject *self, PyObject *const *args, Py_ssize_t nargs) {
  (void)self;
  ARGS(2, "step, bodies");
  cc_step *s = cc_py_step_of(args[0]);
  if (s == NULL) return NULL;
  buffers b = {.n = 0};
  void *bodies;
  Py_ssize_t n;
  if (cc_py_take(&b, args[1], "bodies", 'q', -1, 0, 0, &bodies, &n) < 0) {
    cc_py_release(&b);
    return NULL;
  }
  cc_step_sleep_wake(s, (size_t)n, bodies);
  cc_py_release(&b);
  Py_RETURN_NONE;
}

/* step_sleep_plan(step, w (m, 3), v (m, 3), ask (k) uint8 out) -> the rows to ask */
static PyObject *py_step_sleep_plan(PyObject *self, PyObject *const *args, Py_ssize_t nargs) {
  (void)self;
  ARGS(4, "step, w_WB, v_WB, ask");
  cc_step *s = cc_py_step_of(args[0]);
  if (s == NULL) return NULL;
  Py_ssize_t m = n_bodies(s);
  cc_step_pairs view;
  cc_step_view(s, &view);
  buffers b = {.n = 0};
  void *w, *v, *ask;
  PyObject *result = NULL;
  if (cc_py_take(&b, args[1], "w_WB", 'd', 3 * m, 0, 0, &w, NULL) == 0 &&
      cc_py_take(&b, args[2], "v_WB", 'd', 3 * m, 0, 0, &v, NULL) == 0 &&
      cc_py_take(&b, args[3], "ask", 'b', (Py_ssize_t)view.n, 1, 0, &ask, NULL) == 0) {
    size_t n = 0;
    int status = cc_step_sleep_plan(s, w, v, ask, &n);
    if (status == CC_OK)
      result = PyLong_FromSize_t(n);
    else
      cc_py_status_error(status, "step_sleep_plan (run step_candidates first)");
  }
  cc_py_release(&b);
  return result;
}

/* step_sleep_counts(step) -> (asked, reused, islands, islands_asleep, bodies_asleep) of the latest step */
static PyObject *py_step_sleep_counts(PyObject *self, PyObject *const *args, Py_ssize_t nargs) {
  (void)self;
  ARGS(1, "step");
  cc_step *s = cc_py_step_of(args[0]);
  if (s == NULL) return NULL;
  cc_step_sleep_counts c;
  cc_step_sleep_get_counts(s, &c);
  return Py_BuildValue("(nnnnn)", (Py_ssize_t)c.asked, (Py_ssize_t)c.reused, (Py_ssize_t)c.islands,
                       (Py_ssize_t)c.islands_asleep, (Py_ssize_t)c.bodies_asleep);
}

PyMethodDef cc_py_step_sleep_methods[] = {
    FAST(step_set_sleep, "step_set_sleep(step, (enabled, v_sleep, w_sleep, t_sleep, eps_p, eps_R))"),
    FAST(step_sleep_reset, "step_sleep_reset(step): every body awake, no answer kept"),
    FAST(step_sleep_wake, "step_sleep_wake(step, bodies): their islands are asked at the next step"),
    FAST(step_sleep_plan, "step_sleep_plan(step, w_WB, v_WB, ask) -> the candidate rows to ask (split step)"),
    FAST(step_sleep_counts, "step_sleep_counts(step) -> (asked, reused, islands, islands_asleep, bodies_asleep)"),
    {NULL, NULL, 0, NULL}};
