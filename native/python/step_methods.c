/* step_methods.c: the contact step's CPython bindings (container_contact_step.h), joined into
 * learned_contact._native by module.c. The testbed's one contact step
 * (testbed/effects/learned_dynamics/step.py) is their only intended caller.
 *
 * Every array goes through the buffer protocol (numpy arrays, MuJoCo's data arrays): C-
 * contiguous, float64 ('d'), int64 ('q' / 'l' of 8 bytes) or bool / uint8 (1 byte), with
 * exactly the element count the call expects; outputs are written in place. A step is a
 * capsule owning a cc_step; one thread at a time per step (the GIL is held throughout). */
#define PY_SSIZE_T_CLEAN
#include <Python.h>
#include <string.h>

#include "container_contact_step.h"

#define STEP_CAPSULE "learned_contact._native.step"
#define MAX_BUFFERS 16

typedef struct {
  Py_buffer view[MAX_BUFFERS];
  int n;
} buffers;

static void release(buffers *b) {
  for (int i = 0; i < b->n; ++i) PyBuffer_Release(&b->view[i]);
  b->n = 0;
}

static int format_is(const Py_buffer *v, char kind) {
  const char *f = v->format == NULL ? "B" : v->format;
  if (*f == '<' || *f == '=' || *f == '@') ++f;
  if (f[0] == '\0' || f[1] != '\0') return 0;
  switch (kind) {
    case 'd': return f[0] == 'd' && v->itemsize == 8;
    case 'q': return (f[0] == 'q' || f[0] == 'l') && v->itemsize == 8;
    case 'b': return (f[0] == '?' || f[0] == 'B' || f[0] == 'b') && v->itemsize == 1;
  }
  return 0;
}

static const char *kind_name(char kind) {
  return kind == 'd' ? "float64" : kind == 'q' ? "int64" : "bool or uint8";
}

/* *out = the data of obj (a C-contiguous buffer of kind with `count` elements; count < 0:
 * any, its count written to *got). None is allowed when *out may stay NULL (nullable). */
static int take(buffers *b, PyObject *obj, const char *name, char kind, Py_ssize_t count, int writable, int nullable,
                void **out, Py_ssize_t *got) {
  *out = NULL;
  if (obj == Py_None && nullable) return 0;
  if (b->n == MAX_BUFFERS) {
    PyErr_SetString(PyExc_RuntimeError, "learned_contact._native: too many buffers in one call");
    return -1;
  }
  Py_buffer *v = &b->view[b->n];
  if (PyObject_GetBuffer(obj, v, PyBUF_C_CONTIGUOUS | PyBUF_FORMAT | (writable ? PyBUF_WRITABLE : 0)) < 0) {
    PyErr_Format(PyExc_TypeError, "%s: expected a C-contiguous %s%s array", name, writable ? "writable " : "",
                 kind_name(kind));
    return -1;
  }
  ++b->n;
  if (!format_is(v, kind)) {
    PyErr_Format(PyExc_TypeError, "%s: expected %s, got format '%s'", name, kind_name(kind),
                 v->format == NULL ? "B" : v->format);
    return -1;
  }
  Py_ssize_t n = v->len / v->itemsize;
  if (count >= 0 && n != count) {
    PyErr_Format(PyExc_ValueError, "%s: expected %zd elements, got %zd", name, count, n);
    return -1;
  }
  if (got != NULL) *got = n;
  *out = v->buf;
  return 0;
}

static cc_step *step_of(PyObject *capsule) {
  return (cc_step *)PyCapsule_GetPointer(capsule, STEP_CAPSULE);
}

static void step_destructor(PyObject *capsule) {
  cc_step *s = (cc_step *)PyCapsule_GetPointer(capsule, STEP_CAPSULE);
  if (s != NULL) cc_step_free(s);
}

static int status_error(int status, const char *what) {
  if (status == CC_STEP_NO_MEMORY) {
    PyErr_NoMemory();
  } else {
    PyErr_Format(PyExc_ValueError, "%s: status %d (%s)", what, status,
                 status == CC_BAD_ARGUMENT ? "a bad argument" : "see container_contact.h's enum cc_status");
  }
  return -1;
}

