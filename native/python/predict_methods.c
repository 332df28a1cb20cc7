/* The predictor's CPython bindings (joined into learned_contact._native by module.c):
 *
 *   Model(kind, supported_sizes, main, expert, domain)   a cc_model over numpy arrays
 *   answer(model, p, R, size_A, size_B, with_depth)       a predictor's whole predict, one call
 *   depth_of(model, p, R, size_A, size_B)                 a predictor's whole depth, one call
 *   predict(model, p, R, size_A, size_B, point, normal, depth) -> (status, row)
 *   depth(model, p, R, size_A, size_B, out) -> (status, row)
 *   features(p, R, size_A, size_B, x, point_est, normal_est)   (the benchmark's geometry part)
 *   box_depth(p, R, size_A, size_B, out)                  separating-axis depth, no model
 *   time_core(model, p, R, size_A, size_B, batch, repeats) -> seconds per pair (the benchmark)
 *   constants() -> dict, tanh(x, out), set_vector_path(on), model_type()   (for the tests)
 *
 * Arrays travel through the buffer protocol: float64, C-contiguous. predict, depth and
 * features take the caller's preallocated, writable outputs and check shapes by element
 * count (p holds n poses (3 n values), R 9 n, a size array 3 (broadcast) or 3 n, point and
 * normal 3 n, depth n or None); a TypeError or ValueError otherwise. answer and depth_of
 * are the predictors' fast path: they take the user's numpy arrays as given when they
 * already have the interface's exact shapes (learned_contact.interface), read and allocate
 * them through numpy's C API, and answer None for anything else, which the Python layer
 * then converts and checks, raising the reference path's errors. status is a cc_status
 * (container_contact.h), row the first bad row. The calls are microseconds, so the GIL is
 * kept. */
#define PY_SSIZE_T_CLEAN
#include <Python.h>
#include <string.h>
#include <time.h> /* clock_gettime: Python.h asks for POSIX 2008 */

#include "cc_internal.h"
#include "container_contact.h"

/* numpy's C API, for the fast path only (module.c calls cc_py_predict_init, which imports it) */
#define NPY_NO_DEPRECATED_API NPY_1_22_API_VERSION
#define PY_ARRAY_UNIQUE_SYMBOL cc_py_numpy_api
#include <numpy/arrayobject.h>

/* ------------------------------------------------------------------ buffers */

/* A float64 C-contiguous view of obj (writable when asked); -1 with a Python error else. */
static int get_f64(PyObject *obj, Py_buffer *view, int writable, const char *name) {
  int flags = PyBUF_C_CONTIGUOUS | PyBUF_FORMAT | (writable ? PyBUF_WRITABLE : 0);
  if (PyObject_GetBuffer(obj, view, flags) < 0) {
    PyErr_Clear();
    PyErr_Format(PyExc_TypeError, "%s must be a C-contiguous%s float64 array; got %.100s", name,
                 writable ? " writable" : "", Py_TYPE(obj)->tp_name);
    return -1;
  }
  const char *f = view->format;
  if (f != NULL && (f[0] == '@' || f[0] == '=')) ++f;
#if PY_BIG_ENDIAN
  if (f != NULL && f[0] == '>') ++f;
#else
  if (f != NULL && f[0] == '<') ++f;
#endif
  if (view->itemsize != 8 || f == NULL || strcmp(f, "d") != 0) {
    PyErr_Format(PyExc_TypeError, "%s must be a float64 array; got format %.20s", name,
                 view->format ? view->format : "?");
    PyBuffer_Release(view);
    return -1;
  }
  return 0;
}

/* The number of float64 values in a view. */
static inline Py_ssize_t count_of(const Py_buffer *v) { return v->len / 8; }

/* ------------------------------------------------------------------ the Model type */

#define MAX_VIEWS (2 + 2 * (2 + 2 * CC_MAX_LAYERS))

typedef struct {
  PyObject_HEAD
  cc_model model;
  int n_views;
  Py_buffer views[MAX_VIEWS]; /* held for the model's lifetime: the arrays stay alive and unresized */
} ModelObject;

static void model_dealloc(ModelObject *self) {
  for (int i = 0; i < self->n_views; ++i) PyBuffer_Release(&self->views[i]);
  self->n_views = 0;
  Py_TYPE(self)->tp_free((PyObject *)self);
}

/* Takes a view of obj into self (ndim 1 or 2 with the given shape; -1 for "any"). */
static const double *hold(ModelObject *self, PyObject *obj, const char *name, int ndim, Py_ssize_t d0,
                          Py_ssize_t d1) {
  if (self->n_views >= MAX_VIEWS) {
    PyErr_SetString(PyExc_ValueError, "Model: too many arrays");
    return NULL;
  }
  Py_buffer *v = &self->views[self->n_views];
  if (get_f64(obj, v, 0, name) < 0) return NULL;
  ++self->n_views;
  int ok = v->ndim == ndim && (d0 < 0 || v->shape[0] == d0) && (ndim < 2 || d1 < 0 || v->shape[1] == d1);
  if (!ok) {
    PyErr_Format(PyExc_ValueError, "Model: %s has the wrong shape (ndim %d)", name, v->ndim);
    return NULL;
  }
  return (const double *)v->buf;
}

