/* testbed.geometry._pairwise: signed distances of box pairs (testbed/geometry/boxes.py,
 * pairwise_signed_distances_fast), compiled at install instead of by numba at first use.
 *
 * One call: p_W (m, 3) [m], R_W (m, 3, 3) row-major, h (m, 3) half extents [m], pairs (k, 2)
 * int64, slab (m) uint8 (1: the box is a slab whose +z face faces the others), max_distance
 * [m] -> out (k) [m] signed distances; +inf for pairs whose world axis-aligned boxes lie more
 * than max_distance apart along a world axis. Same arithmetic as the scalar-loop twin in
 * boxes.py (_pairwise_kernel), which the tests compare against the vectorised reference. */
#define PY_SSIZE_T_CLEAN
#include <Python.h>
#include <math.h>
#include <stdint.h>

static double pair_distance(const double *p_W, const double *R_W, const double *h, int64_t i, int64_t j,
                            const uint8_t *slab, double max_distance) {
  for (int a = 0; a < 3; ++a) {
    const double *Ri = R_W + 9 * i + 3 * a, *Rj = R_W + 9 * j + 3 * a;
    double e_i = fabs(Ri[0]) * h[3 * i] + fabs(Ri[1]) * h[3 * i + 1] + fabs(Ri[2]) * h[3 * i + 2];
    double e_j = fabs(Rj[0]) * h[3 * j] + fabs(Rj[1]) * h[3 * j + 1] + fabs(Rj[2]) * h[3 * j + 2];
    if (fabs(p_W[3 * j + a] - p_W[3 * i + a]) - e_i - e_j > max_distance) return INFINITY;
  }
  if (slab[j] && !slab[i]) {  /* the slab is A */
    int64_t t = i;
    i = j;
    j = t;
  }
  /* pose of B (= j) in A (= i): p = R_i^T (p_j - p_i), R = R_i^T R_j */
  double p[3] = {0.0, 0.0, 0.0}, R[3][3] = {{0.0}};
  const double *RA = R_W + 9 * i, *RB = R_W + 9 * j;
  for (int a = 0; a < 3; ++a)
    for (int b = 0; b < 3; ++b) {
      p[a] += RA[3 * b + a] * (p_W[3 * j + b] - p_W[3 * i + b]);
      for (int c = 0; c < 3; ++c) R[a][b] += RA[3 * c + a] * RB[3 * c + b];
    }
  const double *hA = h + 3 * i, *hB = h + 3 * j;
  if (slab[i] != slab[j]) {
    double d = p[2] - (fabs(R[2][0]) * hB[0] + fabs(R[2][1]) * hB[1] + fabs(R[2][2]) * hB[2]) - hA[2];
    double depth = fmax(-d, 0.0);
    double mx = hA[0] - fabs(p[0]) - (fabs(R[0][0]) * hB[0] + fabs(R[0][1]) * hB[1] + fabs(R[0][2]) * hB[2]);
    double my = hA[1] - fabs(p[1]) - (fabs(R[1][0]) * hB[0] + fabs(R[1][1]) * hB[1] + fabs(R[1][2]) * hB[2]);
    if (fmin(mx, my) >= depth && depth < hA[2]) return d;
  }
  double least = INFINITY;
  for (int a = 0; a < 3; ++a) {  /* A's face normals e_a */
    double r = hA[a] + fabs(R[a][0]) * hB[0] + fabs(R[a][1]) * hB[1] + fabs(R[a][2]) * hB[2];
    least = fmin(least, r - fabs(p[a]));
  }
  for (int b = 0; b < 3; ++b) {  /* B's face normals: column b of R */
    double r = fabs(R[0][b]) * hA[0] + fabs(R[1][b]) * hA[1] + fabs(R[2][b]) * hA[2] + hB[b];
    least = fmin(least, r - fabs(R[0][b] * p[0] + R[1][b] * p[1] + R[2][b] * p[2]));
  }
  for (int a = 0; a < 3; ++a)  /* edge axes e_a x b_c */
    for (int c = 0; c < 3; ++c) {
      double u[3] = {0.0, 0.0, 0.0};
      int a1 = (a + 1) % 3, a2 = (a + 2) % 3;
      u[a1] = -R[a2][c];
      u[a2] = R[a1][c];
      double norm = sqrt(u[a1] * u[a1] + u[a2] * u[a2]);
      if (norm <= 1e-6) continue;  /* parallel edges: no information */
      double r = (fabs(u[0]) * hA[0] + fabs(u[1]) * hA[1] + fabs(u[2]) * hA[2]) / norm;
      for (int e = 0; e < 3; ++e) r += fabs(u[0] * R[0][e] + u[1] * R[1][e] + u[2] * R[2][e]) / norm * hB[e];
      least = fmin(least, r - fabs(u[0] * p[0] + u[1] * p[1] + u[2] * p[2]) / norm);
    }
  return -least;
}

