/* core_probes.c: what the tests and the benchmark ask of the native core through
 * learned_contact._native (module.c joins this file's table into the module):
 *
 *   features(p, R, size_A, size_B, x, point_est, normal_est)   (the benchmark's geometry part)
 *   time_core(model, p, R, size_A, size_B, batch, repeats) -> seconds per pair (the benchmark)
 *   tanh(x, out), set_vector_path(on), constants() -> dict     (for the tests)
 */
#include "predict_bindings.h" /* first: Python.h asks for POSIX 2008 (clock_gettime) */

#include <math.h>
#include <time.h>

#include "cc_internal.h"

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
  const cc_model *model = cc_py_model_of(args[0]);
  if (model == NULL) return NULL;
  Py_ssize_t batch = PyLong_AsSsize_t(args[5]), repeats = PyLong_AsSsize_t(args[6]);
  if (PyErr_Occurred()) return NULL;
  inputs in;
  if (cc_py_get_inputs(args + 1, &in) < 0) return NULL;
  if (batch < 1 || repeats < 1 || in.n == 0) {
    cc_py_release_inputs(&in);
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
  cc_py_release_inputs(&in);
  if (PyErr_Occurred()) return NULL;
  return PyFloat_FromDouble(best / (double)n);
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
  if (cc_py_get_inputs(args, &in) < 0) return NULL;
  Py_buffer x, pe, ne;
  if (cc_py_get_f64(args[4], &x, 1, "x") < 0) goto fail_in;
  if (cc_py_get_f64(args[5], &pe, 1, "point_est") < 0) goto fail_x;
  if (cc_py_get_f64(args[6], &ne, 1, "normal_est") < 0) goto fail_pe;
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
  cc_py_release_inputs(&in);
  Py_RETURN_NONE;
fail_all:
  PyBuffer_Release(&ne);
fail_pe:
  PyBuffer_Release(&pe);
fail_x:
  PyBuffer_Release(&x);
fail_in:
  cc_py_release_inputs(&in);
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
  if (cc_py_get_f64(args[0], &x, 0, "x") < 0) return NULL;
  if (cc_py_get_f64(args[1], &out, 1, "out") < 0) {
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

PyMethodDef cc_py_probe_methods[] = {
    {"time_core", (PyCFunction)(void (*)(void))py_time_core, METH_FASTCALL,
     "time_core(model, p, R, size_A, size_B, batch, repeats) -> the core's own cost [s per pair], timed in C"},
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