/* main/expert: (x_mean, x_std, (W_0, ...), (b_0, ...), activation code) into out. */
static int hold_mlp(ModelObject *self, PyObject *spec, const char *name, cc_mlp *out) {
  PyObject *x_mean, *x_std, *Ws, *bs;
  int activation;
  if (!PyTuple_Check(spec) || !PyArg_ParseTuple(spec, "OOO!O!i", &x_mean, &x_std, &PyTuple_Type, &Ws, &PyTuple_Type,
                                                 &bs, &activation)) {
    PyErr_Format(PyExc_TypeError, "Model: %s must be (x_mean, x_std, weights tuple, biases tuple, activation code)",
                 name);
    return -1;
  }
  Py_ssize_t n = PyTuple_GET_SIZE(Ws);
  if (n < 1 || n > CC_MAX_LAYERS || PyTuple_GET_SIZE(bs) != n) {
    PyErr_Format(PyExc_ValueError, "Model: %s needs 1 to %d layers, as many biases as weights", name, CC_MAX_LAYERS);
    return -1;
  }
  memset(out, 0, sizeof *out);
  out->n_layers = (int)n;
  out->activation = activation;
  for (Py_ssize_t i = 0; i < n; ++i) {
    const double *W = hold(self, PyTuple_GET_ITEM(Ws, i), "a weight matrix", 2, i == 0 ? -1 : out->dims[i], -1);
    if (W == NULL) return -1;
    Py_buffer *v = &self->views[self->n_views - 1];
    if (v->shape[0] > CCI_MAX_WIDTH || v->shape[1] > CCI_MAX_WIDTH) {
      PyErr_Format(PyExc_ValueError, "Model: %s has a layer wider than %d", name, CCI_MAX_WIDTH);
      return -1;
    }
    out->dims[i] = (int)v->shape[0];
    out->dims[i + 1] = (int)v->shape[1];
    out->W[i] = W;
    out->b[i] = hold(self, PyTuple_GET_ITEM(bs, i), "a bias vector", 1, out->dims[i + 1], -1);
    if (out->b[i] == NULL) return -1;
  }
  out->x_mean = hold(self, x_mean, "x_mean", 1, out->dims[0], -1);
  if (out->x_mean == NULL) return -1;
  out->x_std = hold(self, x_std, "x_std", 1, out->dims[0], -1);
  return out->x_std == NULL ? -1 : 0;
}

static PyObject *model_new(PyTypeObject *type, PyObject *args, PyObject *kwargs) {
  static char *keywords[] = {"kind", "supported_sizes", "main", "expert", "domain", NULL};
  int kind;
  PyObject *supported, *main_spec, *expert_spec = Py_None, *domain = Py_None;
  if (!PyArg_ParseTupleAndKeywords(args, kwargs, "iOO|OO:Model", keywords, &kind, &supported, &main_spec, &expert_spec,
                                   &domain))
    return NULL;
  ModelObject *self = (ModelObject *)type->tp_alloc(type, 0);
  if (self == NULL) return NULL;
  memset(&self->model, 0, sizeof self->model);
  self->n_views = 0;
  cc_model *m = &self->model;
  m->kind = kind;
  m->supported_sizes = hold(self, supported, "supported_sizes", 2, -1, 3);
  if (m->supported_sizes == NULL) goto fail;
  m->n_sizes = (int)self->views[self->n_views - 1].shape[0];
  if (hold_mlp(self, main_spec, "main", &m->main) < 0) goto fail;
  if ((expert_spec == Py_None) != (domain == Py_None)) {
    PyErr_SetString(PyExc_ValueError, "Model: expert and domain go together");
    goto fail;
  }
  if (expert_spec != Py_None) {
    m->has_expert = 1;
    if (hold_mlp(self, expert_spec, "expert", &m->expert) < 0) goto fail;
    const double *d = hold(self, domain, "domain", 1, -1, -1);
    if (d == NULL) goto fail;
    Py_ssize_t nd = self->views[self->n_views - 1].shape[0];
    if (nd != 9 && nd != 11) {
      PyErr_Format(PyExc_ValueError, "Model: domain has %zd values; expected 11 or 9", nd);
      goto fail;
    }
    m->n_domain = (int)nd;
    for (Py_ssize_t i = 0; i < nd; ++i) m->domain[i] = d[i];
  }
  /* the core's own check of the model (a call for no poses checks the model alone) */
  if (cc_depth(m, 0, NULL, NULL, NULL, 0, NULL, 0, NULL, NULL) != CC_OK) {
    PyErr_SetString(PyExc_ValueError, "Model: the networks' widths do not fit the kind (improved: 91 inputs and 6 "
                                      "outputs; paper: 6 and 4) or the kind is unknown (1 improved, 2 paper)");
    goto fail;
  }
  return (PyObject *)self;
fail:
  Py_DECREF(self);
  return NULL;
}

static PyObject *model_get_kind(ModelObject *self, void *closure) {
  (void)closure;
  return PyLong_FromLong(self->model.kind);
}

static PyObject *model_get_has_expert(ModelObject *self, void *closure) {
  (void)closure;
  return PyBool_FromLong(self->model.has_expert);
}

static PyGetSetDef model_getset[] = {
    {"kind", (getter)model_get_kind, NULL, "1: improved, 2: paper (enum cc_kind)", NULL},
    {"has_expert", (getter)model_get_has_expert, NULL, "whether the resting expert answers", NULL},
    {NULL, NULL, NULL, NULL, NULL},
};

