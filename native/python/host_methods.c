/* host_methods.c: body state from Drake's and MuJoCo's arrays and wrenches back to MuJoCo
 * (container_contact_step.h's host helpers) through CPython, joined into
 * learned_contact._native by module.c (step_bindings.h: what they take). */
#include "step_bindings.h" /* first: Python.h before the standard headers */

/* bodies_from_drake(x, q_start, v_start, fixed_p, fixed_R, free, p, R, w, v) */
static PyObject *py_bodies_from_drake(PyObject *self, PyObject *const *args, Py_ssize_t nargs) {
  (void)self;
  ARGS(10, "x, q_start, v_start, fixed_p, fixed_R, free, p, R, w, v");
  buffers b = {.n = 0};
  Py_ssize_t nx, m;
  void *x, *qs, *vs, *fp, *fR, *fr, *p, *R, *w, *v;
  PyObject *result = NULL;
  if (cc_py_take(&b, args[5], "free", 'b', -1, 0, 0, &fr, &m) < 0 || cc_py_take(&b, args[0], "x", 'd', -1, 0, 0, &x, &nx) < 0 ||
      cc_py_take(&b, args[1], "q_start", 'q', m, 0, 0, &qs, NULL) < 0 ||
      cc_py_take(&b, args[2], "v_start", 'q', m, 0, 0, &vs, NULL) < 0 ||
      cc_py_take(&b, args[3], "fixed_p", 'd', 3 * m, 0, 0, &fp, NULL) < 0 ||
      cc_py_take(&b, args[4], "fixed_R", 'd', 9 * m, 0, 0, &fR, NULL) < 0 || cc_py_take(&b, args[6], "p", 'd', 3 * m, 1, 0, &p, NULL) < 0 ||
      cc_py_take(&b, args[7], "R", 'd', 9 * m, 1, 0, &R, NULL) < 0 || cc_py_take(&b, args[8], "w", 'd', 3 * m, 1, 0, &w, NULL) < 0 ||
      cc_py_take(&b, args[9], "v", 'd', 3 * m, 1, 0, &v, NULL) < 0)
    goto done;
  for (Py_ssize_t i = 0; i < m; ++i) {
    if (!((const uint8_t *)fr)[i]) continue;
    int64_t q0 = ((const int64_t *)qs)[i], v0 = ((const int64_t *)vs)[i];
    if (q0 < 0 || q0 + 7 > nx || v0 < 0 || v0 + 6 > nx) {
      PyErr_Format(PyExc_IndexError, "bodies_from_drake: body %zd's q_start %lld / v_start %lld outside x (%zd)", i,
                   (long long)q0, (long long)v0, nx);
      goto done;
    }
  }
  cc_step_bodies_from_drake((size_t)m, x, qs, vs, fp, fR, fr, p, R, w, v);
  result = Py_None;
  Py_INCREF(result);
done:
  cc_py_release(&b);
  return result;
}

