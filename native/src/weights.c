/* weights.c: cc_model_load / cc_model_free, the predictor weights file reader (libc only).
 *
 * A weights file is an uncompressed zip (numpy.savez) of .npy entries; the layout is the one
 * learned_contact/predictors/base.py (save) writes and learned_contact/predictors/loading.py
 * reads, documented in docs/integrate.md. This reader:
 *   1. reads the whole file (at most MAX_FILE_BYTES, the Python loader's bound);
 *   2. reads the archive and each needed .npy header (npz.c: the zip's records and CRC-32s,
 *      the headers' dtype and shape) and checks each array's dtype and shape against the layout;
 *   3. copies every float64 into one allocation (model->storage), decoding little-endian bytes
 *      one by one, so neither the host's byte order nor the file's alignment matters.
 * Every refusal is CC_FILE_ERROR with one line in err: "weights file PATH: <entry or part>
 * <problem>; expected <what>". The model is zeroed on failure (cc_model_free on it is a no-op).
 * No static mutable state: concurrent loads from several threads are safe.
 */
#include <errno.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cc_internal.h" /* CCI_MAX_WIDTH: the widest layer cc_predict evaluates */
#include "container_contact.h"
#include "npz.h"

#define MAX_FILE_BYTES (64L * 1024L * 1024L) /* loading.py MAX_WEIGHTS_BYTES */

/* ------------------------------------------------------------------- the layout */

typedef struct loader {
  ctx c;
  archive a;
  const char *kind_name;
  int widths[2]; /* network (inputs, outputs) of the kind */
} loader;

/* Entry `name` as an npy; absent: CC_FILE_ERROR naming `expected` unless optional (then *found = 0). */
static int get(loader *L, const char *name, npy *out, int *found, const char *expected) {
  const entry *e = ccz_lookup(&L->a, name);
  if (found) *found = e != NULL;
  if (e == NULL) return found ? CC_OK : ccz_fail(&L->c, "entry '%s' is missing; expected %s", name, expected);
  return ccz_parse_npy(&L->c, e, out);
}

/* A 0-d unicode entry into dst (ASCII only). */
static int get_string(loader *L, const char *name, char *dst, size_t cap, int *found, const char *expected) {
  npy a;
  int rc = get(L, name, &a, found, expected);
  if (rc || (found && !*found)) return rc;
  if (a.type != NPY_UNICODE || a.ndim != 0)
    return ccz_fail(&L->c, "entry '%s' has dtype '%s' and %d dimensions; expected a string ('<U<n>', shape ())", name,
                a.descr, a.ndim);
  size_t n = a.itemsize / 4, j = 0;
  for (size_t i = 0; i < n; ++i) {
    uint32_t cp = u32(a.data + 4 * i);
    if (cp == 0) break; /* numpy pads with NULs */
    if (j + 1 >= cap) return ccz_fail(&L->c, "entry '%s' is longer than %zu characters; expected %s", name, cap - 1,
                                  expected);
    dst[j++] = (cp >= 0x20 && cp < 0x7f) ? (char)cp : '?';
  }
  dst[j] = '\0';
  return CC_OK;
}

static int check_f8(loader *L, const char *name, const npy *a, int ndim, const long *shape, const char *expected) {
  char got[96];
  ccz_shape_text(got, sizeof got, a);
  if (a->type != NPY_F8)
    return ccz_fail(&L->c, "entry '%s' has dtype '%s'; expected '<f8' (float64) %s", name, a->descr, expected);
  int ok = a->ndim == ndim;
  for (int i = 0; ok && i < ndim; ++i) ok = shape[i] < 0 || a->shape[i] == (size_t)shape[i];
  if (!ok) return ccz_fail(&L->c, "entry '%s' has shape %s; expected %s", name, got, expected);
  for (size_t i = 0; i < a->count; ++i)
    if (!isfinite(f64(a->data + 8 * i)))
      return ccz_fail(&L->c, "entry '%s' holds NaN or inf (element %zu); expected finite values", name, i);
  return CC_OK;
}

typedef struct mlp_arrays {
  int n_layers;
  int activation;
  npy x_mean, x_std, W[CC_MAX_LAYERS], b[CC_MAX_LAYERS];
} mlp_arrays;

