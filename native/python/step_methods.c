/* step_methods.c: the contact step's CPython bindings (container_contact_step.h), joined into
 * learned_contact._native by module.c: create, parameters, candidates, the force law, the fused
 * step, the held state (step_bindings.h: what they take; sleeping in step_sleep_methods.c, the
 * hosts' arrays in host_methods.c). The testbed's one contact step
 * (testbed/effects/learned_dynamics/step.py) is their only intended caller. */
#include "step_bindings.h" /* first: Python.h before the standard headers */

#include <string.h>

static void step_destructor(PyObject *capsule) {
  cc_step *s = (cc_step *)PyCapsule_GetPointer(capsule, STEP_CAPSULE);
  if (s != NULL) cc_step_free(s);
}

/* params (11 numbers): margin, h, dissipation, mu, stick_hw, stick_zeta, slip, stiction,
 * torsional, grid, sweeps; kappa (T, T) float64 */
static int read_params(buffers *b, PyObject *kappa, PyObject *tuple, cc_step_params *q) {
  memset(q, 0, sizeof *q);
  PyObject *seq = PySequence_Fast(tuple, "params: expected a sequence of 11 numbers");
  if (seq == NULL) return -1;
  if (PySequence_Fast_GET_SIZE(seq) != 11) {
    Py_DECREF(seq);
    PyErr_SetString(PyExc_ValueError, "params: expected 11 numbers (margin, h, dissipation, mu, stick_hw, "
                                      "stick_zeta, slip, stiction, torsional, grid, sweeps)");
    return -1;
  }
  double x[11];
  for (int i = 0; i < 11; ++i) {
    x[i] = PyFloat_AsDouble(PySequence_Fast_GET_ITEM(seq, i));
    if (x[i] == -1.0 && PyErr_Occurred()) {
      Py_DECREF(seq);
      return -1;
    }
  }
  Py_DECREF(seq);
  q->margin = x[0];
  q->h = x[1];
  q->dissipation = x[2];
  q->mu = x[3];
  q->stick_hw = x[4];
  q->stick_zeta = x[5];
  q->slip = x[6];
  q->stiction = x[7];
  q->torsional = x[8] != 0.0;
  q->grid = (int)x[9];
  q->sweeps = (int)x[10];
  void *k;
  Py_ssize_t n;
  if (cc_py_take(b, kappa, "kappa", 'd', -1, 0, 0, &k, &n) < 0) return -1;
  int t = 0;
  while ((Py_ssize_t)(t + 1) * (t + 1) <= n) ++t;
  if (t < 1 || (Py_ssize_t)t * t != n) {
    PyErr_Format(PyExc_ValueError, "kappa: expected a square (T, T) table, got %zd elements", n);
    return -1;
  }
  q->n_types = t;
  q->kappa = k;
  return 0;
}

/* step_new(size (m, 3), free (m), mass (m), I_Bo (m, 3, 3), type_index (m), kappa (T, T), params) -> step */
static PyObject *py_step_new(PyObject *self, PyObject *const *args, Py_ssize_t nargs) {
  (void)self;
  ARGS(7, "size, free, mass, I_Bo, type_index, kappa, params");
  buffers b = {.n = 0};
  cc_step_scene scene;
  cc_step_params q;
  Py_ssize_t m3;
  void *size, *free_, *mass, *I, *type;
  PyObject *result = NULL;
  if (cc_py_take(&b, args[0], "size", 'd', -1, 0, 0, &size, &m3) < 0) goto done;
  if (m3 % 3 != 0) {
    PyErr_SetString(PyExc_ValueError, "size: expected (m, 3)");
    goto done;
  }
  Py_ssize_t m = m3 / 3;
  if (cc_py_take(&b, args[1], "free", 'b', m, 0, 0, &free_, NULL) < 0 || cc_py_take(&b, args[2], "mass", 'd', m, 0, 0, &mass, NULL) < 0 ||
      cc_py_take(&b, args[3], "I_Bo", 'd', 9 * m, 0, 0, &I, NULL) < 0 ||
      cc_py_take(&b, args[4], "type_index", 'q', m, 0, 0, &type, NULL) < 0 || read_params(&b, args[5], args[6], &q) < 0)
    goto done;
  scene.n_bodies = (size_t)m;
  scene.size = size;
  scene.free = free_;
  scene.mass = mass;
  scene.I_Bo = I;
  scene.type_index = type;
  int status;
  cc_step *s = cc_step_create(&scene, &q, &status);
  if (s == NULL) {
    cc_py_status_error(status, "step_new (sizes > 0, free bodies' mass > 0, h > 0, slip > 0, stiction in [0, 1], "
                         "grid >= 0, sweeps >= 1, kappa >= 0, type_index within kappa)");
    goto done;
  }
  result = PyCapsule_New(s, STEP_CAPSULE, step_destructor);
  if (result == NULL) cc_step_free(s);
done:
  cc_py_release(&b);
  return result;
}

