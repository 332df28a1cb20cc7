/* step_bindings.h: what the contact step's binding files share (not installed): the buffers of
 * one call, the step's capsule, the error of a status, the argument-count check. Files:
 * step_buffers.c (buffers), step_methods.c (the step: create, parameters, candidates, the law,
 * the held state), step_sleep_methods.c (sleeping), host_methods.c (the hosts' arrays);
 * module.c joins their tables.
 *
 * Every array goes through the buffer protocol (numpy arrays, MuJoCo's data arrays): C-
 * contiguous, float64 ('d'), int64 ('q' / 'l' of 8 bytes) or bool / uint8 (1 byte), with
 * exactly the element count the call expects; outputs are written in place. A step is a
 * capsule owning a cc_step; one thread at a time per step (the GIL is held throughout). */
#ifndef CC_STEP_BINDINGS_H
#define CC_STEP_BINDINGS_H

#define PY_SSIZE_T_CLEAN
#include <Python.h>

#include "container_contact_step.h"

#define STEP_CAPSULE "learned_contact._native.step"
#define MAX_BUFFERS 16

typedef struct {
  Py_buffer view[MAX_BUFFERS];
  int n;
} buffers;

/* Releases every view b holds. */
void cc_py_release(buffers *b);
/* *out = the data of obj (a C-contiguous buffer of kind 'd', 'q' or 'b' with `count` elements;
 * count < 0: any, its count written to *got). None is allowed when *out may stay NULL
 * (nullable). -1 with a Python error else; b holds the view either way. */
int cc_py_take(buffers *b, PyObject *obj, const char *name, char kind, Py_ssize_t count, int writable, int nullable,
               void **out, Py_ssize_t *got);
/* The cc_step of a step capsule; NULL with a Python error else. */
cc_step *cc_py_step_of(PyObject *capsule);
/* Sets the Python error of a cc_status other than CC_OK (what: the call); returns -1. */
int cc_py_status_error(int status, const char *what);

static inline Py_ssize_t n_bodies(const cc_step *s) { return (Py_ssize_t)cc_step_n_bodies(s); }

#define ARGS(n, sig)                                                                           \
  if (nargs != (n)) {                                                                          \
    PyErr_Format(PyExc_TypeError, "%s expects %d arguments (%s), got %zd", __func__ + 3, (n), sig, nargs); \
    return NULL;                                                                               \
  }

#define FAST(name, doc) {#name, (PyCFunction)(void (*)(void))py_##name, METH_FASTCALL, doc}

#endif
