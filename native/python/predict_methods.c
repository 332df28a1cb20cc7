/* The predictor's checked calls (joined into learned_contact._native by module.c):
 *
 *   predict(model, p, R, size_A, size_B, point, normal, depth) -> (status, row)
 *   depth(model, p, R, size_A, size_B, out) -> (status, row)
 *   check(supported, p, R, size_A, size_B) -> (status, row)   cc_predict's input checks, no model
 *   box_depth(p, R, size_A, size_B, out)                      separating-axis depth, no model
 *
 * Beside them: model_type.c (Model(kind, supported_sizes, main, expert, domain), a cc_model over
 * numpy arrays), predict_fast.c (answer and depth_of: a predictor's whole predict or depth in one
 * call, the fast path) and core_probes.c (features, time_core, tanh, set_vector_path, constants:
 * what the tests and the benchmark ask of the core).
 *
 * Arrays travel through the buffer protocol: float64, C-contiguous. predict, depth and
 * box_depth take the caller's preallocated, writable outputs and check shapes by element
 * count (p holds n poses (3 n values), R 9 n, a size array 3 (broadcast) or 3 n, point and
 * normal 3 n, depth n or None); a TypeError or ValueError otherwise. status is a cc_status
 * (container_contact.h), row the first bad row. The calls are microseconds, so the GIL is
 * kept. */
#include "predict_bindings.h" /* first: Python.h before the standard headers */

#include <string.h>

#include "cc_internal.h"

/* ------------------------------------------------------------------ buffers */