static PyTypeObject ModelType = {
    PyVarObject_HEAD_INIT(NULL, 0) /* (the macro ends with a comma) */
    .tp_name = "learned_contact._native.Model",
    .tp_basicsize = sizeof(ModelObject),
    .tp_dealloc = (destructor)model_dealloc,
    .tp_flags = Py_TPFLAGS_DEFAULT,
    .tp_doc = "Model(kind, supported_sizes, main, expert=None, domain=None): a predictor for the native core over "
              "numpy arrays (kept alive by the model). kind 1 improved, 2 paper; supported_sizes (k, 3) [m]; main, "
              "expert: (x_mean, x_std, (W_0, ...), (b_0, ...), activation code 0 tanh / 1 silu / 2 relu), W_i "
              "(in, out); domain: the expert gate's 11 (or 9) bounds.",
    .tp_getset = model_getset,
    .tp_new = model_new,
};

/* ------------------------------------------------------------------ calls */

/* The inputs of predict and depth: args[0] the model, args[1..4] p, R, size_A, size_B. */
typedef struct {
  Py_buffer p, R, sA, sB;
  int held;
  size_t n, rows_A, rows_B;
} inputs;

static void release_inputs(inputs *in) {
  Py_buffer *v[4] = {&in->p, &in->R, &in->sA, &in->sB};
  for (int i = 0; i < in->held; ++i) PyBuffer_Release(v[i]);
  in->held = 0;
}

static int ready(PyObject *type_ready) {
  (void)type_ready;
  if (ModelType.tp_flags & Py_TPFLAGS_READY) return 0;
  return PyType_Ready(&ModelType);
}

static const cc_model *model_of(PyObject *obj) {
  if (Py_TYPE(obj) != &ModelType) {
    PyErr_SetString(PyExc_TypeError, "the first argument must be a learned_contact._native.Model");
    return NULL;
  }
  return &((ModelObject *)obj)->model;
}

static int get_inputs(PyObject *const *args, inputs *in) {
  static const char *names[4] = {"p_AB", "R_AB", "size_A", "size_B"};
  Py_buffer *v[4] = {&in->p, &in->R, &in->sA, &in->sB};
  in->held = 0;
  for (int i = 0; i < 4; ++i) {
    if (get_f64(args[i], v[i], 0, names[i]) < 0) {
      release_inputs(in);
      return -1;
    }
    ++in->held;
  }
  Py_ssize_t np = count_of(&in->p), nA = count_of(&in->sA), nB = count_of(&in->sB);
  in->n = (size_t)(np / 3);
  in->rows_A = (size_t)(nA / 3);
  in->rows_B = (size_t)(nB / 3);
  int ok = np % 3 == 0 && count_of(&in->R) == 3 * np && nA % 3 == 0 && nB % 3 == 0 &&
           (in->rows_A == 1 || in->rows_A == in->n) && (in->rows_B == 1 || in->rows_B == in->n);
  if (!ok) {
    PyErr_SetString(PyExc_ValueError, "expected p_AB of n poses (3 n values), R_AB of 9 n, size_A and size_B of 3 or 3 n");
    release_inputs(in);
    return -1;
  }
  return 0;
}

/* model_of for the other binding files of the module (step_methods.c): one owner of the layout */
const cc_model *cc_py_model_of(PyObject *obj);
const cc_model *cc_py_model_of(PyObject *obj) { return model_of(obj); }

static PyObject *status_tuple(int status, size_t row) {
  return Py_BuildValue("(in)", status, (Py_ssize_t)row);
}

/* predict(model, p, R, size_A, size_B, point, normal, depth_or_None) -> (status, row) */
static PyObject *py_predict(PyObject *module, PyObject *const *args, Py_ssize_t nargs) {
  (void)module;
  if (nargs != 8) {
    PyErr_SetString(PyExc_TypeError, "predict(model, p, R, size_A, size_B, point, normal, depth) takes 8 arguments");
    return NULL;
  }
  const cc_model *model = model_of(args[0]);
  if (model == NULL) return NULL;
  inputs in;
  if (get_inputs(args + 1, &in) < 0) return NULL;
  Py_buffer point, normal, depth;
  int have_depth = args[7] != Py_None;
  if (get_f64(args[5], &point, 1, "point") < 0) goto fail_in;
  if (get_f64(args[6], &normal, 1, "normal") < 0) goto fail_point;
  if (have_depth && get_f64(args[7], &depth, 1, "depth") < 0) goto fail_normal;
  if ((size_t)count_of(&point) != 3 * in.n || (size_t)count_of(&normal) != 3 * in.n ||
      (have_depth && (size_t)count_of(&depth) != in.n)) {
    PyErr_SetString(PyExc_ValueError, "point and normal must hold 3 n values, depth n");
    goto fail_all;
  }
  size_t row = 0;
  int status = cc_predict(model, in.n, in.p.buf, in.R.buf, in.sA.buf, in.rows_A, in.sB.buf, in.rows_B, point.buf,
                          normal.buf, have_depth ? depth.buf : NULL, &row);
  if (have_depth) PyBuffer_Release(&depth);
  PyBuffer_Release(&normal);
  PyBuffer_Release(&point);
  release_inputs(&in);
  return status_tuple(status, row);
fail_all:
  if (have_depth) PyBuffer_Release(&depth);
fail_normal:
  PyBuffer_Release(&normal);
fail_point:
  PyBuffer_Release(&point);
fail_in:
  release_inputs(&in);
  return NULL;
}