static PyObject *py_step_set_params(PyObject *self, PyObject *const *args, Py_ssize_t nargs) {
  (void)self;
  ARGS(3, "step, kappa, params");
  cc_step *s = cc_py_step_of(args[0]);
  if (s == NULL) return NULL;
  buffers b = {.n = 0};
  cc_step_params q;
  PyObject *result = NULL;
  if (read_params(&b, args[1], args[2], &q) == 0) {
    int status = cc_step_set_params(s, &q);
    if (status == CC_OK) {
      result = Py_None;
      Py_INCREF(result);
    } else {
      cc_py_status_error(status, "step_set_params");
    }
  }
  cc_py_release(&b);
  return result;
}

static PyObject *py_step_forget(PyObject *self, PyObject *const *args, Py_ssize_t nargs) {
  (void)self;
  ARGS(1, "step");
  cc_step *s = cc_py_step_of(args[0]);
  if (s == NULL) return NULL;
  cc_step_forget(s);
  Py_RETURN_NONE;
}

/* step_candidates(step, p (m, 3), R (m, 3, 3)) -> k */
static PyObject *py_step_candidates(PyObject *self, PyObject *const *args, Py_ssize_t nargs) {
  (void)self;
  ARGS(3, "step, p_WB, R_WB");
  cc_step *s = cc_py_step_of(args[0]);
  if (s == NULL) return NULL;
  Py_ssize_t m = n_bodies(s);
  buffers b = {.n = 0};
  void *p, *R;
  size_t k = 0;
  PyObject *result = NULL;
  if (cc_py_take(&b, args[1], "p_WB", 'd', 3 * m, 0, 0, &p, NULL) == 0 &&
      cc_py_take(&b, args[2], "R_WB", 'd', 9 * m, 0, 0, &R, NULL) == 0) {
    int status = cc_step_candidates(s, p, R, &k);
    if (status == CC_OK)
      result = PyLong_FromSize_t(k);
    else
      cc_py_status_error(status, "step_candidates");
  }
  cc_py_release(&b);
  return result;
}

/* step_read(step, ia, ib, p_AB, R_AB, size_A, size_B, point_A, normal_A, fn, f_W, p_W, n_W, area):
 * copies the latest step's pair arrays (k rows each) into those given (None: skipped) */
static PyObject *py_step_read(PyObject *self, PyObject *const *args, Py_ssize_t nargs) {
  (void)self;
  ARGS(14, "step, ia, ib, p_AB, R_AB, size_A, size_B, point_A, normal_A, fn, f_W, p_W, n_W, area");
  cc_step *s = cc_py_step_of(args[0]);
  if (s == NULL) return NULL;
  cc_step_pairs v;
  cc_step_view(s, &v);
  Py_ssize_t k = (Py_ssize_t)v.n;
  static const char *names[13] = {"ia", "ib", "p_AB", "R_AB", "size_A", "size_B", "point_A",
                                  "normal_A", "fn", "f_W", "p_W", "n_W", "area"};
  static const int cols[13] = {1, 1, 3, 9, 3, 3, 3, 3, 1, 3, 3, 3, 1};
  const void *src[13] = {v.ia, v.ib, v.p_AB, v.R_AB, v.size_A, v.size_B, v.point_A, v.normal_A, v.fn, v.f_W, v.p_W, v.n_W, v.area};
  buffers b = {.n = 0};
  PyObject *result = NULL;
  for (int i = 0; i < 13; ++i) {
    void *dst;
    if (cc_py_take(&b, args[1 + i], names[i], i < 2 ? 'q' : 'd', cols[i] * k, 1, 1, &dst, NULL) < 0) goto done;
    if (dst != NULL && k > 0) memcpy(dst, src[i], (size_t)(cols[i] * k) * 8);
    cc_py_release(&b);
  }
  result = Py_None;
  Py_INCREF(result);
done:
  cc_py_release(&b);
  return result;
}

/* step_force_law(step, w (m, 3), v (m, 3), point_A (k, 3), normal_A (k, 3), wrench (m, 6) out[, elastic (k, 3)]):
 * with elastic, the caller's own (F [N], dF/dd [N/m], area [m^2]) per pair (cc_step_force_law_given) */
