/* model_type.c: the Model type of learned_contact._native: a cc_model over numpy arrays, which
 * the model keeps alive and unresized for its lifetime (its views are held), and the functions
 * that make it and name it (module.c joins this file's table into the module). */
#include "predict_bindings.h"

#include "cc_internal.h" /* CCI_MAX_WIDTH */

#define MAX_VIEWS (3 + 2 * (2 + 2 * CC_MAX_LAYERS)) /* sizes, range, domain and two networks */

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
  if (cc_py_get_f64(obj, v, 0, name) < 0) return NULL;
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
  static char *keywords[] = {"kind", "supported_sizes", "main", "expert", "domain", "size_range", NULL};
  int kind;
  PyObject *supported, *main_spec, *expert_spec = Py_None, *domain = Py_None, *size_range = Py_None;
  if (!PyArg_ParseTupleAndKeywords(args, kwargs, "iOO|OOO:Model", keywords, &kind, &supported, &main_spec, &expert_spec,
                                   &domain, &size_range))
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
  if (size_range != Py_None) {
    const double *r = hold(self, size_range, "size_range", 2, 2, 3);
    if (r == NULL) goto fail;
    for (int i = 0; i < 6; ++i) m->size_range[i] = r[i];
    m->has_size_range = 1;
  }
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
    .tp_doc = "Model(kind, supported_sizes, main, expert=None, domain=None, size_range=None): a predictor for the native core over "
              "numpy arrays (kept alive by the model). kind 1 improved, 2 paper; supported_sizes (k, 3) [m]; main, "
              "expert: (x_mean, x_std, (W_0, ...), (b_0, ...), activation code 0 tanh / 1 silu / 2 relu), W_i "
              "(in, out); domain: the expert gate's 11 (or 9) bounds.",
    .tp_getset = model_getset,
    .tp_new = model_new,
};

static int ready(PyObject *type_ready) {
  (void)type_ready;
  if (ModelType.tp_flags & Py_TPFLAGS_READY) return 0;
  return PyType_Ready(&ModelType);
}

const cc_model *cc_py_model_of(PyObject *obj) {
  if (Py_TYPE(obj) != &ModelType) {
    PyErr_SetString(PyExc_TypeError, "the first argument must be a learned_contact._native.Model");
    return NULL;
  }
  return &((ModelObject *)obj)->model;
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

PyMethodDef cc_py_model_methods[] = {
    {"Model", (PyCFunction)(void (*)(void))py_model, METH_VARARGS | METH_KEYWORDS, "Model(kind, supported_sizes, main, "
     "expert=None, domain=None): a predictor for the native core (see model_type().__doc__)."},
    {"model_type", py_model_type, METH_NOARGS, "model_type() -> the Model type."},
    {NULL, NULL, 0, NULL},
};