#define ARGS(n, sig)                                                                           \
  if (nargs != (n)) {                                                                          \
    PyErr_Format(PyExc_TypeError, "%s expects %d arguments (%s), got %zd", __func__ + 3, (n), sig, nargs); \
    return NULL;                                                                               \
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
  if (take(b, kappa, "kappa", 'd', -1, 0, 0, &k, &n) < 0) return -1;
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
  if (take(&b, args[0], "size", 'd', -1, 0, 0, &size, &m3) < 0) goto done;
  if (m3 % 3 != 0) {
    PyErr_SetString(PyExc_ValueError, "size: expected (m, 3)");
    goto done;
  }
  Py_ssize_t m = m3 / 3;
  if (take(&b, args[1], "free", 'b', m, 0, 0, &free_, NULL) < 0 || take(&b, args[2], "mass", 'd', m, 0, 0, &mass, NULL) < 0 ||
      take(&b, args[3], "I_Bo", 'd', 9 * m, 0, 0, &I, NULL) < 0 ||
      take(&b, args[4], "type_index", 'q', m, 0, 0, &type, NULL) < 0 || read_params(&b, args[5], args[6], &q) < 0)
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
    status_error(status, "step_new (sizes > 0, free bodies' mass > 0, h > 0, slip > 0, stiction in [0, 1], "
                         "grid and sweeps >= 1, kappa >= 0, type_index within kappa)");
    goto done;
  }
  result = PyCapsule_New(s, STEP_CAPSULE, step_destructor);
  if (result == NULL) cc_step_free(s);
done:
  release(&b);
  return result;
}

static PyObject *py_step_set_params(PyObject *self, PyObject *const *args, Py_ssize_t nargs) {
  (void)self;
  ARGS(3, "step, kappa, params");
  cc_step *s = step_of(args[0]);
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
      status_error(status, "step_set_params");
    }
  }
  release(&b);
  return result;
}

static PyObject *py_step_forget(PyObject *self, PyObject *const *args, Py_ssize_t nargs) {
  (void)self;
  ARGS(1, "step");
  cc_step *s = step_of(args[0]);
  if (s == NULL) return NULL;
  cc_step_forget(s);
  Py_RETURN_NONE;
}

static Py_ssize_t n_bodies(const cc_step *s) { return (Py_ssize_t)cc_step_n_bodies(s); }

/* step_candidates(step, p (m, 3), R (m, 3, 3)) -> k */
static PyObject *py_step_candidates(PyObject *self, PyObject *const *args, Py_ssize_t nargs) {
  (void)self;
  ARGS(3, "step, p_WB, R_WB");
  cc_step *s = step_of(args[0]);
  if (s == NULL) return NULL;
  Py_ssize_t m = n_bodies(s);
  buffers b = {.n = 0};
  void *p, *R;
  size_t k = 0;
  PyObject *result = NULL;
  if (take(&b, args[1], "p_WB", 'd', 3 * m, 0, 0, &p, NULL) == 0 &&
      take(&b, args[2], "R_WB", 'd', 9 * m, 0, 0, &R, NULL) == 0) {
    int status = cc_step_candidates(s, p, R, &k);
    if (status == CC_OK)
      result = PyLong_FromSize_t(k);
    else
      status_error(status, "step_candidates");
  }
  release(&b);
  return result;
}

/* step_read(step, ia, ib, p_AB, R_AB, size_A, size_B, point_A, normal_A, fn, f_W, p_W, n_W, area):
 * copies the latest step's pair arrays (k rows each) into those given (None: skipped) */
static PyObject *py_step_read(PyObject *self, PyObject *const *args, Py_ssize_t nargs) {
  (void)self;
  ARGS(14, "step, ia, ib, p_AB, R_AB, size_A, size_B, point_A, normal_A, fn, f_W, p_W, n_W, area");
  cc_step *s = step_of(args[0]);
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
    if (take(&b, args[1 + i], names[i], i < 2 ? 'q' : 'd', cols[i] * k, 1, 1, &dst, NULL) < 0) goto done;
    if (dst != NULL && k > 0) memcpy(dst, src[i], (size_t)(cols[i] * k) * 8);
    release(&b);
  }
  result = Py_None;
  Py_INCREF(result);
done:
  release(&b);
  return result;
}