static PyObject *py_step_force_law(PyObject *self, PyObject *const *args, Py_ssize_t nargs) {
  (void)self;
  if (nargs != 6 && nargs != 7)
    return PyErr_Format(PyExc_TypeError, "step_force_law expects 6 or 7 arguments (step, w_WB, v_WB, point_A, "
                        "normal_A, wrench_W[, elastic]), got %zd", nargs);
  cc_step *s = cc_py_step_of(args[0]);
  if (s == NULL) return NULL;
  Py_ssize_t m = n_bodies(s);
  cc_step_pairs view;
  cc_step_view(s, &view);
  Py_ssize_t k = (Py_ssize_t)view.n;
  buffers b = {.n = 0};
  void *w, *v, *pA, *nA, *out, *given = NULL;
  PyObject *result = NULL;
  if (cc_py_take(&b, args[1], "w_WB", 'd', 3 * m, 0, 0, &w, NULL) == 0 &&
      cc_py_take(&b, args[2], "v_WB", 'd', 3 * m, 0, 0, &v, NULL) == 0 &&
      cc_py_take(&b, args[3], "point_A", 'd', 3 * k, 0, 0, &pA, NULL) == 0 &&
      cc_py_take(&b, args[4], "normal_A", 'd', 3 * k, 0, 0, &nA, NULL) == 0 &&
      cc_py_take(&b, args[5], "wrench_W", 'd', 6 * m, 1, 0, &out, NULL) == 0 &&
      (nargs == 6 || cc_py_take(&b, args[6], "elastic", 'd', 3 * k, 0, 0, &given, NULL) == 0)) {
    int status = nargs == 6 ? cc_step_force_law(s, w, v, pA, nA, out) : cc_step_force_law_given(s, w, v, pA, nA, given, out);
    if (status == CC_OK) result = Py_NewRef(Py_None);
    else cc_py_status_error(status, "step_force_law (run step_candidates first, once per law; elastic values finite)");
  }
  cc_py_release(&b);
  return result;
}

/* The cc_model inside a learned_contact._native.Model (defined in model_type.c, which
 * owns the type's layout); a TypeError and NULL for anything else. */
extern const cc_model *cc_py_model_of(PyObject *obj);

/* step_contact(step, model, p, R, w, v, wrench out, seconds (3) out or None) -> k: the fused
 * step (cc_contact_step_timed); (status, row, k) when the predictor refused a candidate's pose */
static PyObject *py_step_contact(PyObject *self, PyObject *const *args, Py_ssize_t nargs) {
  (void)self;
  ARGS(8, "step, model, p_WB, R_WB, w_WB, v_WB, wrench_W, seconds");
  cc_step *s = cc_py_step_of(args[0]);
  if (s == NULL) return NULL;
  const cc_model *model = cc_py_model_of(args[1]);
  if (model == NULL) return NULL;
  Py_ssize_t m = n_bodies(s);
  buffers b = {.n = 0};
  void *p, *R, *w, *v, *out, *seconds;
  PyObject *result = NULL;
  if (cc_py_take(&b, args[7], "seconds", 'd', 3, 1, 1, &seconds, NULL) == 0 &&
      cc_py_take(&b, args[2], "p_WB", 'd', 3 * m, 0, 0, &p, NULL) == 0 &&
      cc_py_take(&b, args[3], "R_WB", 'd', 9 * m, 0, 0, &R, NULL) == 0 &&
      cc_py_take(&b, args[4], "w_WB", 'd', 3 * m, 0, 0, &w, NULL) == 0 &&
      cc_py_take(&b, args[5], "v_WB", 'd', 3 * m, 0, 0, &v, NULL) == 0 &&
      cc_py_take(&b, args[6], "wrench_W", 'd', 6 * m, 1, 0, &out, NULL) == 0) {
    size_t bad = 0;
    int status = cc_contact_step_timed(model, s, p, R, w, v, out, &bad, seconds);
    if (status == CC_OK) {
      cc_step_pairs view;
      cc_step_view(s, &view);
      result = PyLong_FromSize_t(view.n);
    } else if (status == CC_BAD_ARGUMENT || status == CC_STEP_NO_MEMORY) {
      cc_py_status_error(status, "step_contact");
    } else { /* the predictor refused a pose: (status, candidate row, k) for the caller to word
                (step_read still reads the k candidates) */
      cc_step_pairs view;
      cc_step_view(s, &view);
      result = Py_BuildValue("(inn)", status, (Py_ssize_t)bad, (Py_ssize_t)view.n);
    }
  }
  cc_py_release(&b);
  return result;
}