/* a C-contiguous buffer of `itemsize` bytes per item and `items` items, else a TypeError */
static int get_buffer(PyObject *obj, Py_buffer *view, const char *name, Py_ssize_t itemsize, Py_ssize_t items, int writable) {
  if (PyObject_GetBuffer(obj, view, PyBUF_C_CONTIGUOUS | (writable ? PyBUF_WRITABLE : 0)) < 0) return -1;
  if (view->itemsize != itemsize || (items >= 0 && view->len != items * itemsize)) {
    PyErr_Format(PyExc_TypeError, "%s: expected %zd items of %zd bytes, got %zd bytes", name, items, itemsize, view->len);
    PyBuffer_Release(view);
    return -1;
  }
  return 0;
}

static PyObject *signed_distances(PyObject *self, PyObject *const *args, Py_ssize_t nargs) {
  (void)self;
  if (nargs != 7) {
    PyErr_SetString(PyExc_TypeError, "signed_distances(p_W, R_W, h, pairs, slab, max_distance, out)");
    return NULL;
  }
  Py_buffer vp, vR, vh, vpairs, vslab, vout;
  if (get_buffer(args[0], &vp, "p_W", 8, -1, 0) < 0) return NULL;
  Py_ssize_t m = vp.len / 24;
  double max_distance = PyFloat_AsDouble(args[5]);
  PyObject *result = NULL;
  if (max_distance == -1.0 && PyErr_Occurred()) goto p;
  if (get_buffer(args[1], &vR, "R_W", 8, 9 * m, 0) < 0) goto p;
  if (get_buffer(args[2], &vh, "h", 8, 3 * m, 0) < 0) goto R;
  if (get_buffer(args[3], &vpairs, "pairs", 8, -1, 0) < 0) goto h;
  Py_ssize_t k = vpairs.len / 16;
  if (get_buffer(args[4], &vslab, "slab", 1, m, 0) < 0) goto pairs;
  if (get_buffer(args[6], &vout, "out", 8, k, 1) < 0) goto slab;
  const int64_t *pairs = vpairs.buf;
  double *out = vout.buf;
  for (Py_ssize_t q = 0; q < k; ++q) {
    int64_t i = pairs[2 * q], j = pairs[2 * q + 1];
    if (i < 0 || j < 0 || i >= m || j >= m) {
      PyErr_Format(PyExc_IndexError, "pairs[%zd] = (%lld, %lld): expected indices below %zd", q, (long long)i, (long long)j, m);
      goto out;
    }
    out[q] = pair_distance(vp.buf, vR.buf, vh.buf, i, j, vslab.buf, max_distance);
  }
  result = Py_None;
  Py_INCREF(result);
out:
  PyBuffer_Release(&vout);
slab:
  PyBuffer_Release(&vslab);
pairs:
  PyBuffer_Release(&vpairs);
h:
  PyBuffer_Release(&vh);
R:
  PyBuffer_Release(&vR);
p:
  PyBuffer_Release(&vp);
  return result;
}

static PyMethodDef methods[] = {
    {"signed_distances", (PyCFunction)(void (*)(void))signed_distances, METH_FASTCALL,
     "signed_distances(p_W, R_W, h, pairs, slab, max_distance, out): see the module docstring"},
    {NULL, NULL, 0, NULL}};

static PyModuleDef module = {PyModuleDef_HEAD_INIT, "testbed.geometry._pairwise",
                             "Signed distances of box pairs (native twin of boxes._pairwise_kernel).", -1, methods,
                             NULL, NULL, NULL, NULL};

PyMODINIT_FUNC PyInit__pairwise(void) { return PyModule_Create(&module); }