static int read_mlp(loader *L, const char *prefix, mlp_arrays *m) {
  char name[64], expected[160], act[16];
  size_t plen = strlen(prefix);
  /* the number of layers: entries named <prefix>W<anything>, as loading.py counts them */
  int n = 0;
  for (size_t i = 0; i < L->a.n; ++i) {
    const entry *e = &L->a.entries[i];
    if (e->name_len > plen + 1 && memcmp(e->name, prefix, plen) == 0 && e->name[plen] == 'W') n++;
  }
  if (n == 0) {
    snprintf(name, sizeof name, "%sW0", prefix);
    return ccz_fail(&L->c, "entry '%s' is missing; expected a %s network (%sW0, %sb0, ...)", name, L->kind_name, prefix,
                prefix);
  }
  if (n > CC_MAX_LAYERS)
    return ccz_fail(&L->c, "entries '%sW*' number %d layers; expected at most %d (CC_MAX_LAYERS)", prefix, n,
                CC_MAX_LAYERS);
  m->n_layers = n;
  snprintf(expected, sizeof expected, "a %s network with %d layers", L->kind_name, n);
  snprintf(name, sizeof name, "%sactivation", prefix);
  int rc = get_string(L, name, act, sizeof act, NULL, "one of 'relu', 'silu', 'tanh'");
  if (rc) return rc;
  if (strcmp(act, "tanh") == 0) m->activation = CC_TANH;
  else if (strcmp(act, "silu") == 0) m->activation = CC_SILU;
  else if (strcmp(act, "relu") == 0) m->activation = CC_RELU;
  else return ccz_fail(&L->c, "entry '%s' is '%s'; expected one of 'relu', 'silu', 'tanh'", name, act);
  long width = L->widths[0];
  for (int i = 0; i < n; ++i) {
    char wname[64], bname[64];
    snprintf(wname, sizeof wname, "%sW%d", prefix, i);
    snprintf(bname, sizeof bname, "%sb%d", prefix, i);
    if ((rc = get(L, wname, &m->W[i], NULL, expected)) || (rc = get(L, bname, &m->b[i], NULL, expected))) return rc;
    if (m->W[i].ndim != 2 || (long)m->W[i].shape[0] != width || m->W[i].shape[1] == 0 ||
        m->W[i].shape[1] > CCI_MAX_WIDTH) {
      char got[96];
      ccz_shape_text(got, sizeof got, &m->W[i]);
      return ccz_fail(&L->c, "entry '%s' has shape %s; expected (%ld, m) with bias (m,), 1 <= m <= %d", wname, got, width,
                  CCI_MAX_WIDTH);
    }
    char want[96];
    snprintf(want, sizeof want, "(%ld, m) with bias (m,)", width);
    long shapeW[2] = {width, -1};
    if ((rc = check_f8(L, wname, &m->W[i], 2, shapeW, want))) return rc;
    width = (long)m->W[i].shape[1];
    snprintf(want, sizeof want, "(%ld,), the bias of %s", width, wname);
    if ((rc = check_f8(L, bname, &m->b[i], 1, &width, want))) return rc;
  }
  if (width != L->widths[1])
    return ccz_fail(&L->c, "entry '%sW%d' has %ld outputs; expected %d for kind '%s'", prefix, n - 1, width,
                L->widths[1], L->kind_name);
  long in = L->widths[0];
  char want[64];
  snprintf(want, sizeof want, "(%ld,)", in);
  snprintf(name, sizeof name, "%sx_mean", prefix);
  if ((rc = get(L, name, &m->x_mean, NULL, expected)) || (rc = check_f8(L, name, &m->x_mean, 1, &in, want))) return rc;
  snprintf(name, sizeof name, "%sx_std", prefix);
  if ((rc = get(L, name, &m->x_std, NULL, expected)) || (rc = check_f8(L, name, &m->x_std, 1, &in, want))) return rc;
  return CC_OK;
}

static size_t mlp_doubles(const mlp_arrays *m) {
  size_t n = m->x_mean.count + m->x_std.count;
  for (int i = 0; i < m->n_layers; ++i) n += m->W[i].count + m->b[i].count;
  return n;
}

