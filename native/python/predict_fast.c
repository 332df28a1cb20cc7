/* predict_fast.c: answer and depth_of, the predictor's fast path in learned_contact._native
 * (module.c joins this file's table into the module; what they take and return is below). */
#include "predict_bindings.h" /* first: Python.h before the standard headers */

#include "cc_internal.h"

/* numpy's C API, for the fast path only (module.c calls cc_py_predict_init, which imports it) */
#define NPY_NO_DEPRECATED_API NPY_1_22_API_VERSION
#define PY_ARRAY_UNIQUE_SYMBOL cc_py_numpy_api
#include <numpy/arrayobject.h>

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
  const cc_model *model = cc_py_model_of(args[0]);
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
  const cc_model *model = cc_py_model_of(args[0]);
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

PyMethodDef cc_py_fast_methods[] = {
    {"answer", (PyCFunction)(void (*)(void))py_answer, METH_FASTCALL,
     "answer(model, p, R, size_A, size_B, with_depth) -> (status, row, point, normal, depth, n_outside) or None: a "
     "predictor's predict in one call for float64 C-contiguous arrays of the interface's shapes (None: convert and check in "
     "Python)."},
    {"depth_of", (PyCFunction)(void (*)(void))py_depth_of, METH_FASTCALL,
     "depth_of(model, p, R, size_A, size_B) -> (status, row, depth) or None: a predictor's depth in one call (a "
     "float for a single pose)."},
    {NULL, NULL, 0, NULL},
};
