/* learned_contact._native: the CPython face of the native core (native/src). The method
 * tables live beside the code they wrap: predict_methods.c (the predictor) and
 * step_methods.c (the contact step); this file only joins them into one module. */
#define PY_SSIZE_T_CLEAN
#include <Python.h>

#include "container_contact.h"

extern PyMethodDef cc_py_predict_methods[];
extern PyMethodDef cc_py_step_methods[];
int cc_py_predict_init(void); /* numpy's C API for the predictor's fast path */

static PyModuleDef cc_module = {PyModuleDef_HEAD_INIT, "learned_contact._native",
                                "The native contact core (C11): predictor and contact step.", -1, NULL,
                                NULL, NULL, NULL, NULL};

static int add_methods(PyObject *module, PyMethodDef *table) {
  for (PyMethodDef *m = table; m->ml_name != NULL; ++m) {
    PyObject *f = PyCFunction_NewEx(m, NULL, PyModule_GetNameObject(module));
    if (f == NULL || PyModule_AddObject(module, m->ml_name, f) < 0) {
      Py_XDECREF(f);
      return -1;
    }
  }
  return 0;
}

PyMODINIT_FUNC PyInit__native(void) {
  if (cc_py_predict_init() < 0) return NULL;
  PyObject *module = PyModule_Create(&cc_module);
  if (module == NULL) return NULL;
  if (add_methods(module, cc_py_predict_methods) < 0 || add_methods(module, cc_py_step_methods) < 0 ||
      PyModule_AddIntConstant(module, "ABI_VERSION", CC_ABI_VERSION) < 0) {
    Py_DECREF(module);
    return NULL;
  }
  return module;
}
