/* predict_bindings.h: what the predictor's binding files share (not installed): float64 views
 * through the buffer protocol, the (p, R, size_A, size_B) inputs of the checked calls, the
 * cc_model inside a Model, the (status, row) answer. Files: model_type.c (the Model type),
 * predict_methods.c (the checked calls), predict_fast.c (the fast path), core_probes.c (what
 * the tests and the benchmark ask of the core); module.c joins their tables. */
#ifndef CC_PREDICT_BINDINGS_H
#define CC_PREDICT_BINDINGS_H

#define PY_SSIZE_T_CLEAN
#include <Python.h>

#include "container_contact.h"

/* A float64 C-contiguous view of obj (writable when asked); -1 with a Python error else. */
int cc_py_get_f64(PyObject *obj, Py_buffer *view, int writable, const char *name);

/* The number of float64 values in a view. */
static inline Py_ssize_t count_of(const Py_buffer *v) { return v->len / 8; }

/* The inputs of predict and depth: args[0] the model, args[1..4] p, R, size_A, size_B. */
typedef struct {
  Py_buffer p, R, sA, sB;
  int held;
  size_t n, rows_A, rows_B;
} inputs;

/* Views of args[0..3] (p, R, size_A, size_B) with their counts checked; -1 with a Python error else. */
int cc_py_get_inputs(PyObject *const *args, inputs *in);
void cc_py_release_inputs(inputs *in);

/* The cc_model inside a learned_contact._native.Model (model_type.c); NULL with a TypeError else. */
const cc_model *cc_py_model_of(PyObject *obj);

/* (status, row) */
PyObject *cc_py_status_tuple(int status, size_t row);

#endif