/* bodies_from_mujoco(xpos, xmat, qvel, body, dof, free, p, R, w, v) */
static PyObject *py_bodies_from_mujoco(PyObject *self, PyObject *const *args, Py_ssize_t nargs) {
  (void)self;
  ARGS(10, "xpos, xmat, qvel, body, dof, free, p, R, w, v");
  buffers b = {.n = 0};
  Py_ssize_t nb3, nv, m;
  void *xpos, *xmat, *qvel, *body, *dof, *fr, *p, *R, *w, *v;
  PyObject *result = NULL;
  if (cc_py_take(&b, args[5], "free", 'b', -1, 0, 0, &fr, &m) < 0 ||
      cc_py_take(&b, args[0], "xpos", 'd', -1, 0, 0, &xpos, &nb3) < 0 ||
      cc_py_take(&b, args[1], "xmat", 'd', 3 * nb3, 0, 0, &xmat, NULL) < 0 ||
      cc_py_take(&b, args[2], "qvel", 'd', -1, 0, 0, &qvel, &nv) < 0 || cc_py_take(&b, args[3], "body", 'q', m, 0, 0, &body, NULL) < 0 ||
      cc_py_take(&b, args[4], "dof", 'q', m, 0, 0, &dof, NULL) < 0 || cc_py_take(&b, args[6], "p", 'd', 3 * m, 1, 0, &p, NULL) < 0 ||
      cc_py_take(&b, args[7], "R", 'd', 9 * m, 1, 0, &R, NULL) < 0 || cc_py_take(&b, args[8], "w", 'd', 3 * m, 1, 0, &w, NULL) < 0 ||
      cc_py_take(&b, args[9], "v", 'd', 3 * m, 1, 0, &v, NULL) < 0)
    goto done;
  for (Py_ssize_t i = 0; i < m; ++i) {
    int64_t id = ((const int64_t *)body)[i], d = ((const int64_t *)dof)[i];
    if (id < 0 || 3 * id + 3 > nb3 || (((const uint8_t *)fr)[i] && (d < 0 || d + 6 > nv))) {
      PyErr_Format(PyExc_IndexError, "bodies_from_mujoco: body %zd's id %lld / dof %lld outside the model", i,
                   (long long)id, (long long)d);
      goto done;
    }
  }
  cc_step_bodies_from_mujoco((size_t)m, xpos, xmat, qvel, body, dof, fr, p, R, w, v);
  result = Py_None;
  Py_INCREF(result);
done:
  cc_py_release(&b);
  return result;
}

/* wrench_to_mujoco(wrench (m, 6), body, free, xpos, xipos, xfrc_applied out) */
static PyObject *py_wrench_to_mujoco(PyObject *self, PyObject *const *args, Py_ssize_t nargs) {
  (void)self;
  ARGS(6, "wrench_W, body, free, xpos, xipos, xfrc_applied");
  buffers b = {.n = 0};
  Py_ssize_t m, nb3;
  void *out, *body, *fr, *xpos, *xipos, *xfrc;
  PyObject *result = NULL;
  if (cc_py_take(&b, args[2], "free", 'b', -1, 0, 0, &fr, &m) < 0 ||
      cc_py_take(&b, args[0], "wrench_W", 'd', 6 * m, 0, 0, &out, NULL) < 0 ||
      cc_py_take(&b, args[1], "body", 'q', m, 0, 0, &body, NULL) < 0 ||
      cc_py_take(&b, args[3], "xpos", 'd', -1, 0, 0, &xpos, &nb3) < 0 ||
      cc_py_take(&b, args[4], "xipos", 'd', nb3, 0, 0, &xipos, NULL) < 0 ||
      cc_py_take(&b, args[5], "xfrc_applied", 'd', 2 * nb3, 1, 0, &xfrc, NULL) < 0)
    goto done;
  for (Py_ssize_t i = 0; i < m; ++i) {
    int64_t id = ((const int64_t *)body)[i];
    if (id < 0 || 3 * id + 3 > nb3) {
      PyErr_Format(PyExc_IndexError, "wrench_to_mujoco: body %zd's id %lld outside the model", i, (long long)id);
      goto done;
    }
  }
  cc_step_wrench_to_mujoco((size_t)m, (size_t)(nb3 / 3), out, body, fr, xpos, xipos, xfrc);
  result = Py_None;
  Py_INCREF(result);
done:
  cc_py_release(&b);
  return result;
}

PyMethodDef cc_py_host_methods[] = {
    FAST(bodies_from_drake, "bodies_from_drake(x, q_start, v_start, fixed_p, fixed_R, free, p, R, w, v)"),
    FAST(bodies_from_mujoco, "bodies_from_mujoco(xpos, xmat, qvel, body, dof, free, p, R, w, v)"),
    FAST(wrench_to_mujoco, "wrench_to_mujoco(wrench_W, body, free, xpos, xipos, xfrc_applied)"),
    {NULL, NULL, 0, NULL}};
