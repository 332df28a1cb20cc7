/* load_dump: the test driver of native/src/weights.c and npz.c (tests/native/test_integrator_kit.py).
 *
 *   load_dump WEIGHTS OUT.bin
 *       Loads WEIGHTS with cc_model_load. On success prints the model's integers on stdout (one
 *       "key value..." line each) and writes every float64 it holds to OUT.bin in this order:
 *       supported_sizes, size_range (if any), main (x_mean, x_std, W0, b0, W1, b1, ...), expert (same order, if
 *       any), domain (if any); exit 0. On failure prints the error line on stderr, exit 2.
 *   load_dump --fuzz WEIGHTS STRIDE SCRATCH
 *       For every STRIDE-th byte offset k of WEIGHTS: the file cut to k bytes, the byte at k
 *       inverted, and the byte at k replaced by a value that varies with k, each written to
 *       SCRATCH and loaded. Each must either be refused (CC_FILE_ERROR, a model left zeroed,
 *       one line starting "weights file SCRATCH: ") or load exactly the original model (a byte
 *       the format does not read: a zip timestamp, a local header's copy of a size). Prints
 *       the counts; exit 0 when every case held, 1 otherwise (each failure printed). */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "container_contact.h"

/* ------------------------------------------------------------------ a model as bytes */

typedef struct flat {
  unsigned char *bytes;
  size_t n, cap;
} flat;

static void add(flat *f, const void *p, size_t n) {
  if (f->n + n > f->cap) {
    size_t cap = f->cap ? f->cap : 4096;
    while (cap < f->n + n) cap *= 2;
    unsigned char *grown = realloc(f->bytes, cap);
    if (grown == NULL) abort();
    f->bytes = grown;
    f->cap = cap;
  }
  memcpy(f->bytes + f->n, p, n);
  f->n += n;
}

static void add_mlp(flat *f, const cc_mlp *m) {
  add(f, &m->n_layers, sizeof m->n_layers);
  add(f, &m->activation, sizeof m->activation);
  add(f, m->dims, sizeof(int) * (size_t)(m->n_layers + 1));
  add(f, m->x_mean, sizeof(double) * (size_t)m->dims[0]);
  add(f, m->x_std, sizeof(double) * (size_t)m->dims[0]);
  for (int i = 0; i < m->n_layers; ++i) {
    add(f, m->W[i], sizeof(double) * (size_t)m->dims[i] * (size_t)m->dims[i + 1]);
    add(f, m->b[i], sizeof(double) * (size_t)m->dims[i + 1]);
  }
}

/* Every field a predictor reads, in a fixed order (pointers replaced by what they point at). */
static flat flatten(const cc_model *m) {
  flat f = {NULL, 0, 0};
  int ints[6] = {m->kind, m->format_version, m->n_sizes, m->has_expert, m->n_domain, m->has_size_range};
  add(&f, ints, sizeof ints);
  add(&f, m->supported_sizes, sizeof(double) * 3 * (size_t)m->n_sizes);
  if (m->has_size_range) add(&f, m->size_range, sizeof m->size_range);
  add_mlp(&f, &m->main);
  if (m->has_expert) {
    add_mlp(&f, &m->expert);
    add(&f, m->domain, sizeof(double) * (size_t)m->n_domain);
  }
  return f;
}

/* ------------------------------------------------------------------------ dump mode */

static int put(FILE *f, const double *a, size_t n) { return fwrite(a, sizeof(double), n, f) == n; }

static int put_mlp(FILE *f, const char *name, const cc_mlp *m) {
  printf("%s layers %d activation %d dims", name, m->n_layers, m->activation);
  for (int i = 0; i <= m->n_layers; ++i) printf(" %d", m->dims[i]);
  printf("\n");
  int ok = put(f, m->x_mean, (size_t)m->dims[0]) && put(f, m->x_std, (size_t)m->dims[0]);
  for (int i = 0; i < m->n_layers; ++i)
    ok = ok && put(f, m->W[i], (size_t)m->dims[i] * (size_t)m->dims[i + 1]) && put(f, m->b[i], (size_t)m->dims[i + 1]);
  return ok;
}

static int dump(const char *weights, const char *out) {
  cc_model model;
  char err[1024];
  if (cc_model_load(weights, &model, err, sizeof err) != CC_OK) {
    fprintf(stderr, "%s\n", err);
    return 2;
  }
  FILE *f = fopen(out, "wb");
  if (f == NULL) {
    cc_model_free(&model);
    return 1;
  }
  printf("kind %d\nformat_version %d\nn_sizes %d\nhas_expert %d\nn_domain %d\nhas_size_range %d\n", model.kind,
         model.format_version, model.n_sizes, model.has_expert, model.n_domain, model.has_size_range);
  int ok = put(f, model.supported_sizes, 3 * (size_t)model.n_sizes);
  if (model.has_size_range) ok = ok && put(f, model.size_range, 6);
  ok = ok && put_mlp(f, "main", &model.main);
  if (model.has_expert) ok = ok && put_mlp(f, "expert", &model.expert) && put(f, model.domain, (size_t)model.n_domain);
  ok = (fclose(f) == 0) && ok;
  cc_model_free(&model);
  cc_model_free(&model); /* a second free of a freed (zeroed) model is a no-op */
  return ok ? 0 : 1;
}