/* Copies a's values into *at in C (row-major) order, transposing a Fortran-order matrix. */
static const double *copy_doubles(double **at, const npy *a) {
  double *dst = *at;
  if (a->fortran) {
    size_t rows = a->shape[0], cols = a->shape[1];
    for (size_t r = 0; r < rows; ++r)
      for (size_t k = 0; k < cols; ++k) dst[r * cols + k] = f64(a->data + 8 * (k * rows + r));
  } else {
    for (size_t i = 0; i < a->count; ++i) dst[i] = f64(a->data + 8 * i);
  }
  *at += a->count;
  return dst;
}

static void fill_mlp(cc_mlp *out, const mlp_arrays *m, double **at) {
  out->n_layers = m->n_layers;
  out->activation = m->activation;
  out->dims[0] = (int)m->x_mean.count;
  out->x_mean = copy_doubles(at, &m->x_mean);
  out->x_std = copy_doubles(at, &m->x_std);
  for (int i = 0; i < m->n_layers; ++i) {
    out->dims[i + 1] = (int)m->W[i].shape[1];
    out->W[i] = copy_doubles(at, &m->W[i]);
    out->b[i] = copy_doubles(at, &m->b[i]);
  }
}

static int load(loader *L, const unsigned char *buf, size_t size, cc_model *out) {
  int rc = ccz_read_archive(&L->c, buf, size, &L->a);
  if (rc) return rc;
  /* kind (files from before `kind` existed: told by their arrays, as loading.infer_kind does) */
  char kind[32];
  int found;
  if ((rc = get_string(L, "kind", kind, sizeof kind, &found, "'improved' or 'paper'"))) return rc;
  npy W0;
  int have_W0 = 0;
  if (!found) {
    if ((rc = get(L, "mlp/W0", &W0, &have_W0, NULL))) return rc;
    if (!have_W0)
      return ccz_fail(&L->c, "entry 'kind' is missing and there is no network (mlp/W0); expected a predictor weights "
                  "file");
    if (ccz_lookup(&L->a, "supported_sizes")) snprintf(kind, sizeof kind, "improved");
    else if (W0.ndim == 2 && W0.shape[0] == 6) snprintf(kind, sizeof kind, "paper");
    else return ccz_fail(&L->c, "entry 'kind' is missing and cannot be inferred; expected 'improved' or 'paper'");
  }
  if (strcmp(kind, "improved") == 0) {
    out->kind = CC_KIND_IMPROVED;
    L->widths[0] = 91;
    L->widths[1] = 6;
  } else if (strcmp(kind, "paper") == 0) {
    out->kind = CC_KIND_PAPER;
    L->widths[0] = 6;
    L->widths[1] = 4;
  } else {
    return ccz_fail(&L->c, "entry 'kind' is '%s'; expected one of 'improved', 'paper'", kind);
  }
  L->kind_name = out->kind == CC_KIND_IMPROVED ? "improved" : "paper";
  /* format_version (a legacy paper file has none: version 1) */
  npy v;
  if ((rc = get(L, "format_version", &v, &found, NULL))) return rc;
  long long version;
  if (!found) {
    if (out->kind != CC_KIND_PAPER) /* loading.py: a paper file without a version is a legacy one, version 1 */
      return ccz_fail(&L->c, "entry 'format_version' is missing; expected 1, 2 or 3");
    version = 1;
  } else {
    if (v.type != NPY_INT || v.ndim != 0)
      return ccz_fail(&L->c, "entry 'format_version' has dtype '%s' and %d dimensions; expected an integer of shape ()",
                  v.descr, v.ndim);
    uint64_t raw = 0;
    for (size_t i = 0; i < v.itemsize; ++i) raw |= (uint64_t)v.data[i] << (8 * i);
    int negative = v.is_signed && ((raw >> (8 * v.itemsize - 1)) & 1u);
    if (negative) raw = (v.itemsize < 8 ? (1ull << (8 * v.itemsize)) : 0) - raw; /* the magnitude */
    if (negative || raw < 1 || raw > 3)
      return ccz_fail(&L->c, "entry 'format_version' is %s%llu; expected 1, 2 or 3", negative ? "-" : "",
                  (unsigned long long)raw);
    version = (long long)raw;
  }
  out->format_version = (int)version;
  /* the networks */
  mlp_arrays main_net, expert_net;
  memset(&expert_net, 0, sizeof expert_net);
  if ((rc = read_mlp(L, "mlp/", &main_net))) return rc;
  int has_expert = ccz_has_prefix(&L->a, "expert/");
  npy domain;
  if (!has_expert && version >= 2)
    return ccz_fail(&L->c, "entry 'expert/W0' is missing (format_version %lld carries a resting expert); expected "
                "expert/ arrays, or format_version 1", version);
  if (has_expert) {
    if (out->kind != CC_KIND_IMPROVED)
      return ccz_fail(&L->c, "entries 'expert/*' are present in a '%s' file; expected a resting expert only in an "
                  "improved file", L->kind_name);
    if (version < 2)
      return ccz_fail(&L->c, "entry 'format_version' is %lld but the file carries a resting expert (expert/); "
                  "expected 2 or 3", version);
    long n_dom = version == 3 ? 11 : 9;
    char want[128];
    snprintf(want, sizeof want, "(%ld,) the expert gate's bounds of format_version %lld", n_dom, version);
    if ((rc = get(L, "expert/domain", &domain, NULL, want)) ||
        (rc = check_f8(L, "expert/domain", &domain, 1, &n_dom, want)))
      return rc;
    /* learned_contact.model.expert.check_domain: 0 <= inner < outer per pair, r_slab > 0 */
    for (long k = 0; k < (n_dom - 1) / 2; ++k) {
      double lo = f64(domain.data + 16 * k), hi = f64(domain.data + 16 * k + 8);
      if (!(0.0 <= lo && lo < hi))
        return ccz_fail(&L->c, "entry 'expert/domain' has bounds %ld and %ld = %.17g and %.17g; expected 0 <= in < out",
                    2 * k, 2 * k + 1, lo, hi);
    }
    double r_slab = f64(domain.data + 8 * (n_dom - 1));
    if (!(r_slab > 0.0))
      return ccz_fail(&L->c, "entry 'expert/domain' has r_slab = %.17g; expected > 0", r_slab);
    if ((rc = read_mlp(L, "expert/", &expert_net))) return rc;
  }
  /* supported sizes */
  npy sizes;
  if ((rc = get(L, "supported_sizes", &sizes, &found, NULL))) return rc;
  if (!found)
    return ccz_fail(&L->c, "entry 'supported_sizes' is missing; expected (k, 3) full extents [m] (a legacy paper file: "
                "load and re-save it with learned_contact)");
  long shape_sizes[2] = {-1, 3};
  if ((rc = check_f8(L, "supported_sizes", &sizes, 2, shape_sizes, "(k, 3) finite full extents [m]"))) return rc;
  if (sizes.shape[0] == 0 || sizes.shape[0] > 1u << 20)
    return ccz_fail(&L->c, "entry 'supported_sizes' has %zu rows; expected (k, 3) with k >= 1", sizes.shape[0]);
  /* the size range (optional): any box inside it answers too */
  npy range;
  int has_range = 0;
  if ((rc = get(L, "size_range", &range, &has_range, NULL))) return rc;
  if (has_range) {
    long shape_range[2] = {2, 3};
    if ((rc = check_f8(L, "size_range", &range, 2, shape_range, "(2, 3) lowest and highest full extents [m]"))) return rc;
    for (int c = 0; c < 3; ++c) {
      double lo = f64(range.data + 8 * c), hi = f64(range.data + 8 * (3 + c));
      if (!(lo > 0.0 && lo <= hi && isfinite(hi)))
        return ccz_fail(&L->c, "entry 'size_range' axis %d is %.17g to %.17g; expected 0 < lowest <= highest, finite", c,
                        lo, hi);
      out->size_range[c] = lo;
      out->size_range[3 + c] = hi;
    }
    out->has_size_range = 1;
  }
  /* one allocation for every array */
  size_t total = sizes.count + mlp_doubles(&main_net) + (has_expert ? mlp_doubles(&expert_net) : 0);
  double *storage = malloc(total * sizeof(double));
  if (storage == NULL) return ccz_fail(&L->c, "out of memory for %zu weights", total);
  double *at = storage;
  out->n_sizes = (int)sizes.shape[0];
  out->supported_sizes = copy_doubles(&at, &sizes);
  fill_mlp(&out->main, &main_net, &at);
  out->has_expert = has_expert;
  if (has_expert) {
    fill_mlp(&out->expert, &expert_net, &at);
    out->n_domain = (int)domain.count;
    for (size_t i = 0; i < domain.count; ++i) out->domain[i] = f64(domain.data + 8 * i);
  }
  out->storage = storage;
  return CC_OK;
}