/* depth(model, p, R, size_A, size_B, out) -> (status, row) */
static PyObject *py_depth(PyObject *module, PyObject *const *args, Py_ssize_t nargs) {
  (void)module;
  if (nargs != 6) {
    PyErr_SetString(PyExc_TypeError, "depth(model, p, R, size_A, size_B, out) takes 6 arguments");
    return NULL;
  }
  const cc_model *model = model_of(args[0]);
  if (model == NULL) return NULL;
  inputs in;
  if (get_inputs(args + 1, &in) < 0) return NULL;
  Py_buffer out;
  if (get_f64(args[5], &out, 1, "out") < 0) {
    release_inputs(&in);
    return NULL;
  }
  if ((size_t)count_of(&out) != in.n) {
    PyErr_SetString(PyExc_ValueError, "out must hold n values");
    PyBuffer_Release(&out);
    release_inputs(&in);
    return NULL;
  }
  size_t row = 0;
  int status = cc_depth(model, in.n, in.p.buf, in.R.buf, in.sA.buf, in.rows_A, in.sB.buf, in.rows_B, out.buf, &row);
  PyBuffer_Release(&out);
  release_inputs(&in);
  return status_tuple(status, row);
}

/* box_depth(p, R, size_A, size_B, out): the separating-axis depth [m] of n poses of boxes of
 * any size (no model, no supported-size check: for a model the testbed did not ship, whose
 * inputs learned_contact.interface has checked already). Non-finite inputs give NaN. */
static PyObject *py_box_depth(PyObject *module, PyObject *const *args, Py_ssize_t nargs) {
  (void)module;
  if (nargs != 5) {
    PyErr_SetString(PyExc_TypeError, "box_depth(p, R, size_A, size_B, out) takes 5 arguments");
    return NULL;
  }
  inputs in;
  if (get_inputs(args, &in) < 0) return NULL;
  Py_buffer out;
  if (get_f64(args[4], &out, 1, "out") < 0) {
    release_inputs(&in);
    return NULL;
  }
  if ((size_t)count_of(&out) != in.n) {
    PyErr_SetString(PyExc_ValueError, "out must hold n values");
    PyBuffer_Release(&out);
    release_inputs(&in);
    return NULL;
  }
  const double *p = in.p.buf, *R = in.R.buf, *sA = in.sA.buf, *sB = in.sB.buf;
  double *d = out.buf;
  for (size_t r = 0; r < in.n; ++r) {
    const double *a = sA + 3 * (in.rows_A == 1 ? 0 : r), *b = sB + 3 * (in.rows_B == 1 ? 0 : r);
    double hA[3] = {0.5 * a[0], 0.5 * a[1], 0.5 * a[2]}, hB[3] = {0.5 * b[0], 0.5 * b[1], 0.5 * b[2]};
    d[r] = cci_sat_depth(p + 3 * r, R + 9 * r, hA, hB);
  }
  PyBuffer_Release(&out);
  release_inputs(&in);
  Py_RETURN_NONE;
}

/* check(supported, p, R, size_A, size_B) -> (status, row): cc_predict's input checks
 * (interface.check_numpy's, in its order) against supported (k, 3) full extents [m], for a
 * model the testbed did not ship: a status other than 0 sends the caller to check_numpy,
 * which raises the reference's error. */
static PyObject *py_check(PyObject *module, PyObject *const *args, Py_ssize_t nargs) {
  (void)module;
  if (nargs != 5) {
    PyErr_SetString(PyExc_TypeError, "check(supported, p, R, size_A, size_B) takes 5 arguments");
    return NULL;
  }
  Py_buffer supported;
  if (get_f64(args[0], &supported, 0, "supported") < 0) return NULL;
  Py_ssize_t k = count_of(&supported) / 3;
  if (k < 1 || count_of(&supported) != 3 * k) {
    PyBuffer_Release(&supported);
    PyErr_SetString(PyExc_ValueError, "supported must hold 3 k values (k >= 1)");
    return NULL;
  }
  inputs in;
  if (get_inputs(args + 1, &in) < 0) {
    PyBuffer_Release(&supported);
    return NULL;
  }
  size_t row = 0;
  int status = cci_check_inputs(supported.buf, (int)k, in.n, in.p.buf, in.R.buf, in.sA.buf, in.rows_A, in.sB.buf,
                                in.rows_B, &row);
  release_inputs(&in);
  PyBuffer_Release(&supported);
  return status_tuple(status, row);
}

/* time_core(model, p, R, size_A, size_B, batch, repeats) -> float: the native core's own cost
 * [s per pair], timed in C with no Python between calls: cc_predict over the n poses in calls
 * of `batch` poses (1: one pair per call, as a simulator's per-contact call), the whole pass
 * repeated `repeats` times and the fastest pass kept (least disturbed by other load). size_A
 * and size_B must have 1 row (broadcast) or n. A status other than CC_OK raises ValueError. */
