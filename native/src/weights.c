/* weights.c: cc_model_load / cc_model_free, the predictor weights file reader (libc only).
 *
 * A weights file is an uncompressed zip (numpy.savez) of .npy entries; the layout is the one
 * learned_contact/predictors/base.py (save) writes and learned_contact/predictors/loading.py
 * reads, documented in docs/integrate.md. This reader:
 *   1. reads the whole file (at most MAX_FILE_BYTES, the Python loader's bound);
 *   2. finds the zip's end-of-central-directory record (and its zip64 form), walks the central
 *      directory, and for each entry checks its local file header (same name, method 0 =
 *      stored), the data's bounds and its CRC-32 (as Python's zipfile does on reading);
 *   3. parses each needed .npy header (versions 1, 2, 3; a Python dict literal with descr,
 *      fortran_order and shape) and checks its dtype and shape against the layout;
 *   4. copies every float64 into one allocation (model->storage), decoding little-endian bytes
 *      one by one, so neither the host's byte order nor the file's alignment matters.
 * Every refusal is CC_FILE_ERROR with one line in err: "weights file PATH: <entry or part>
 * <problem>; expected <what>". The model is zeroed on failure (cc_model_free on it is a no-op).
 * No static mutable state: concurrent loads from several threads are safe.
 */
#include <errno.h>
#include <math.h>
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cc_internal.h" /* CCI_MAX_WIDTH: the widest layer cc_predict evaluates */
#include "container_contact.h"

#define MAX_FILE_BYTES (64L * 1024L * 1024L) /* loading.py MAX_WEIGHTS_BYTES */
#define MAX_NAME 256                         /* longest entry name we report or match */
#define MAX_NDIM 8

/* --------------------------------------------------------------------- errors */

typedef struct ctx {
  const char *path;
  char *err;
  size_t err_len;
} ctx;

/* Copies s into dst (capacity cap) with control characters and non-ASCII bytes as '?', so the
 * message stays one printable line whatever the path or an entry name holds. */
static void sanitize(char *dst, size_t cap, const char *s, size_t n) {
  size_t j = 0;
  for (size_t i = 0; i < n && s[i] != '\0' && j + 1 < cap; ++i) {
    unsigned char c = (unsigned char)s[i];
    dst[j++] = (c < 0x20 || c >= 0x7f) ? '?' : (char)c;
  }
  if (cap) dst[j] = '\0';
}

static int fail(const ctx *c, const char *fmt, ...) {
  if (c->err == NULL || c->err_len == 0) return CC_FILE_ERROR;
  char path[512], body[768];
  sanitize(path, sizeof path, c->path ? c->path : "(null)", (size_t)-1);
  va_list ap;
  va_start(ap, fmt);
  vsnprintf(body, sizeof body, fmt, ap);
  va_end(ap);
  char line[1400];
  snprintf(line, sizeof line, "weights file %s: %s", path, body);
  sanitize(c->err, c->err_len, line, sizeof line);
  return CC_FILE_ERROR;
}

/* ------------------------------------------------------------ little-endian reads */