/* step_counts(step) -> (n_broad, k): the latest broad phase's candidates, the pairs kept */
static PyObject *py_step_counts(PyObject *self, PyObject *const *args, Py_ssize_t nargs) {
  (void)self;
  ARGS(1, "step");
  cc_step *s = cc_py_step_of(args[0]);
  if (s == NULL) return NULL;
  cc_step_pairs view;
  cc_step_view(s, &view);
  return Py_BuildValue("(nn)", (Py_ssize_t)view.n_broad, (Py_ssize_t)view.n);
}

/* step_elastic(p_AB (3), R_AB (3, 3), hA (3), hB (3), kappa, grid) -> (F [N], area [m^2], k_n [N/m]) */
static PyObject *py_step_elastic(PyObject *self, PyObject *const *args, Py_ssize_t nargs) {
  (void)self;
  ARGS(6, "p_AB, R_AB, hA, hB, kappa, grid");
  buffers b = {.n = 0};
  void *p, *R, *hA, *hB;
  PyObject *result = NULL;
  double kappa = PyFloat_AsDouble(args[4]);
  long grid = PyLong_AsLong(args[5]);
  if (PyErr_Occurred()) return NULL;
  if (cc_py_take(&b, args[0], "p_AB", 'd', 3, 0, 0, &p, NULL) == 0 && cc_py_take(&b, args[1], "R_AB", 'd', 9, 0, 0, &R, NULL) == 0 &&
      cc_py_take(&b, args[2], "hA", 'd', 3, 0, 0, &hA, NULL) == 0 && cc_py_take(&b, args[3], "hB", 'd', 3, 0, 0, &hB, NULL) == 0) {
    double out[3];
    cc_step_elastic(p, R, hA, hB, kappa, (int)grid, out);
    result = Py_BuildValue("(ddd)", out[0], out[1], out[2]);
  }
  cc_py_release(&b);
  return result;
}

/* static_contact(p_AB (n, 3), R_AB (n, 3, 3), hA (n, 3), hB (n, 3), modulus_A, modulus_B, out) -> None:
 * out (n, 26): per pose one row of cc_static_contact: force (3), moment (3), cop (3), first_moment (3),
 * pressure_integral, area, dforce_ddepth (9), stiffness, pieces (as a double), 0; out of 35 n doubles:
 * those rows, then the damping inertias (n, 9) */
static PyObject *py_static_contact(PyObject *self, PyObject *const *args, Py_ssize_t nargs) {
  (void)self;
  ARGS(7, "p_AB, R_AB, hA, hB, modulus_A, modulus_B, out");
  buffers b = {.n = 0};
  void *p, *R, *hA, *hB, *out;
  Py_ssize_t n3 = 0, n9, nA, nB, nout;
  PyObject *result = NULL;
  double EA = PyFloat_AsDouble(args[4]), EB = PyFloat_AsDouble(args[5]);
  if (PyErr_Occurred()) return NULL;
  if (cc_py_take(&b, args[0], "p_AB", 'd', -1, 0, 0, &p, &n3) == 0 && cc_py_take(&b, args[1], "R_AB", 'd', -1, 0, 0, &R, &n9) == 0 &&
      cc_py_take(&b, args[2], "hA", 'd', -1, 0, 0, &hA, &nA) == 0 && cc_py_take(&b, args[3], "hB", 'd', -1, 0, 0, &hB, &nB) == 0 &&
      cc_py_take(&b, args[6], "out", 'd', -1, 1, 0, &out, &nout) == 0) {
    Py_ssize_t n = n3 / 3;
    if (n3 != 3 * n || n9 != 9 * n || nA != 3 * n || nB != 3 * n || (nout != 26 * n && nout != 35 * n)) {
      PyErr_SetString(PyExc_ValueError, "static_contact: p_AB (n, 3), R_AB (n, 3, 3), hA, hB (n, 3), out (n, 26) or (n, 35)");
    } else {
      for (Py_ssize_t i = 0; i < n; ++i) {
        cc_field_contact c;
        cc_static_contact((const double *)p + 3 * i, (const double *)R + 9 * i, (const double *)hA + 3 * i,
                          (const double *)hB + 3 * i, EA, EB, &c);
        double *o = (double *)out + 26 * i;
        memcpy(o, c.force, 3 * sizeof(double));
        memcpy(o + 3, c.moment, 3 * sizeof(double));
        memcpy(o + 6, c.cop, 3 * sizeof(double));
        memcpy(o + 9, c.first_moment, 3 * sizeof(double));
        o[12] = c.pressure_integral;
        o[13] = c.area;
        memcpy(o + 14, c.dforce_ddepth, 9 * sizeof(double));
        o[23] = c.stiffness;
        o[24] = (double)c.pieces;
        o[25] = 0.0;
        if (nout == 35 * n) memcpy((double *)out + 26 * n + 9 * i, c.damping_inertia, 9 * sizeof(double));
      }
      Py_INCREF(Py_None);
      result = Py_None;
    }
  }
  cc_py_release(&b);
  return result;
}