/* A float64 C-contiguous view of obj (writable when asked); -1 with a Python error else. */
int cc_py_get_f64(PyObject *obj, Py_buffer *view, int writable, const char *name) {
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

void cc_py_release_inputs(inputs *in) {
  Py_buffer *v[4] = {&in->p, &in->R, &in->sA, &in->sB};
  for (int i = 0; i < in->held; ++i) PyBuffer_Release(v[i]);
  in->held = 0;
}

int cc_py_get_inputs(PyObject *const *args, inputs *in) {
  static const char *names[4] = {"p_AB", "R_AB", "size_A", "size_B"};
  Py_buffer *v[4] = {&in->p, &in->R, &in->sA, &in->sB};
  in->held = 0;
  for (int i = 0; i < 4; ++i) {
    if (cc_py_get_f64(args[i], v[i], 0, names[i]) < 0) {
      cc_py_release_inputs(in);
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
    cc_py_release_inputs(in);
    return -1;
  }
  return 0;
}

PyObject *cc_py_status_tuple(int status, size_t row) {
  return Py_BuildValue("(in)", status, (Py_ssize_t)row);
}

/* ------------------------------------------------------------------ calls */

/* predict(model, p, R, size_A, size_B, point, normal, depth_or_None) -> (status, row) */
static PyObject *py_predict(PyObject *module, PyObject *const *args, Py_ssize_t nargs) {
  (void)module;
  if (nargs != 8) {
    PyErr_SetString(PyExc_TypeError, "predict(model, p, R, size_A, size_B, point, normal, depth) takes 8 arguments");
    return NULL;
  }
  const cc_model *model = cc_py_model_of(args[0]);
  if (model == NULL) return NULL;
  inputs in;
  if (cc_py_get_inputs(args + 1, &in) < 0) return NULL;
  Py_buffer point, normal, depth;
  int have_depth = args[7] != Py_None;
  if (cc_py_get_f64(args[5], &point, 1, "point") < 0) goto fail_in;
  if (cc_py_get_f64(args[6], &normal, 1, "normal") < 0) goto fail_point;
  if (have_depth && cc_py_get_f64(args[7], &depth, 1, "depth") < 0) goto fail_normal;
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
  cc_py_release_inputs(&in);
  return cc_py_status_tuple(status, row);
fail_all:
  if (have_depth) PyBuffer_Release(&depth);
fail_normal:
  PyBuffer_Release(&normal);
fail_point:
  PyBuffer_Release(&point);
fail_in:
  cc_py_release_inputs(&in);
  return NULL;
}

/* depth(model, p, R, size_A, size_B, out) -> (status, row) */
static PyObject *py_depth(PyObject *module, PyObject *const *args, Py_ssize_t nargs) {
  (void)module;
  if (nargs != 6) {
    PyErr_SetString(PyExc_TypeError, "depth(model, p, R, size_A, size_B, out) takes 6 arguments");
    return NULL;
  }
  const cc_model *model = cc_py_model_of(args[0]);
  if (model == NULL) return NULL;
  inputs in;
  if (cc_py_get_inputs(args + 1, &in) < 0) return NULL;
  Py_buffer out;
  if (cc_py_get_f64(args[5], &out, 1, "out") < 0) {
    cc_py_release_inputs(&in);
    return NULL;
  }
  if ((size_t)count_of(&out) != in.n) {
    PyErr_SetString(PyExc_ValueError, "out must hold n values");
    PyBuffer_Release(&out);
    cc_py_release_inputs(&in);
    return NULL;
  }
  size_t row = 0;
  int status = cc_depth(model, in.n, in.p.buf, in.R.buf, in.sA.buf, in.rows_A, in.sB.buf, in.rows_B, out.buf, &row);
  PyBuffer_Release(&out);
  cc_py_release_inputs(&in);
  return cc_py_status_tuple(status, row);
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
  if (cc_py_get_inputs(args, &in) < 0) return NULL;
  Py_buffer out;
  if (cc_py_get_f64(args[4], &out, 1, "out") < 0) {
    cc_py_release_inputs(&in);
    return NULL;
  }
  if ((size_t)count_of(&out) != in.n) {
    PyErr_SetString(PyExc_ValueError, "out must hold n values");
    PyBuffer_Release(&out);
    cc_py_release_inputs(&in);
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
  cc_py_release_inputs(&in);
  Py_RETURN_NONE;
}

/* check(supported, p, R, size_A, size_B) -> (status, row): cc_predict's input checks
 * (interface.check_numpy's, in its order) against supported (k, 3) full extents [m], for a
 * model the testbed did not ship: a status other than 0 sends the caller to check_numpy,
 * which raises the reference's error. */
static PyObject *py_check(PyObject *module, PyObject *const *args, Py_ssize_t nargs) {
  (void)module;
  if (nargs != 5 && nargs != 6) {
    PyErr_SetString(PyExc_TypeError, "check(supported, p, R, size_A, size_B[, size_range]) takes 5 or 6 arguments");
    return NULL;
  }
  double range[6];
  const double *range_at = NULL;
  if (nargs == 6 && args[5] != Py_None) {
    Py_buffer r;
    if (cc_py_get_f64(args[5], &r, 0, "size_range") < 0) return NULL;
    if (count_of(&r) != 6) {
      PyBuffer_Release(&r);
      PyErr_SetString(PyExc_ValueError, "size_range must hold 6 values (2, 3)");
      return NULL;
    }
    memcpy(range, r.buf, sizeof range);
    PyBuffer_Release(&r);
    range_at = range;
  }
  Py_buffer supported;
  if (cc_py_get_f64(args[0], &supported, 0, "supported") < 0) return NULL;
  Py_ssize_t k = count_of(&supported) / 3;
  if (k < 1 || count_of(&supported) != 3 * k) {
    PyBuffer_Release(&supported);
    PyErr_SetString(PyExc_ValueError, "supported must hold 3 k values (k >= 1)");
    return NULL;
  }
  inputs in;
  if (cc_py_get_inputs(args + 1, &in) < 0) {
    PyBuffer_Release(&supported);
    return NULL;
  }
  size_t row = 0;
  int status = cci_check_inputs(supported.buf, (int)k, range_at, in.n, in.p.buf, in.R.buf, in.sA.buf, in.rows_A, in.sB.buf,
                                in.rows_B, &row);
  cc_py_release_inputs(&in);
  PyBuffer_Release(&supported);
  return cc_py_status_tuple(status, row);
}

PyMethodDef cc_py_predict_methods[] = {
    {"predict", (PyCFunction)(void (*)(void))py_predict, METH_FASTCALL,
     "predict(model, p, R, size_A, size_B, point, normal, depth) -> (status, row): cc_predict on float64 arrays "
     "(outputs preallocated; depth may be None)."},
    {"depth", (PyCFunction)(void (*)(void))py_depth, METH_FASTCALL,
     "depth(model, p, R, size_A, size_B, out) -> (status, row): cc_depth on float64 arrays."},
    {"check", (PyCFunction)(void (*)(void))py_check, METH_FASTCALL,
     "check(supported, p, R, size_A, size_B[, size_range]) -> (status, row): cc_predict's input checks, no model"},
    {"box_depth", (PyCFunction)(void (*)(void))py_box_depth, METH_FASTCALL,
     "box_depth(p, R, size_A, size_B, out): separating-axis depth [m] of boxes of any size (no model)"},
    {NULL, NULL, 0, NULL},
};