/* step_force_law(step, w (m, 3), v (m, 3), point_A (k, 3), normal_A (k, 3), wrench (m, 6) out) */
static PyObject *py_step_force_law(PyObject *self, PyObject *const *args, Py_ssize_t nargs) {
  (void)self;
  ARGS(6, "step, w_WB, v_WB, point_A, normal_A, wrench_W");
  cc_step *s = step_of(args[0]);
  if (s == NULL) return NULL;
  Py_ssize_t m = n_bodies(s);
  cc_step_pairs view;
  cc_step_view(s, &view);
  Py_ssize_t k = (Py_ssize_t)view.n;
  buffers b = {.n = 0};
  void *w, *v, *pA, *nA, *out;
  PyObject *result = NULL;
  if (take(&b, args[1], "w_WB", 'd', 3 * m, 0, 0, &w, NULL) == 0 &&
      take(&b, args[2], "v_WB", 'd', 3 * m, 0, 0, &v, NULL) == 0 &&
      take(&b, args[3], "point_A", 'd', 3 * k, 0, 0, &pA, NULL) == 0 &&
      take(&b, args[4], "normal_A", 'd', 3 * k, 0, 0, &nA, NULL) == 0 &&
      take(&b, args[5], "wrench_W", 'd', 6 * m, 1, 0, &out, NULL) == 0) {
    int status = cc_step_force_law(s, w, v, pA, nA, out);
    if (status == CC_OK) {
      result = Py_None;
      Py_INCREF(result);
    } else {
      status_error(status, "step_force_law (run step_candidates first, once per law)");
    }
  }
  release(&b);
  return result;
}

/* The cc_model inside a learned_contact._native.Model (defined in predict_methods.c, which
 * owns the type's layout); a TypeError and NULL for anything else. */
extern const cc_model *cc_py_model_of(PyObject *obj);

/* step_contact(step, model, p, R, w, v, wrench out, seconds (3) out or None) -> k: the fused
 * step (cc_contact_step_timed); (status, row, k) when the predictor refused a candidate's pose */
static PyObject *py_step_contact(PyObject *self, PyObject *const *args, Py_ssize_t nargs) {
  (void)self;
  ARGS(8, "step, model, p_WB, R_WB, w_WB, v_WB, wrench_W, seconds");
  cc_step *s = step_of(args[0]);
  if (s == NULL) return NULL;
  const cc_model *model = cc_py_model_of(args[1]);
  if (model == NULL) return NULL;
  Py_ssize_t m = n_bodies(s);
  buffers b = {.n = 0};
  void *p, *R, *w, *v, *out, *seconds;
  PyObject *result = NULL;
  if (take(&b, args[7], "seconds", 'd', 3, 1, 1, &seconds, NULL) == 0 &&
      take(&b, args[2], "p_WB", 'd', 3 * m, 0, 0, &p, NULL) == 0 &&
      take(&b, args[3], "R_WB", 'd', 9 * m, 0, 0, &R, NULL) == 0 &&
      take(&b, args[4], "w_WB", 'd', 3 * m, 0, 0, &w, NULL) == 0 &&
      take(&b, args[5], "v_WB", 'd', 3 * m, 0, 0, &v, NULL) == 0 &&
      take(&b, args[6], "wrench_W", 'd', 6 * m, 1, 0, &out, NULL) == 0) {
    size_t bad = 0;
    int status = cc_contact_step_timed(model, s, p, R, w, v, out, &bad, seconds);
    if (status == CC_OK) {
      cc_step_pairs view;
      cc_step_view(s, &view);
      result = PyLong_FromSize_t(view.n);
    } else if (status == CC_BAD_ARGUMENT || status == CC_STEP_NO_MEMORY) {
      status_error(status, "step_contact");
    } else { /* the predictor refused a pose: (status, candidate row, k) for the caller to word
                (step_read still reads the k candidates) */
      cc_step_pairs view;
      cc_step_view(s, &view);
      result = Py_BuildValue("(inn)", status, (Py_ssize_t)bad, (Py_ssize_t)view.n);
    }
  }
  release(&b);
  return result;
}

/* step_counts(step) -> (n_broad, k): the latest broad phase's candidates, the pairs kept */
static PyObject *py_step_counts(PyObject *self, PyObject *const *args, Py_ssize_t nargs) {
  (void)self;
  ARGS(1, "step");
  cc_step *s = step_of(args[0]);
  if (s == NULL) return NULL;
  cc_step_pairs view;
  cc_step_view(s, &view);
  return Py_BuildValue("(nn)", (Py_ssize_t)view.n_broad, (Py_ssize_t)view.n);
}

