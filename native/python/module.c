/* learned_contact._native: the CPython face of the native core (native/src). The method
 * tables live beside the code they wrap: model_type.c (the Model type), predict_methods.c (the
 * predictor's checked calls), predict_fast.c (its fast path), core_probes.c (what the tests
 * and the benchmark ask of the core), step_methods.c (the contact step), step_sleep_methods.c
 * (its sleeping islands) and host_methods.c (the hosts' arrays); this file only joins them
 * into one module. */
#define PY_SSIZE_T_CLEAN
#include <Python.h>

#include "container_contact.h"

extern PyMethodDef cc_py_model_methods[];
extern PyMethodDef cc_py_predict_methods[];
extern PyMethodDef cc_py_fast_methods[];
extern PyMethodDef cc_py_probe_methods[];
extern PyMethodDef cc_py_step_methods[];
extern PyMethodDef cc_py_step_sleep_methods[];
extern PyMethodDef cc_py_host_methods[];
int cc_py_predict_init(void); /* numpy's C API for the predictor's fast path */

static PyModuleDef cc_module = {PyModuleDef_HEAD_INIT, "learned_contact._native",
                                "The native contact core (C11): predictor and contact step.", -1, NULL,
                                NULL, NULL, NULL, NULL};

static int add_methods(PyObject *module, PyMethodDef *table) {
  PyObject *name = PyModule_GetNameObject(module); /* a new reference; each function takes its own */
  if (name == NULL) return -1;
  for (PyMethodDef *m = table; m->ml_name != NULL; ++m) {
    PyObject *f = PyCFunction_NewEx(m, NULL, name);
    if (f == NULL || PyModule_AddObject(module, m->ml_name, f) < 0) {
      Py_XDECREF(f);
      Py_DECREF(name);
      return -1;
    }
  }
  Py_DECREF(name);
  return 0;
}

PyMODINIT_FUNC PyInit__native(void) {
  if (cc_py_predict_init() < 0) return NULL;
  PyObject *module = PyModule_Create(&cc_module);
  if (module == NULL) return NULL;
  PyMethodDef *tables[] = {cc_py_model_methods, cc_py_predict_methods, cc_py_fast_methods, cc_py_probe_methods,
                           cc_py_step_methods, cc_py_step_sleep_methods, cc_py_host_methods};
  int failed = 0;
  for (size_t i = 0; i < sizeof tables / sizeof tables[0] && !failed; ++i) failed = add_methods(module, tables[i]) < 0;
  if (failed ||
      PyModule_AddIntConstant(module, "ABI_VERSION", CC_ABI_VERSION) < 0 ||
      PyModule_AddIntConstant(module, "LIBRARY_ABI_VERSION", cc_abi_version()) < 0) {
    Py_DECREF(module);
    return NULL;
  }
  return module;
}