static double now_s(void) {
  struct timespec ts;
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

static PyObject *py_time_core(PyObject *module, PyObject *const *args, Py_ssize_t nargs) {
  (void)module;
  if (nargs != 7) {
    PyErr_SetString(PyExc_TypeError, "time_core(model, p, R, size_A, size_B, batch, repeats) takes 7 arguments");
    return NULL;
  }
  const cc_model *model = model_of(args[0]);
  if (model == NULL) return NULL;
  Py_ssize_t batch = PyLong_AsSsize_t(args[5]), repeats = PyLong_AsSsize_t(args[6]);
  if (PyErr_Occurred()) return NULL;
  inputs in;
  if (get_inputs(args + 1, &in) < 0) return NULL;
  if (batch < 1 || repeats < 1 || in.n == 0) {
    release_inputs(&in);
    PyErr_SetString(PyExc_ValueError, "time_core: expected batch >= 1, repeats >= 1 and at least one pose");
    return NULL;
  }
  size_t n = in.n, b = (size_t)batch;
  double *point = PyMem_Malloc(sizeof(double) * 3 * n), *normal = PyMem_Malloc(sizeof(double) * 3 * n);
  double *depth = PyMem_Malloc(sizeof(double) * n);
  double best = INFINITY;
  int status = CC_OK;
  if (point == NULL || normal == NULL || depth == NULL) {
    PyErr_NoMemory();
  } else {
    for (Py_ssize_t rep = 0; rep < repeats && status == CC_OK; ++rep) {
      double t0 = now_s();
      for (size_t r = 0; r < n && status == CC_OK; r += b) {
        size_t m = n - r < b ? n - r : b, row = 0;
        const double *sA = (const double *)in.sA.buf + (in.rows_A == 1 ? 0 : 3 * r);
        const double *sB = (const double *)in.sB.buf + (in.rows_B == 1 ? 0 : 3 * r);
        status = cc_predict(model, m, (const double *)in.p.buf + 3 * r, (const double *)in.R.buf + 9 * r, sA,
                            in.rows_A == 1 ? 1 : m, sB, in.rows_B == 1 ? 1 : m, point + 3 * r, normal + 3 * r,
                            depth + r, &row);
      }
      double t = now_s() - t0;
      if (t < best) best = t;
    }
    if (status != CC_OK) PyErr_Format(PyExc_ValueError, "time_core: cc_predict answered status %d", status);
  }
  PyMem_Free(point);
  PyMem_Free(normal);
  PyMem_Free(depth);
  release_inputs(&in);
  if (PyErr_Occurred()) return NULL;
  return PyFloat_FromDouble(best / (double)n);
}

/* ------------------------------------------------------------------ the predictor's fast path
 * answer(model, p_AB, R_AB, size_A, size_B, with_depth) and depth_of(model, p_AB, R_AB, size_A,
 * size_B): the whole of a predictor's predict / depth for inputs that are already float64
 * C-contiguous numpy arrays of the interface's shapes (p (3,) with R (3, 3), or p (n, 3)
 * with R (n, 3, 3); sizes (3,) or (n, 3)), outputs allocated here (numpy.empty). They return
 * None for anything else (a list, another dtype or layout, another shape): the caller then
 * converts and checks in Python (learned_contact.interface), which raises the reference's
 * errors for bad shapes. answer returns (status, row, point, normal, depth or None, the
 * number of poses outside DOMAIN_DEPTH (0 without depth)): point and normal (3,) for a
 * single pose, (n, 3) else; depth_of returns (status, row, depth): a float for a single
 * pose, (n,) else. */

/* Arrays through numpy's C API (not the buffer protocol) on this path: one call's
 * overhead around the core was ~1.4 us per call through PyObject_GetBuffer and numpy.empty
 * (measured: 3.15 us for answer against 1.72 us for the core's own one-pair call), which the
 * benchmark's one-pair-per-call targets count. */
int cc_py_predict_init(void) {
  import_array1(-1);
  return 0;
}

/* A new float64 array of shape (n, 3) (rows) or (n,), its data in *data; NULL with an error set. */
static PyObject *new_array(Py_ssize_t n, int rows, double **data) {
  npy_intp dims[2] = {(npy_intp)n, 3};
  PyObject *array = PyArray_SimpleNew(rows ? 2 : 1, dims, NPY_DOUBLE);
  if (array != NULL) *data = (double *)PyArray_DATA((PyArrayObject *)array);
  return array;
}

/* obj's float64 values when it is a numpy array of native byte order, aligned and C-contiguous,
 * with ndim dimensions (shape in *shape); NULL else (no error set). */
static const double *array_f64(PyObject *obj, int ndim, const npy_intp **shape) {
  if (!PyArray_Check(obj)) return NULL;
  PyArrayObject *a = (PyArrayObject *)obj;
  if (PyArray_TYPE(a) != NPY_DOUBLE || PyArray_NDIM(a) != ndim || !PyArray_ISCARRAY_RO(a) || !PyArray_ISNOTSWAPPED(a))
    return NULL;
  *shape = PyArray_DIMS(a);
  return (const double *)PyArray_DATA(a);
}

/* The interface's inputs on the fast path (borrowed: the caller's arguments outlive the call). */
typedef struct {
  const double *p, *R, *sA, *sB;
  size_t n, rows_A, rows_B;
} fast_in;

/* A size array (3,) (one row) or, for n poses, (n, 3): its values and row count; NULL else. */
static const double *size_rows(PyObject *obj, int single, size_t n, size_t *rows) {
  const npy_intp *shape;
  const double *v = array_f64(obj, 1, &shape);
  if (v != NULL) {
    *rows = 1;
    return shape[0] == 3 ? v : NULL;
  }
  v = single ? NULL : array_f64(obj, 2, &shape);
  *rows = n;
  return v != NULL && (size_t)shape[0] == n && shape[1] == 3 ? v : NULL;
}

/* The interface's inputs (args[0..3]: p, R, size_A, size_B): 1 in the fast path's form (in
 * set; *single for p (3,) with R (3, 3)), 0 else. */
static int fast_inputs(PyObject *const *args, fast_in *in, int *single) {
  const npy_intp *shape;
  if ((in->p = array_f64(args[0], 1, &shape)) != NULL) {
    if (shape[0] != 3) return 0;
    *single = 1;
    in->n = 1;
    if ((in->R = array_f64(args[1], 2, &shape)) == NULL || shape[0] != 3 || shape[1] != 3) return 0;
  } else if ((in->p = array_f64(args[0], 2, &shape)) != NULL && shape[1] == 3) {
    *single = 0;
    in->n = (size_t)shape[0];
    if ((in->R = array_f64(args[1], 3, &shape)) == NULL || (size_t)shape[0] != in->n || shape[1] != 3 ||
        shape[2] != 3)
      return 0;
  } else {
    return 0;
  }
  in->sA = size_rows(args[2], *single, in->n, &in->rows_A);
  in->sB = size_rows(args[3], *single, in->n, &in->rows_B);
  return in->sA != NULL && in->sB != NULL;
}

/* answer(model, p, R, size_A, size_B, with_depth) -> (status, row, point, normal, depth, n_outside) or None */
static PyObject *py_answer(PyObject *module, PyObject *const *args, Py_ssize_t nargs) {
  (void)module;
  if (nargs != 6) {
    PyErr_SetString(PyExc_TypeError, "answer(model, p, R, size_A, size_B, with_depth) takes 6 arguments");
    return NULL;
  }
  const cc_model *model = model_of(args[0]);
  if (model == NULL) return NULL;
  int with_depth = PyObject_IsTrue(args[5]);
  if (with_depth < 0) return NULL;
  fast_in in;
  int single;
  if (!fast_inputs(args + 1, &in, &single)) Py_RETURN_NONE;
  double *vp = NULL, *vn = NULL, *vd = NULL;
  PyObject *point = NULL, *normal = NULL, *depth = NULL, *result = NULL;
  Py_ssize_t n = (Py_ssize_t)in.n;
  if ((point = new_array(single ? 3 : n, !single, &vp)) == NULL) goto done;
  if ((normal = new_array(single ? 3 : n, !single, &vn)) == NULL) goto done;
  if (with_depth && (depth = new_array(n, 0, &vd)) == NULL) goto done;
  size_t row = 0;
  int status = cc_predict(model, in.n, in.p, in.R, in.sA, in.rows_A, in.sB, in.rows_B, vp, vn, vd, &row);
  Py_ssize_t n_outside = 0; /* poses outside the trained depth range (interface.DOMAIN_DEPTH) */
  if (with_depth && status == CC_OK) {
    for (Py_ssize_t r = 0; r < n; ++r) n_outside += vd[r] < CCI_DOMAIN_DEPTH_LO || vd[r] > CCI_DOMAIN_DEPTH_HI;
  }
  result = Py_BuildValue("(inOOOn)", status, (Py_ssize_t)row, point, normal, depth ? depth : Py_None, n_outside);
done:
  Py_XDECREF(point);
  Py_XDECREF(normal);
  Py_XDECREF(depth);
  return result;
}

/* depth_of(model, p, R, size_A, size_B) -> (status, row, depth) or None */
static PyObject *py_depth_of(PyObject *module, PyObject *const *args, Py_ssize_t nargs) {
  (void)module;
  if (nargs != 5) {
    PyErr_SetString(PyExc_TypeError, "depth_of(model, p, R, size_A, size_B) takes 5 arguments");
    return NULL;
  }
  const cc_model *model = model_of(args[0]);
  if (model == NULL) return NULL;
  fast_in in;
  int single;
  if (!fast_inputs(args + 1, &in, &single)) Py_RETURN_NONE;
  size_t row = 0;
  if (single) {
    double d = 0.0;
    int status = cc_depth(model, 1, in.p, in.R, in.sA, 1, in.sB, 1, &d, &row);
    return Py_BuildValue("(ind)", status, (Py_ssize_t)row, d);
  }
  double *vd = NULL;
  PyObject *depth = new_array((Py_ssize_t)in.n, 0, &vd);
  if (depth == NULL) return NULL;
  int status = cc_depth(model, in.n, in.p, in.R, in.sA, in.rows_A, in.sB, in.rows_B, vd, &row);
  PyObject *result = Py_BuildValue("(inO)", status, (Py_ssize_t)row, depth);
  Py_DECREF(depth);
  return result;
}

/* features(p, R, size_A, size_B, x, point_est, normal_est): encodings.features of the
 * canonicalised poses (no input checks: the benchmark's geometry-and-features figure). */
static PyObject *py_features(PyObject *module, PyObject *const *args, Py_ssize_t nargs) {
  (void)module;
  if (nargs != 7) {
    PyErr_SetString(PyExc_TypeError, "features(p, R, size_A, size_B, x, point_est, normal_est) takes 7 arguments");
    return NULL;
  }
  inputs in;
  if (get_inputs(args, &in) < 0) return NULL;
  Py_buffer x, pe, ne;
  if (get_f64(args[4], &x, 1, "x") < 0) goto fail_in;
  if (get_f64(args[5], &pe, 1, "point_est") < 0) goto fail_x;
  if (get_f64(args[6], &ne, 1, "normal_est") < 0) goto fail_pe;
  if ((size_t)count_of(&x) != CCI_N_FEATURES * in.n || (size_t)count_of(&pe) != 3 * in.n ||
      (size_t)count_of(&ne) != 3 * in.n) {
    PyErr_Format(PyExc_ValueError, "x must hold %d n values, point_est and normal_est 3 n", CCI_N_FEATURES);
    goto fail_all;
  }
  const double *p = in.p.buf, *R = in.R.buf, *sA = in.sA.buf, *sB = in.sB.buf;
  for (size_t r = 0; r < in.n; ++r) {
    const double *a = sA + (in.rows_A == 1 ? 0 : 3 * r), *b = sB + (in.rows_B == 1 ? 0 : 3 * r);
    double hA[3] = {0.5 * a[0], 0.5 * a[1], 0.5 * a[2]}, hB[3] = {0.5 * b[0], 0.5 * b[1], 0.5 * b[2]};
    double S[3], p_c[3], R_c[9], overlap[15];
    cci_canonicalise(p + 3 * r, R + 9 * r, S, p_c, R_c);
    cci_features(p_c, R_c, hA, hB, (double *)x.buf + CCI_N_FEATURES * r, (double *)pe.buf + 3 * r,
                 (double *)ne.buf + 3 * r, overlap);
  }
  PyBuffer_Release(&ne);
  PyBuffer_Release(&pe);
  PyBuffer_Release(&x);
  release_inputs(&in);
  Py_RETURN_NONE;
fail_all:
  PyBuffer_Release(&ne);
fail_pe:
  PyBuffer_Release(&pe);
fail_x:
  PyBuffer_Release(&x);
fail_in:
  release_inputs(&in);
  return NULL;
}

/* tanh(x, out): out = the networks' tanh of x (cci_tanh), element by element (for the tests). */
static PyObject *py_tanh(PyObject *module, PyObject *const *args, Py_ssize_t nargs) {
  (void)module;
  if (nargs != 2) {
    PyErr_SetString(PyExc_TypeError, "tanh(x, out) takes 2 arguments");
    return NULL;
  }
  Py_buffer x, out;
  if (get_f64(args[0], &x, 0, "x") < 0) return NULL;
  if (get_f64(args[1], &out, 1, "out") < 0) {
    PyBuffer_Release(&x);
    return NULL;
  }
  if (count_of(&x) != count_of(&out)) {
    PyErr_SetString(PyExc_ValueError, "x and out must hold as many values");
  } else {
    const double *a = x.buf;
    double *b = out.buf;
    for (Py_ssize_t i = 0; i < count_of(&x); ++i) b[i] = cci_tanh(a[i]);
  }
  PyBuffer_Release(&out);
  PyBuffer_Release(&x);
  if (PyErr_Occurred()) return NULL;
  Py_RETURN_NONE;
}

/* set_vector_path(on): the networks on AVX vectors where available (True, the default) or in
 * plain C only (False); the two give the same bits (for the tests). */
static PyObject *py_set_vector_path(PyObject *module, PyObject *on) {
  (void)module;
  int flag = PyObject_IsTrue(on);
  if (flag < 0) return NULL;
  cci_set_vector_path(flag);
  Py_RETURN_NONE;
}

static int set_float(PyObject *d, const char *name, double v) {
  PyObject *f = PyFloat_FromDouble(v);
  if (f == NULL) return -1;
  int rc = PyDict_SetItemString(d, name, f);
  Py_DECREF(f);
  return rc;
}

static int set_int(PyObject *d, const char *name, long v) {
  PyObject *i = PyLong_FromLong(v);
  if (i == NULL) return -1;
  int rc = PyDict_SetItemString(d, name, i);
  Py_DECREF(i);
  return rc;
}

/* constants() -> {name: value}: the constants the C core holds (the Python names). */
static PyObject *py_constants(PyObject *module, PyObject *unused) {
  (void)module;
  (void)unused;
  PyObject *d = PyDict_New();
  if (d == NULL) return NULL;
  int rc = set_float(d, "SIZE_TOLERANCE", CCI_SIZE_TOLERANCE) | set_float(d, "ROTATION_TOLERANCE", CCI_ROTATION_TOLERANCE) |
           set_float(d, "DOMAIN_DEPTH_LO", CCI_DOMAIN_DEPTH_LO) | set_float(d, "DOMAIN_DEPTH_HI", CCI_DOMAIN_DEPTH_HI) |
           set_float(d, "CLIP_MARGIN", CCI_CLIP_MARGIN) | set_float(d, "POINT_STEP", CCI_POINT_STEP) |
           set_float(d, "SYMMETRY_BAND", CCI_SYMMETRY_BAND) | set_float(d, "R_SLAB", CCI_R_SLAB) |
           set_float(d, "LENGTH_SCALE", CCI_LENGTH_SCALE) | set_float(d, "EDGE_BIAS", CCI_EDGE_BIAS) |
           set_float(d, "POINT_TILT_0", CCI_POINT_TILT_0) | set_float(d, "POINT_TILT_1", CCI_POINT_TILT_1) |
           set_float(d, "NORMAL_TILT_0", CCI_NORMAL_TILT_0) | set_float(d, "NORMAL_TILT_1", CCI_NORMAL_TILT_1) |
           set_int(d, "N_FEATURES", CCI_N_FEATURES) | set_int(d, "MAX_VERTS", CCI_MAX_VERTS) |
           set_int(d, "QUAD_VERTS", CCI_QUAD_VERTS) | set_int(d, "MAX_WIDTH", CCI_MAX_WIDTH) |
           set_int(d, "MAX_LAYERS", CC_MAX_LAYERS) | set_int(d, "KIND_IMPROVED", CC_KIND_IMPROVED) |
           set_int(d, "KIND_PAPER", CC_KIND_PAPER) | set_int(d, "TANH", CC_TANH) | set_int(d, "SILU", CC_SILU) |
           set_int(d, "RELU", CC_RELU);
  PyObject *frame = rc ? NULL : PyTuple_New(9);
  if (frame != NULL) {
    for (int i = 0; i < 9; ++i) PyTuple_SET_ITEM(frame, i, PyFloat_FromDouble(cci_paper_frame[i / 3][i % 3]));
    rc = PyDict_SetItemString(d, "PAPER_FRAME", frame);
    Py_DECREF(frame);
  } else {
    rc = -1;
  }
  if (rc) {
    Py_DECREF(d);
    return NULL;
  }
  return d;
}

/* Model is a type, not a function: this entry makes it (readies the type on first use) and
 * module.c's table of functions carries it like the others. */
static PyObject *py_model(PyObject *module, PyObject *args, PyObject *kwargs) {
  (void)module;
  if (ready(NULL) < 0) return NULL;
  return model_new(&ModelType, args, kwargs);
}

/* model_type() -> the Model type (for isinstance checks). */
static PyObject *py_model_type(PyObject *module, PyObject *unused) {
  (void)module;
  (void)unused;
  if (ready(NULL) < 0) return NULL;
  Py_INCREF(&ModelType);
  return (PyObject *)&ModelType;
}

PyMethodDef cc_py_predict_methods[] = {
    {"Model", (PyCFunction)(void (*)(void))py_model, METH_VARARGS | METH_KEYWORDS, "Model(kind, supported_sizes, main, "
     "expert=None, domain=None): a predictor for the native core (see model_type().__doc__)."},
    {"model_type", py_model_type, METH_NOARGS, "model_type() -> the Model type."},
    {"predict", (PyCFunction)(void (*)(void))py_predict, METH_FASTCALL,
     "predict(model, p, R, size_A, size_B, point, normal, depth) -> (status, row): cc_predict on float64 arrays "
     "(outputs preallocated; depth may be None)."},
    {"depth", (PyCFunction)(void (*)(void))py_depth, METH_FASTCALL,
     "depth(model, p, R, size_A, size_B, out) -> (status, row): cc_depth on float64 arrays."},
    {"check", (PyCFunction)(void (*)(void))py_check, METH_FASTCALL,
     "check(supported, p, R, size_A, size_B) -> (status, row): cc_predict's input checks, no model"},
    {"time_core", (PyCFunction)(void (*)(void))py_time_core, METH_FASTCALL,
     "time_core(model, p, R, size_A, size_B, batch, repeats) -> the core's own cost [s per pair], timed in C"},
    {"box_depth", (PyCFunction)(void (*)(void))py_box_depth, METH_FASTCALL,
     "box_depth(p, R, size_A, size_B, out): separating-axis depth [m] of boxes of any size (no model)"},
    {"answer", (PyCFunction)(void (*)(void))py_answer, METH_FASTCALL,
     "answer(model, p, R, size_A, size_B, with_depth) -> (status, row, point, normal, depth, n_outside) or None: a "
     "predictor's predict in one call for float64 C-contiguous arrays of the interface's shapes (None: convert and check in "
     "Python)."},
    {"depth_of", (PyCFunction)(void (*)(void))py_depth_of, METH_FASTCALL,
     "depth_of(model, p, R, size_A, size_B) -> (status, row, depth) or None: a predictor's depth in one call (a "
     "float for a single pose)."},
    {"features", (PyCFunction)(void (*)(void))py_features, METH_FASTCALL,
     "features(p, R, size_A, size_B, x, point_est, normal_est): the improved predictor's features of the "
     "canonicalised poses (no input checks)."},
    {"tanh", (PyCFunction)(void (*)(void))py_tanh, METH_FASTCALL,
     "tanh(x, out): out = the networks' tanh of x (plain arithmetic, native/src/mlp.c), element by element."},
    {"set_vector_path", py_set_vector_path, METH_O,
     "set_vector_path(on): the networks on AVX vectors where the CPU has them (True, the default) or in plain C "
     "(False); both give the same bits."},
    {"constants", py_constants, METH_NOARGS, "constants() -> {name: value} held by the C core."},
    {NULL, NULL, 0, NULL},
};
