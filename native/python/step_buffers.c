/* step_buffers.c: the buffers of one call to the step's bindings, the step's capsule and the
 * error of a status (step_bindings.h). */
#include "step_bindings.h" /* first: Python.h before the standard headers */

void cc_py_release(buffers *b) {
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
int cc_py_take(buffers *b, PyObject *obj, const char *name, char kind, Py_ssize_t count, int writable, int nullable,
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

cc_step *cc_py_step_of(PyObject *capsule) {
  return (cc_step *)PyCapsule_GetPointer(capsule, STEP_CAPSULE);
}

int cc_py_status_error(int status, const char *what) {
  if (status == CC_STEP_NO_MEMORY) {
    PyErr_NoMemory();
  } else {
    PyErr_Format(PyExc_ValueError, "%s: status %d (%s)", what, status,
                 status == CC_BAD_ARGUMENT ? "a bad argument" : "see container_contact.h's enum cc_status");
  }
  return -1;
}