/* ------------------------------------------------------------------------ fuzz mode */

typedef struct tally {
  size_t refused, same, bad;
} tally;

static void attempt(const unsigned char *bytes, size_t n, const char *scratch, const flat *original, tally *t,
                    const char *what, size_t k) {
  FILE *f = fopen(scratch, "wb");
  if (f == NULL || fwrite(bytes, 1, n, f) != n || fclose(f) != 0) {
    printf("cannot write %s\n", scratch);
    t->bad++;
    return;
  }
  cc_model m;
  memset(&m, 0xAB, sizeof m); /* the loader must overwrite it either way */
  char err[1024];
  memset(err, 'x', sizeof err);
  char prefix[600];
  snprintf(prefix, sizeof prefix, "weights file %s: ", scratch);
  int rc = cc_model_load(scratch, &m, err, sizeof err);
  if (rc == CC_OK) {
    flat got = flatten(&m);
    int same = got.n == original->n && memcmp(got.bytes, original->bytes, got.n) == 0;
    free(got.bytes);
    cc_model_free(&m);
    if (same) {
      t->same++;
    } else {
      printf("%s at %zu: loaded a different model\n", what, k);
      t->bad++;
    }
    return;
  }
  cc_model zero;
  memset(&zero, 0, sizeof zero);
  if (rc != CC_FILE_ERROR || memchr(err, '\0', sizeof err) == NULL || strchr(err, '\n') != NULL ||
      strncmp(err, prefix, strlen(prefix)) != 0 || memcmp(&m, &zero, sizeof m) != 0) {
    printf("%s at %zu: status %d, message \"%.300s\"\n", what, k, rc,
           memchr(err, '\0', sizeof err) ? err : "(not terminated)");
    t->bad++;
    return;
  }
  t->refused++;
}

static int fuzz(const char *weights, size_t stride, const char *scratch) {
  FILE *f = fopen(weights, "rb");
  if (f == NULL) return 1;
  fseek(f, 0, SEEK_END);
  long size = ftell(f);
  rewind(f);
  unsigned char *bytes = malloc((size_t)size), *copy = malloc((size_t)size);
  if (bytes == NULL || copy == NULL || fread(bytes, 1, (size_t)size, f) != (size_t)size) return 1;
  fclose(f);
  cc_model m;
  char err[1024];
  if (cc_model_load(weights, &m, err, sizeof err) != CC_OK) {
    printf("the original does not load: %s\n", err);
    return 1;
  }
  flat original = flatten(&m);
  cc_model_free(&m);
  tally cut = {0, 0, 0}, flip = {0, 0, 0}, set = {0, 0, 0};
  size_t offsets = 0;
  for (size_t k = 0; k < (size_t)size; k += stride, ++offsets) {
    attempt(bytes, k, scratch, &original, &cut, "cut", k);
    memcpy(copy, bytes, (size_t)size);
    copy[k] ^= 0xFF;
    attempt(copy, (size_t)size, scratch, &original, &flip, "inverted byte", k);
    memcpy(copy, bytes, (size_t)size);
    copy[k] = (unsigned char)(k * 37u + 11u);
    if (copy[k] != bytes[k]) attempt(copy, (size_t)size, scratch, &original, &set, "replaced byte", k);
  }
  printf("offsets %zu\ncut refused %zu same %zu bad %zu\ninverted refused %zu same %zu bad %zu\n"
         "replaced refused %zu same %zu bad %zu\n",
         offsets, cut.refused, cut.same, cut.bad, flip.refused, flip.same, flip.bad, set.refused, set.same, set.bad);
  free(original.bytes);
  free(bytes);
  free(copy);
  return cut.bad + flip.bad + set.bad ? 1 : 0;
}

int main(int argc, char **argv) {
  if (argc == 5 && strcmp(argv[1], "--fuzz") == 0) {
    size_t stride = (size_t)strtoul(argv[3], NULL, 10);
    return fuzz(argv[2], stride ? stride : 1, argv[4]);
  }
  if (argc == 3) return dump(argv[1], argv[2]);
  fprintf(stderr, "usage: load_dump WEIGHTS OUT.bin | load_dump --fuzz WEIGHTS STRIDE SCRATCH\n");
  return 64;
}