/* ---------------------------------------------------------------------- the API */

/* Why fopen or fread failed, for the common causes: strerror's text is not promised to be
 * thread-safe (C11 7.24.6.2), and a load must be safe from several threads. */
static const char *reason(int e) {
  switch (e) {
#ifdef ENOENT
    case ENOENT: return "no such file or directory";
#endif
#ifdef EACCES
    case EACCES: return "permission denied";
#endif
#ifdef EISDIR
    case EISDIR: return "is a directory";
#endif
#ifdef ENOTDIR
    case ENOTDIR: return "a component of the path is not a directory";
#endif
#ifdef ENAMETOOLONG
    case ENAMETOOLONG: return "file name too long";
#endif
#ifdef ELOOP
    case ELOOP: return "too many symbolic links";
#endif
#ifdef EIO
    case EIO: return "input/output error";
#endif
    case 0: return "unknown error";
    default: return "system error";
  }
}

int cc_model_load(const char *path, cc_model *out, char *err, size_t err_len) {
  ctx c = {path, err, err_len};
  if (err && err_len) err[0] = '\0';
  if (out == NULL) return ccz_fail(&c, "no model to fill (a null cc_model pointer); expected a cc_model to load into");
  memset(out, 0, sizeof *out);
  if (path == NULL) return ccz_fail(&c, "a null path; expected the path of a weights file (.npz)");
  errno = 0;
  FILE *f = fopen(path, "rb");
  if (f == NULL)
    return ccz_fail(&c, "cannot be opened (%s); expected a predictor weights file (.npz)",
                reason(errno));
  /* read to the end, growing the buffer, at most one byte past the bound (a file that grows
   * while it is read is refused too); no stat(): fopen and fread are all C11 offers */
  size_t cap = 256 * 1024, size = 0;
  unsigned char *buf = NULL;
  int read_error = 0, saved = 0, no_memory = 0;
  for (;;) {
    unsigned char *grown = realloc(buf, cap);
    if (grown == NULL) {
      no_memory = 1;
      break;
    }
    buf = grown;
    size += fread(buf + size, 1, cap - size, f);
    if (size < cap) {
      read_error = ferror(f);
      saved = errno;
      break;
    }
    if (size > (size_t)MAX_FILE_BYTES) break;
    cap = cap * 2 > (size_t)MAX_FILE_BYTES + 1 ? (size_t)MAX_FILE_BYTES + 1 : cap * 2;
  }
  fclose(f);
  int rc;
  if (no_memory) {
    rc = ccz_fail(&c, "out of memory reading it (%zu bytes so far); expected memory for the file", size);
  } else if (read_error) {
    rc = ccz_fail(&c, "cannot be read (%s); expected a regular file", reason(saved));
  } else if (size > (size_t)MAX_FILE_BYTES) {
    rc = ccz_fail(&c, "is larger than %ld bytes; expected a weights file of at most 64 MiB", MAX_FILE_BYTES);
  } else {
    loader L;
    memset(&L, 0, sizeof L);
    L.c = c;
    rc = load(&L, buf, size, out);
    free(L.a.entries);
  }
  free(buf);
  if (rc != CC_OK) {
    free(out->storage);
    memset(out, 0, sizeof *out);
  }
  return rc;
}

void cc_model_free(cc_model *model) {
  if (model == NULL) return;
  free(model->storage);
  memset(model, 0, sizeof *model);
}