/* step_set_sleep(step, (enabled, v_sleep, w_sleep, t_sleep, eps_p, eps_R[, pair_reuse])) (cc_step_set_sleep) */
static PyObject *py_step_set_sleep(PyObject *self, PyObject *const *args, Py_ssize_t nargs) {
  (void)self;
  ARGS(2, "step, (enabled, v_sleep, w_sleep, t_sleep, eps_p, eps_R[, pair_reuse])");
  cc_step *s = step_of(args[0]);
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
    status_error(CC_BAD_ARGUMENT, "step_set_sleep (v_sleep, w_sleep, t_sleep, eps_p, eps_R finite >= 0)");
    return NULL;
  }
  Py_RETURN_NONE;
}

static PyObject *py_step_sleep_reset(PyObject *self, PyObject *const *args, Py_ssize_t nargs) {
  (void)self;
  ARGS(1, "step");
  cc_step *s = step_of(args[0]);
  if (s == NULL) return NULL;
  cc_step_sleep_reset(s);
  Py_RETURN_NONE;
}

/* step_sleep_wake(step, bodies (n) int64) */
static PyObject *py_step_sleep_wake(PyObject *self, PyObject *const *args, Py_ssize_t nargs) {
  (void)self;
  ARGS(2, "step, bodies");
  cc_step *s = step_of(args[0]);
  if (s == NULL) return NULL;
  buffers b = {.n = 0};
  void *bodies;
  Py_ssize_t n;
  if (take(&b, args[1], "bodies", 'q', -1, 0, 0, &bodies, &n) < 0) {
    release(&b);
    return NULL;
  }
  cc_step_sleep_wake(s, (size_t)n, bodies);
  release(&b);
  Py_RETURN_NONE;
}

/* step_sleep_plan(step, w (m, 3), v (m, 3), ask (k) uint8 out) -> the rows to ask */
static PyObject *py_step_sleep_plan(PyObject *self, PyObject *const *args, Py_ssize_t nargs) {
  (void)self;
  ARGS(4, "step, w_WB, v_WB, ask");
  cc_step *s = step_of(args[0]);
  if (s == NULL) return NULL;
  Py_ssize_t m = n_bodies(s);
  cc_step_pairs view;
  cc_step_view(s, &view);
  buffers b = {.n = 0};
  void *w, *v, *ask;
  PyObject *result = NULL;
  if (take(&b, args[1], "w_WB", 'd', 3 * m, 0, 0, &w, NULL) == 0 &&
      take(&b, args[2], "v_WB", 'd', 3 * m, 0, 0, &v, NULL) == 0 &&
      take(&b, args[3], "ask", 'b', (Py_ssize_t)view.n, 1, 0, &ask, NULL) == 0) {
    size_t n = 0;
    int status = cc_step_sleep_plan(s, w, v, ask, &n);
    if (status == CC_OK)
      result = PyLong_FromSize_t(n);
    else
      status_error(status, "step_sleep_plan (run step_candidates first)");
  }
  release(&b);
  return result;
}

/* step_sleep_counts(step) -> (asked, reused, islands, islands_asleep, bodies_asleep) of the latest step */
static PyObject *py_step_sleep_counts(PyObject *self, PyObject *const *args, Py_ssize_t nargs) {
  (void)self;
  ARGS(1, "step");
  cc_step *s = step_of(args[0]);
  if (s == NULL) return NULL;
  cc_step_sleep_counts c;
  cc_step_sleep_get_counts(s, &c);
  return Py_BuildValue("(nnnnn)", (Py_ssize_t)c.asked, (Py_ssize_t)c.reused, (Py_ssize_t)c.islands,
                       (Py_ssize_t)c.islands_asleep, (Py_ssize_t)c.bodies_asleep);
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
  if (take(&b, args[0], "p_AB", 'd', 3, 0, 0, &p, NULL) == 0 && take(&b, args[1], "R_AB", 'd', 9, 0, 0, &R, NULL) == 0 &&
      take(&b, args[2], "hA", 'd', 3, 0, 0, &hA, NULL) == 0 && take(&b, args[3], "hB", 'd', 3, 0, 0, &hB, NULL) == 0) {
    double out[3];
    cc_step_elastic(p, R, hA, hB, kappa, (int)grid, out);
    result = Py_BuildValue("(ddd)", out[0], out[1], out[2]);
  }
  release(&b);
  return result;
}