static PyObject *py_step_held_count(PyObject *self, PyObject *const *args, Py_ssize_t nargs) {
  (void)self;
  ARGS(1, "step");
  cc_step *s = cc_py_step_of(args[0]);
  if (s == NULL) return NULL;
  return PyLong_FromSize_t(cc_step_held_count(s));
}

/* step_held_get(step, keys (s) out, rows (s, 8) out, history (m, 12) out) */
static PyObject *py_step_held_get(PyObject *self, PyObject *const *args, Py_ssize_t nargs) {
  (void)self;
  ARGS(4, "step, keys, rows, history");
  cc_step *s = cc_py_step_of(args[0]);
  if (s == NULL) return NULL;
  Py_ssize_t n = (Py_ssize_t)cc_step_held_count(s), m = n_bodies(s);
  buffers b = {.n = 0};
  void *keys, *rows, *history;
  PyObject *result = NULL;
  if (cc_py_take(&b, args[1], "keys", 'q', n, 1, 0, &keys, NULL) == 0 &&
      cc_py_take(&b, args[2], "rows", 'd', CC_STEP_ROW * n, 1, 0, &rows, NULL) == 0 &&
      cc_py_take(&b, args[3], "history", 'd', CC_STEP_BODY * m, 1, 0, &history, NULL) == 0) {
    cc_step_held_get(s, keys, rows, history);
    result = Py_None;
    Py_INCREF(result);
  }
  cc_py_release(&b);
  return result;
}

/* step_held_set(step, keys (s), rows (s, 8), history (m, 12) or None) */
static PyObject *py_step_held_set(PyObject *self, PyObject *const *args, Py_ssize_t nargs) {
  (void)self;
  ARGS(4, "step, keys, rows, history");
  cc_step *s = cc_py_step_of(args[0]);
  if (s == NULL) return NULL;
  Py_ssize_t m = n_bodies(s), n;
  buffers b = {.n = 0};
  void *keys, *rows, *history;
  PyObject *result = NULL;
  if (cc_py_take(&b, args[1], "keys", 'q', -1, 0, 0, &keys, &n) == 0 &&
      cc_py_take(&b, args[2], "rows", 'd', CC_STEP_ROW * n, 0, 0, &rows, NULL) == 0 &&
      cc_py_take(&b, args[3], "history", 'd', CC_STEP_BODY * m, 0, 1, &history, NULL) == 0) {
    int status = cc_step_held_set(s, (size_t)n, keys, rows, history);
    if (status == CC_OK) {
      result = Py_None;
      Py_INCREF(result);
    } else {
      cc_py_status_error(status, "step_held_set (keys ascending, each ia * m + ib < m * m)");
    }
  }
  cc_py_release(&b);
  return result;
}

PyMethodDef cc_py_step_methods[] = {
    FAST(step_new, "step_new(size, free, mass, I_Bo, type_index, kappa, params) -> step (container_contact_step.h)"),
    FAST(step_set_params, "step_set_params(step, kappa, params)"),
    FAST(step_forget, "step_forget(step): no pair held, no body history"),
    FAST(step_candidates, "step_candidates(step, p_WB, R_WB) -> k candidate pairs"),
    FAST(step_read, "step_read(step, ia, ib, p_AB, R_AB, size_A, size_B, point_A, normal_A, fn, f_W, p_W, n_W, area)"),
    FAST(step_force_law, "step_force_law(step, w_WB, v_WB, point_A, normal_A, wrench_W[, elastic])"),
    FAST(step_contact, "step_contact(step, model, p_WB, R_WB, w_WB, v_WB, wrench_W, seconds) -> k, or (status, row, k)"),
    FAST(step_counts, "step_counts(step) -> (n_broad, k): the broad phase's candidates, the pairs kept"),
    FAST(step_elastic, "step_elastic(p_AB, R_AB, hA, hB, kappa, grid) -> (F, area, k_n) of one pose"),
    FAST(static_contact, "static_contact(p_AB, R_AB, hA, hB, modulus_A, modulus_B, out (n, 26)): exact field contact per pose"),
    FAST(step_held_count, "step_held_count(step) -> s pairs held"),
    FAST(step_held_get, "step_held_get(step, keys, rows, history)"),
    FAST(step_held_set, "step_held_set(step, keys, rows, history or None)"),
    {NULL, NULL, 0, NULL}};