static uint32_t u16(const unsigned char *p) { return (uint32_t)p[0] | (uint32_t)p[1] << 8; }
static uint32_t u32(const unsigned char *p) {
  return (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 | (uint32_t)p[3] << 24;
}
static uint64_t u64(const unsigned char *p) { return (uint64_t)u32(p) | (uint64_t)u32(p + 4) << 32; }
static double f64(const unsigned char *p) {
  uint64_t bits = u64(p);
  double d;
  memcpy(&d, &bits, sizeof d); /* IEEE 754 binary64 with the host's integer byte order */
  return d;
}

/* CRC-32 (ISO-HDLC, zip's), with a table built per call: no shared state between threads. */
static uint32_t crc32_of(const unsigned char *p, size_t n) {
  uint32_t table[256];
  for (uint32_t i = 0; i < 256; ++i) {
    uint32_t c = i;
    for (int k = 0; k < 8; ++k) c = (c & 1u) ? 0xEDB88320u ^ (c >> 1) : c >> 1;
    table[i] = c;
  }
  uint32_t crc = 0xFFFFFFFFu;
  for (size_t i = 0; i < n; ++i) crc = table[(crc ^ p[i]) & 0xFFu] ^ (crc >> 8);
  return crc ^ 0xFFFFFFFFu;
}

/* ----------------------------------------------------------------------- the zip */

typedef struct entry {
  const char *name; /* in the file buffer, not NUL-terminated */
  size_t name_len;
  const unsigned char *data; /* the .npy bytes */
  size_t size;
} entry;

typedef struct archive {
  entry *entries;
  size_t n;
} archive;

/* The entry's name for messages: "mlp/W0.npy" -> "mlp/W0.npy" (sanitised, truncated). */
static void entry_label(char *dst, size_t cap, const entry *e) { sanitize(dst, cap, e->name, e->name_len); }

static int find_eocd(const ctx *c, const unsigned char *buf, size_t size, size_t *at) {
  if (size < 22) return fail(c, "is %zu bytes, too short for a zip; expected an .npz written by numpy.savez", size);
  size_t lowest = size > 22 + 65535 ? size - 22 - 65535 : 0;
  for (size_t i = size - 22 + 1; i-- > lowest;) {
    if (u32(buf + i) == 0x06054b50u && i + 22 + u16(buf + i + 20) == size) {
      *at = i;
      return CC_OK;
    }
  }
  return fail(c, "no zip end-of-central-directory record; expected an .npz written by numpy.savez");
}

/* Fills a with the entries of the zip in buf (borrowing buf). */
static int read_archive(const ctx *c, const unsigned char *buf, size_t size, archive *a) {
  size_t eocd = 0;
  int rc = find_eocd(c, buf, size, &eocd);
  if (rc) return rc;
  const unsigned char *e = buf + eocd;
  uint64_t n_entries = u16(e + 10), cd_size = u32(e + 12), cd_offset = u32(e + 16);
  if (u16(e + 4) != 0 || u16(e + 6) != 0 || u16(e + 8) != u16(e + 10))
    return fail(c, "zip end record names several disks; expected a single-file .npz");
  size_t cd_end_limit = eocd;
  if (eocd >= 20 && u32(buf + eocd - 20) == 0x07064b50u) { /* zip64 end-of-central-directory locator */
    uint64_t z = u64(buf + eocd - 20 + 8);
    if (z > eocd - 20 || eocd - 20 - z < 56 || u32(buf + z) != 0x06064b50u)
      return fail(c, "zip64 end record locator points outside the file; expected a zip64 end record before it");
    const unsigned char *z64 = buf + z;
    if (u32(z64 + 16) != 0 || u32(z64 + 20) != 0 || u64(z64 + 24) != u64(z64 + 32))
      return fail(c, "zip64 end record names several disks; expected a single-file .npz");
    n_entries = u64(z64 + 32);
    cd_size = u64(z64 + 40);
    cd_offset = u64(z64 + 48);
    cd_end_limit = (size_t)z;
  } else if (n_entries == 0xFFFFu || cd_size == 0xFFFFFFFFu || cd_offset == 0xFFFFFFFFu) {
    return fail(c, "zip end record defers to a zip64 record that is missing; expected a zip64 locator");
  }
  if (cd_offset > cd_end_limit || cd_size > cd_end_limit - cd_offset)
    return fail(c, "zip central directory (offset %llu, %llu bytes) lies outside the file; expected it before "
                "the end record", (unsigned long long)cd_offset, (unsigned long long)cd_size);
  if (n_entries == 0) return fail(c, "zip holds no entries; expected the arrays of a predictor weights file");
  if (n_entries > cd_size / 46)
    return fail(c, "zip end record counts %llu entries in a %llu-byte central directory; expected at most %llu",
                (unsigned long long)n_entries, (unsigned long long)cd_size, (unsigned long long)(cd_size / 46));
  a->entries = calloc((size_t)n_entries, sizeof(entry));
  if (a->entries == NULL) return fail(c, "out of memory for %llu zip entries", (unsigned long long)n_entries);
  a->n = 0;
  const unsigned char *p = buf + cd_offset, *end = buf + cd_offset + cd_size;
  for (uint64_t k = 0; k < n_entries; ++k) {
    if ((size_t)(end - p) < 46 || u32(p) != 0x02014b50u)
      return fail(c, "zip central directory entry %llu is truncated or has a bad signature; expected %llu "
                  "entries", (unsigned long long)k, (unsigned long long)n_entries);
    uint32_t flags = u16(p + 8), method = u16(p + 10), crc = u32(p + 16);
    uint64_t csize = u32(p + 20), usize = u32(p + 24), offset = u32(p + 42);
    size_t name_len = u16(p + 28), extra_len = u16(p + 30), comment_len = u16(p + 32);
    uint32_t disk = u16(p + 34);
    if ((size_t)(end - p) - 46 < name_len + extra_len + comment_len)
      return fail(c, "zip central directory entry %llu runs past the directory; expected %zu bytes of name, "
                  "extra and comment", (unsigned long long)k, name_len + extra_len + comment_len);
    entry *en = &a->entries[a->n];
    en->name = (const char *)p + 46;
    en->name_len = name_len;
    char label[MAX_NAME];
    entry_label(label, sizeof label, en);
    /* zip64 extra field: the 0xFFFFFFFF fields, in the order usize, csize, offset, disk */
    const unsigned char *x = p + 46 + name_len, *x_end = x + extra_len;
    while (x_end - x >= 4) {
      uint32_t id = u16(x), len = u16(x + 2);
      if ((size_t)(x_end - x) - 4 < len) break;
      if (id == 0x0001) {
        const unsigned char *f = x + 4, *f_end = x + 4 + len;
        uint64_t *want[3] = {&usize, &csize, &offset};
        uint64_t sentinel = 0xFFFFFFFFu;
        for (int i = 0; i < 3; ++i) {
          if (*want[i] != sentinel) continue;
          if (f_end - f < 8)
            return fail(c, "entry '%s': zip64 extra field is short; expected 8 bytes per deferred size or offset",
                        label);
          *want[i] = u64(f);
          f += 8;
        }
      }
      x += 4 + len;
    }
    if (disk != 0 && disk != 0xFFFFu)
      return fail(c, "entry '%s' lies on disk %u; expected a single-file .npz", label, disk);
    if (flags & 0x1u) return fail(c, "entry '%s' is encrypted; expected a plain numpy.savez file", label);
    if (method != 0)
      return fail(c, "compressed entry '%s' (zip method %u): save with numpy.savez, not savez_compressed", label,
                  method);
    if (csize != usize)
      return fail(c, "entry '%s' is stored (method 0) with %llu bytes in and %llu out; expected equal sizes", label,
                  (unsigned long long)csize, (unsigned long long)usize);
    /* the local file header: same name, stored, followed by the data */
    if (offset > size || size - offset < 30 || u32(buf + offset) != 0x04034b50u)
      return fail(c, "entry '%s': no local file header at offset %llu; expected one (signature PK\\3\\4)", label,
                  (unsigned long long)offset);
    const unsigned char *l = buf + offset;
    size_t l_name = u16(l + 26), l_extra = u16(l + 28);
    if (u16(l + 8) != 0)
      return fail(c, "compressed entry '%s' (zip method %u in its local header): save with numpy.savez, not "
                  "savez_compressed", label, u16(l + 8));
    if (l_name != name_len || memcmp(l + 30, en->name, name_len) != 0)
      return fail(c, "entry '%s': its local file header names another entry; expected the same name", label);
    uint64_t data_at = offset + 30 + l_name + l_extra;
    if (data_at > size || size - data_at < usize)
      return fail(c, "entry '%s' (%llu bytes at offset %llu) runs past the end of the file (%zu bytes); expected "
                  "the whole entry", label, (unsigned long long)usize, (unsigned long long)data_at, size);
    en->data = buf + data_at;
    en->size = (size_t)usize;
    if (crc32_of(en->data, en->size) != crc)
      return fail(c, "entry '%s' fails its CRC-32 check (the file is corrupt); expected CRC %08x", label, crc);
    for (size_t i = 0; i < a->n; ++i)
      if (a->entries[i].name_len == name_len && memcmp(a->entries[i].name, en->name, name_len) == 0)
        return fail(c, "entry '%s' appears twice; expected each array once", label);
    a->n++;
    p += 46 + name_len + extra_len + comment_len;
  }
  return CC_OK;
}

/* The entry named `name` + ".npy", or NULL. */
static const entry *lookup(const archive *a, const char *name) {
  size_t n = strlen(name);
  for (size_t i = 0; i < a->n; ++i) {
    const entry *e = &a->entries[i];
    if (e->name_len == n + 4 && memcmp(e->name, name, n) == 0 && memcmp(e->name + n, ".npy", 4) == 0) return e;
  }
  return NULL;
}

static int has_prefix(const archive *a, const char *prefix) {
  size_t n = strlen(prefix);
  for (size_t i = 0; i < a->n; ++i)
    if (a->entries[i].name_len >= n && memcmp(a->entries[i].name, prefix, n) == 0) return 1;
  return 0;
}

/* ------------------------------------------------------------------------ .npy */

enum npy_type { NPY_F8, NPY_INT, NPY_UNICODE };

typedef struct npy {
  int type;          /* enum npy_type */
  int is_signed;     /* NPY_INT */
  size_t itemsize;   /* bytes per element (NPY_UNICODE: 4 per code point) */
  int ndim;
  int fortran;       /* column-major data (numpy's fortran_order True: a transposed array) */
  size_t shape[MAX_NDIM];
  size_t count;      /* elements */
  const unsigned char *data;
  char descr[32];    /* as written, for messages */
} npy;

typedef struct cursor {
  const char *s, *end;
} cursor;

static void skip_ws(cursor *k) {
  while (k->s < k->end && (*k->s == ' ' || *k->s == '\t' || *k->s == '\n' || *k->s == '\r')) k->s++;
}

static int eat(cursor *k, char ch) {
  skip_ws(k);
  if (k->s < k->end && *k->s == ch) {
    k->s++;
    return 1;
  }
  return 0;
}

/* A quoted Python string literal (no escapes: numpy's keys and descrs have none) into dst. */
static int quoted(cursor *k, char *dst, size_t cap) {
  skip_ws(k);
  if (k->s >= k->end || (*k->s != '\'' && *k->s != '"')) return 0;
  char q = *k->s++;
  size_t j = 0;
  while (k->s < k->end && *k->s != q) {
    if (*k->s == '\\' || j + 1 >= cap) return 0;
    dst[j++] = *k->s++;
  }
  if (k->s >= k->end) return 0;
  k->s++;
  dst[j] = '\0';
  return 1;
}

static int word(cursor *k, const char *w) {
  skip_ws(k);
  size_t n = strlen(w);
  if ((size_t)(k->end - k->s) >= n && memcmp(k->s, w, n) == 0) {
    k->s += n;
    return 1;
  }
  return 0;
}

/* Parses one .npy entry's header and checks the data's length. */
static int parse_npy(const ctx *c, const entry *e, npy *out) {
  char label[MAX_NAME];
  entry_label(label, sizeof label, e);
  memset(out, 0, sizeof *out);
  const unsigned char *b = e->data;
  if (e->size < 10 || memcmp(b, "\x93NUMPY", 6) != 0)
    return fail(c, "entry '%s' is not an .npy array (no \\x93NUMPY magic); expected numpy's .npy format", label);
  unsigned major = b[6];
  size_t hlen, start;
  if (major == 1) {
    hlen = u16(b + 8);
    start = 10;
  } else if (major == 2 || major == 3) {
    if (e->size < 12) return fail(c, "entry '%s': .npy header is truncated; expected a 12-byte preamble", label);
    hlen = u32(b + 8);
    start = 12;
  } else {
    return fail(c, "entry '%s' is .npy version %u; expected version 1, 2 or 3", label, major);
  }
  if (hlen > e->size - start)
    return fail(c, "entry '%s': .npy header of %zu bytes runs past the entry (%zu bytes); expected a whole "
                "header", label, hlen, e->size);
  cursor k = {(const char *)b + start, (const char *)b + start + hlen};
  char key[32], descr[32] = "";
  int seen_descr = 0, seen_order = 0, seen_shape = 0, fortran = 0;
  if (!eat(&k, '{')) goto bad_header;
  while (!eat(&k, '}')) {
    if (!quoted(&k, key, sizeof key) || !eat(&k, ':')) goto bad_header;
    if (strcmp(key, "descr") == 0 && !seen_descr) {
      if (!quoted(&k, descr, sizeof descr)) {
        return fail(c, "entry '%s' has a structured or unreadable dtype; expected '<f8', '<U<n>' or an integer",
                    label);
      }
      seen_descr = 1;
    } else if (strcmp(key, "fortran_order") == 0 && !seen_order) {
      if (word(&k, "True")) fortran = 1;
      else if (!word(&k, "False")) goto bad_header;
      seen_order = 1;
    } else if (strcmp(key, "shape") == 0 && !seen_shape) {
      if (!eat(&k, '(')) goto bad_header;
      out->ndim = 0;
      while (!eat(&k, ')')) {
        skip_ws(&k);
        if (k.s >= k.end || *k.s < '0' || *k.s > '9') goto bad_header;
        size_t v = 0;
        while (k.s < k.end && *k.s >= '0' && *k.s <= '9') {
          if (v > (SIZE_MAX - 9) / 10) goto bad_header;
          v = v * 10 + (size_t)(*k.s++ - '0');
        }
        if (out->ndim == MAX_NDIM)
          return fail(c, "entry '%s' has more than %d dimensions; expected at most 2", label, MAX_NDIM);
        out->shape[out->ndim++] = v;
        if (!eat(&k, ',')) {
          if (!eat(&k, ')')) goto bad_header;
          if (out->ndim == 1) goto bad_header; /* "(5)" is an int in Python, not a tuple */
          break;
        }
      }
      seen_shape = 1;
    } else {
      goto bad_header;
    }
    if (!eat(&k, ',')) {
      if (!eat(&k, '}')) goto bad_header;
      break;
    }
  }
  if (!seen_descr || !seen_order || !seen_shape) goto bad_header;
  snprintf(out->descr, sizeof out->descr, "%s", descr);
  /* dtype */
  char order = descr[0];
  char t = order ? descr[1] : '\0';
  char *digits_end = NULL;
  long width = (order && t) ? strtol(descr + 2, &digits_end, 10) : 0;
  if (!order || !t || digits_end == descr + 2 || *digits_end != '\0' || width <= 0) {
    return fail(c, "entry '%s' has dtype '%s'; expected '<f8', '<U<n>' or a little-endian integer", label,
                out->descr);
  }
  if (t == 'f' && width == 8 && order == '<') {
    out->type = NPY_F8;
    out->itemsize = 8;
  } else if ((t == 'i' || t == 'u') && (width == 1 || width == 2 || width == 4 || width == 8) &&
             (order == '<' || (order == '|' && width == 1))) {
    out->type = NPY_INT;
    out->is_signed = t == 'i';
    out->itemsize = (size_t)width;
  } else if (t == 'U' && order == '<' && width <= 1 << 20) {
    out->type = NPY_UNICODE;
    out->itemsize = 4 * (size_t)width;
  } else {
    return fail(c, "entry '%s' has dtype '%s'; expected '<f8' (little-endian float64), '<U<n>' or a "
                "little-endian integer", label, out->descr);
  }
  size_t count = 1;
  for (int i = 0; i < out->ndim; ++i) {
    if (out->shape[i] != 0 && count > SIZE_MAX / out->shape[i]) goto too_big;
    count *= out->shape[i];
  }
  if (fortran && out->ndim > 2)
    return fail(c, "entry '%s' has %d dimensions in Fortran order; expected C order (fortran_order False)", label,
                out->ndim);
  out->fortran = fortran && out->ndim == 2;
  if (count > SIZE_MAX / out->itemsize) goto too_big;
  size_t body = e->size - start - hlen;
  if (count * out->itemsize != body)
    return fail(c, "entry '%s' holds %zu data bytes; expected %zu for dtype '%s' and its shape", label, body,
                count * out->itemsize, out->descr);
  out->count = count;
  out->data = b + start + hlen;
  return CC_OK;
too_big:
  return fail(c, "entry '%s' has a shape beyond the file's size; expected a weights array", label);
bad_header:
  return fail(c, "entry '%s' has an unreadable .npy header; expected {'descr': ..., 'fortran_order': ..., "
              "'shape': (...)}", label);
}

static void shape_text(char *dst, size_t cap, const npy *a) {
  size_t j = (size_t)snprintf(dst, cap, "(");
  for (int i = 0; i < a->ndim && j < cap; ++i)
    j += (size_t)snprintf(dst + j, cap - j, a->ndim == 1 ? "%zu," : (i ? ", %zu" : "%zu"), a->shape[i]);
  if (j < cap) snprintf(dst + j, cap - j, ")");
}

/* ------------------------------------------------------------------- the layout */

typedef struct loader {
  ctx c;
  archive a;
  const char *kind_name;
  int widths[2]; /* network (inputs, outputs) of the kind */
} loader;

/* Entry `name` as an npy; absent: CC_FILE_ERROR naming `expected` unless optional (then *found = 0). */
static int get(loader *L, const char *name, npy *out, int *found, const char *expected) {
  const entry *e = lookup(&L->a, name);
  if (found) *found = e != NULL;
  if (e == NULL) return found ? CC_OK : fail(&L->c, "entry '%s' is missing; expected %s", name, expected);
  return parse_npy(&L->c, e, out);
}

/* A 0-d unicode entry into dst (ASCII only). */
static int get_string(loader *L, const char *name, char *dst, size_t cap, int *found, const char *expected) {
  npy a;
  int rc = get(L, name, &a, found, expected);
  if (rc || (found && !*found)) return rc;
  if (a.type != NPY_UNICODE || a.ndim != 0)
    return fail(&L->c, "entry '%s' has dtype '%s' and %d dimensions; expected a string ('<U<n>', shape ())", name,
                a.descr, a.ndim);
  size_t n = a.itemsize / 4, j = 0;
  for (size_t i = 0; i < n; ++i) {
    uint32_t cp = u32(a.data + 4 * i);
    if (cp == 0) break; /* numpy pads with NULs */
    if (j + 1 >= cap) return fail(&L->c, "entry '%s' is longer than %zu characters; expected %s", name, cap - 1,
                                  expected);
    dst[j++] = (cp >= 0x20 && cp < 0x7f) ? (char)cp : '?';
  }
  dst[j] = '\0';
  return CC_OK;
}

static int check_f8(loader *L, const char *name, const npy *a, int ndim, const long *shape, const char *expected) {
  char got[96];
  shape_text(got, sizeof got, a);
  if (a->type != NPY_F8)
    return fail(&L->c, "entry '%s' has dtype '%s'; expected '<f8' (float64) %s", name, a->descr, expected);
  int ok = a->ndim == ndim;
  for (int i = 0; ok && i < ndim; ++i) ok = shape[i] < 0 || a->shape[i] == (size_t)shape[i];
  if (!ok) return fail(&L->c, "entry '%s' has shape %s; expected %s", name, got, expected);
  for (size_t i = 0; i < a->count; ++i)
    if (!isfinite(f64(a->data + 8 * i)))
      return fail(&L->c, "entry '%s' holds NaN or inf (element %zu); expected finite values", name, i);
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
    return fail(&L->c, "entry '%s' is missing; expected a %s network (%sW0, %sb0, ...)", name, L->kind_name, prefix,
                prefix);
  }
  if (n > CC_MAX_LAYERS)
    return fail(&L->c, "entries '%sW*' number %d layers; expected at most %d (CC_MAX_LAYERS)", prefix, n,
                CC_MAX_LAYERS);
  m->n_layers = n;
  snprintf(expected, sizeof expected, "a %s network with %d layers", L->kind_name, n);
  snprintf(name, sizeof name, "%sactivation", prefix);
  int rc = get_string(L, name, act, sizeof act, NULL, "one of 'relu', 'silu', 'tanh'");
  if (rc) return rc;
  if (strcmp(act, "tanh") == 0) m->activation = CC_TANH;
  else if (strcmp(act, "silu") == 0) m->activation = CC_SILU;
  else if (strcmp(act, "relu") == 0) m->activation = CC_RELU;
  else return fail(&L->c, "entry '%s' is '%s'; expected one of 'relu', 'silu', 'tanh'", name, act);
  long width = L->widths[0];
  for (int i = 0; i < n; ++i) {
    char wname[64], bname[64];
    snprintf(wname, sizeof wname, "%sW%d", prefix, i);
    snprintf(bname, sizeof bname, "%sb%d", prefix, i);
    if ((rc = get(L, wname, &m->W[i], NULL, expected)) || (rc = get(L, bname, &m->b[i], NULL, expected))) return rc;
    if (m->W[i].ndim != 2 || (long)m->W[i].shape[0] != width || m->W[i].shape[1] == 0 ||
        m->W[i].shape[1] > CCI_MAX_WIDTH) {
      char got[96];
      shape_text(got, sizeof got, &m->W[i]);
      return fail(&L->c, "entry '%s' has shape %s; expected (%ld, m) with bias (m,), 1 <= m <= %d", wname, got, width,
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
    return fail(&L->c, "entry '%sW%d' has %ld outputs; expected %d for kind '%s'", prefix, n - 1, width,
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
  int rc = read_archive(&L->c, buf, size, &L->a);
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
      return fail(&L->c, "entry 'kind' is missing and there is no network (mlp/W0); expected a predictor weights "
                  "file");
    if (lookup(&L->a, "supported_sizes")) snprintf(kind, sizeof kind, "improved");
    else if (W0.ndim == 2 && W0.shape[0] == 6) snprintf(kind, sizeof kind, "paper");
    else return fail(&L->c, "entry 'kind' is missing and cannot be inferred; expected 'improved' or 'paper'");
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
    return fail(&L->c, "entry 'kind' is '%s'; expected one of 'improved', 'paper'", kind);
  }
  L->kind_name = out->kind == CC_KIND_IMPROVED ? "improved" : "paper";
  /* format_version (a legacy paper file has none: version 1) */
  npy v;
  if ((rc = get(L, "format_version", &v, &found, NULL))) return rc;
  long long version;
  if (!found) {
    if (out->kind != CC_KIND_PAPER) /* loading.py: a paper file without a version is a legacy one, version 1 */
      return fail(&L->c, "entry 'format_version' is missing; expected 1, 2 or 3");
    version = 1;
  } else {
    if (v.type != NPY_INT || v.ndim != 0)
      return fail(&L->c, "entry 'format_version' has dtype '%s' and %d dimensions; expected an integer of shape ()",
                  v.descr, v.ndim);
    uint64_t raw = 0;
    for (size_t i = 0; i < v.itemsize; ++i) raw |= (uint64_t)v.data[i] << (8 * i);
    int negative = v.is_signed && ((raw >> (8 * v.itemsize - 1)) & 1u);
    if (negative) raw = (v.itemsize < 8 ? (1ull << (8 * v.itemsize)) : 0) - raw; /* the magnitude */
    if (negative || raw < 1 || raw > 3)
      return fail(&L->c, "entry 'format_version' is %s%llu; expected 1, 2 or 3", negative ? "-" : "",
                  (unsigned long long)raw);
    version = (long long)raw;
  }
  out->format_version = (int)version;
  /* the networks */
  mlp_arrays main_net, expert_net;
  memset(&expert_net, 0, sizeof expert_net);
  if ((rc = read_mlp(L, "mlp/", &main_net))) return rc;
  int has_expert = has_prefix(&L->a, "expert/");
  npy domain;
  if (!has_expert && version >= 2)
    return fail(&L->c, "entry 'expert/W0' is missing (format_version %lld carries a resting expert); expected "
                "expert/ arrays, or format_version 1", version);
  if (has_expert) {
    if (out->kind != CC_KIND_IMPROVED)
      return fail(&L->c, "entries 'expert/*' are present in a '%s' file; expected a resting expert only in an "
                  "improved file", L->kind_name);
    if (version < 2)
      return fail(&L->c, "entry 'format_version' is %lld but the file carries a resting expert (expert/); "
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
        return fail(&L->c, "entry 'expert/domain' has bounds %ld and %ld = %.17g and %.17g; expected 0 <= in < out",
                    2 * k, 2 * k + 1, lo, hi);
    }
    double r_slab = f64(domain.data + 8 * (n_dom - 1));
    if (!(r_slab > 0.0))
      return fail(&L->c, "entry 'expert/domain' has r_slab = %.17g; expected > 0", r_slab);
    if ((rc = read_mlp(L, "expert/", &expert_net))) return rc;
  }
  /* supported sizes */
  npy sizes;
  if ((rc = get(L, "supported_sizes", &sizes, &found, NULL))) return rc;
  if (!found)
    return fail(&L->c, "entry 'supported_sizes' is missing; expected (k, 3) full extents [m] (a legacy paper file: "
                "load and re-save it with learned_contact)");
  long shape_sizes[2] = {-1, 3};
  if ((rc = check_f8(L, "supported_sizes", &sizes, 2, shape_sizes, "(k, 3) finite full extents [m]"))) return rc;
  if (sizes.shape[0] == 0 || sizes.shape[0] > 1u << 20)
    return fail(&L->c, "entry 'supported_sizes' has %zu rows; expected (k, 3) with k >= 1", sizes.shape[0]);
  /* one allocation for every array */
  size_t total = sizes.count + mlp_doubles(&main_net) + (has_expert ? mlp_doubles(&expert_net) : 0);
  double *storage = malloc(total * sizeof(double));
  if (storage == NULL) return fail(&L->c, "out of memory for %zu weights", total);
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
  if (out == NULL) return fail(&c, "no model to fill (a null cc_model pointer); expected a cc_model to load into");
  memset(out, 0, sizeof *out);
  if (path == NULL) return fail(&c, "a null path; expected the path of a weights file (.npz)");
  errno = 0;
  FILE *f = fopen(path, "rb");
  if (f == NULL)
    return fail(&c, "cannot be opened (%s); expected a predictor weights file (.npz)",
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
    rc = fail(&c, "out of memory reading it (%zu bytes so far); expected memory for the file", size);
  } else if (read_error) {
    rc = fail(&c, "cannot be read (%s); expected a regular file", reason(saved));
  } else if (size > (size_t)MAX_FILE_BYTES) {
    rc = fail(&c, "is larger than %ld bytes; expected a weights file of at most 64 MiB", MAX_FILE_BYTES);
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