static PyObject *py_step_held_count(PyObject *self, PyObject *const *args, Py_ssize_t nargs) {
  (void)self;
  ARGS(1, "step");
  cc_step *s = step_of(args[0]);
  if (s == NULL) return NULL;
  return PyLong_FromSize_t(cc_step_held_count(s));
}

/* step_held_get(step, keys (s) out, rows (s, 8) out, history (m, 12) out) */
static PyObject *py_step_held_get(PyObject *self, PyObject *const *args, Py_ssize_t nargs) {
  (void)self;
  ARGS(4, "step, keys, rows, history");
  cc_step *s = step_of(args[0]);
  if (s == NULL) return NULL;
  Py_ssize_t n = (Py_ssize_t)cc_step_held_count(s), m = n_bodies(s);
  buffers b = {.n = 0};
  void *keys, *rows, *history;
  PyObject *result = NULL;
  if (take(&b, args[1], "keys", 'q', n, 1, 0, &keys, NULL) == 0 &&
      take(&b, args[2], "rows", 'd', CC_STEP_ROW * n, 1, 0, &rows, NULL) == 0 &&
      take(&b, args[3], "history", 'd', CC_STEP_BODY * m, 1, 0, &history, NULL) == 0) {
    cc_step_held_get(s, keys, rows, history);
    result = Py_None;
    Py_INCREF(result);
  }
  release(&b);
  return result;
}

/* step_held_set(step, keys (s), rows (s, 8), history (m, 12) or None) */
static PyObject *py_step_held_set(PyObject *self, PyObject *const *args, Py_ssize_t nargs) {
  (void)self;
  ARGS(4, "step, keys, rows, history");
  cc_step *s = step_of(args[0]);
  if (s == NULL) return NULL;
  Py_ssize_t m = n_bodies(s), n;
  buffers b = {.n = 0};
  void *keys, *rows, *history;
  PyObject *result = NULL;
  if (take(&b, args[1], "keys", 'q', -1, 0, 0, &keys, &n) == 0 &&
      take(&b, args[2], "rows", 'd', CC_STEP_ROW * n, 0, 0, &rows, NULL) == 0 &&
      take(&b, args[3], "history", 'd', CC_STEP_BODY * m, 0, 1, &history, NULL) == 0) {
    int status = cc_step_held_set(s, (size_t)n, keys, rows, history);
    if (status == CC_OK) {
      result = Py_None;
      Py_INCREF(result);
    } else {
      status_error(status, "step_held_set (keys ascending, each ia * m + ib < m * m)");
    }
  }
  release(&b);
  return result;
}

/* bodies_from_drake(x, q_start, v_start, fixed_p, fixed_R, free, p, R, w, v) */
static PyObject *py_bodies_from_drake(PyObject *self, PyObject *const *args, Py_ssize_t nargs) {
  (void)self;
  ARGS(10, "x, q_start, v_start, fixed_p, fixed_R, free, p, R, w, v");
  buffers b = {.n = 0};
  Py_ssize_t nx, m;
  void *x, *qs, *vs, *fp, *fR, *fr, *p, *R, *w, *v;
  PyObject *result = NULL;
  if (take(&b, args[5], "free", 'b', -1, 0, 0, &fr, &m) < 0 || take(&b, args[0], "x", 'd', -1, 0, 0, &x, &nx) < 0 ||
      take(&b, args[1], "q_start", 'q', m, 0, 0, &qs, NULL) < 0 ||
      take(&b, args[2], "v_start", 'q', m, 0, 0, &vs, NULL) < 0 ||
      take(&b, args[3], "fixed_p", 'd', 3 * m, 0, 0, &fp, NULL) < 0 ||
      take(&b, args[4], "fixed_R", 'd', 9 * m, 0, 0, &fR, NULL) < 0 || take(&b, args[6], "p", 'd', 3 * m, 1, 0, &p, NULL) < 0 ||
      take(&b, args[7], "R", 'd', 9 * m, 1, 0, &R, NULL) < 0 || take(&b, args[8], "w", 'd', 3 * m, 1, 0, &w, NULL) < 0 ||
      take(&b, args[9], "v", 'd', 3 * m, 1, 0, &v, NULL) < 0)
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
  release(&b);
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
  if (take(&b, args[5], "free", 'b', -1, 0, 0, &fr, &m) < 0 ||
      take(&b, args[0], "xpos", 'd', -1, 0, 0, &xpos, &nb3) < 0 ||
      take(&b, args[1], "xmat", 'd', 3 * nb3, 0, 0, &xmat, NULL) < 0 ||
      take(&b, args[2], "qvel", 'd', -1, 0, 0, &qvel, &nv) < 0 || take(&b, args[3], "body", 'q', m, 0, 0, &body, NULL) < 0 ||
      take(&b, args[4], "dof", 'q', m, 0, 0, &dof, NULL) < 0 || take(&b, args[6], "p", 'd', 3 * m, 1, 0, &p, NULL) < 0 ||
      take(&b, args[7], "R", 'd', 9 * m, 1, 0, &R, NULL) < 0 || take(&b, args[8], "w", 'd', 3 * m, 1, 0, &w, NULL) < 0 ||
      take(&b, args[9], "v", 'd', 3 * m, 1, 0, &v, NULL) < 0)
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
  release(&b);
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
  if (take(&b, args[2], "free", 'b', -1, 0, 0, &fr, &m) < 0 ||
      take(&b, args[0], "wrench_W", 'd', 6 * m, 0, 0, &out, NULL) < 0 ||
      take(&b, args[1], "body", 'q', m, 0, 0, &body, NULL) < 0 ||
      take(&b, args[3], "xpos", 'd', -1, 0, 0, &xpos, &nb3) < 0 ||
      take(&b, args[4], "xipos", 'd', nb3, 0, 0, &xipos, NULL) < 0 ||
      take(&b, args[5], "xfrc_applied", 'd', 2 * nb3, 1, 0, &xfrc, NULL) < 0)
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
  release(&b);
  return result;
}

#define FAST(name, doc) {#name, (PyCFunction)(void (*)(void))py_##name, METH_FASTCALL, doc}

PyMethodDef cc_py_step_methods[] = {
    FAST(step_new, "step_new(size, free, mass, I_Bo, type_index, kappa, params) -> step (container_contact_step.h)"),
    FAST(step_set_params, "step_set_params(step, kappa, params)"),
    FAST(step_forget, "step_forget(step): no pair held, no body history"),
    FAST(step_candidates, "step_candidates(step, p_WB, R_WB) -> k candidate pairs"),
    FAST(step_read, "step_read(step, ia, ib, p_AB, R_AB, size_A, size_B, point_A, normal_A, fn, f_W, p_W, n_W, area)"),
    FAST(step_force_law, "step_force_law(step, w_WB, v_WB, point_A, normal_A, wrench_W)"),
    FAST(step_contact, "step_contact(step, model, p_WB, R_WB, w_WB, v_WB, wrench_W, seconds) -> k, or (status, row, k)"),
    FAST(step_counts, "step_counts(step) -> (n_broad, k): the broad phase's candidates, the pairs kept"),
    FAST(step_set_sleep, "step_set_sleep(step, (enabled, v_sleep, w_sleep, t_sleep, eps_p, eps_R))"),
    FAST(step_sleep_reset, "step_sleep_reset(step): every body awake, no answer kept"),
    FAST(step_sleep_wake, "step_sleep_wake(step, bodies): their islands are asked at the next step"),
    FAST(step_sleep_plan, "step_sleep_plan(step, w_WB, v_WB, ask) -> the candidate rows to ask (split step)"),
    FAST(step_sleep_counts, "step_sleep_counts(step) -> (asked, reused, islands, islands_asleep, bodies_asleep)"),
    FAST(step_elastic, "step_elastic(p_AB, R_AB, hA, hB, kappa, grid) -> (F, area, k_n) of one pose"),
    FAST(step_held_count, "step_held_count(step) -> s pairs held"),
    FAST(step_held_get, "step_held_get(step, keys, rows, history)"),
    FAST(step_held_set, "step_held_set(step, keys, rows, history or None)"),
    FAST(bodies_from_drake, "bodies_from_drake(x, q_start, v_start, fixed_p, fixed_R, free, p, R, w, v)"),
    FAST(bodies_from_mujoco, "bodies_from_mujoco(xpos, xmat, qvel, body, dof, free, p, R, w, v)"),
    FAST(wrench_to_mujoco, "wrench_to_mujoco(wrench_W, body, free, xpos, xipos, xfrc_applied)"),
    {NULL, NULL, 0, NULL}};
