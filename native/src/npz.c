/* npz.c: reading numpy's .npz archives (npz.h), for the weights reader (weights.c), libc only:
 *   1. finds the zip's end-of-central-directory record (and its zip64 form), walks the central
 *      directory, and for each entry checks its local file header (same name, method 0 =
 *      stored), the data's bounds and its CRC-32 (as Python's zipfile does on reading);
 *   2. parses an .npy header (versions 1, 2, 3; a Python dict literal with descr,
 *      fortran_order and shape) and checks the data's length against it.
 * No static mutable state: concurrent loads from several threads are safe. */
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "npz.h"

/* what a file that is no zip gets told: what the core reads, and where another model goes */
#define NPZ_EXPECTED                                                                                   \
  "expected an .npz written by numpy.savez (other models, ONNX or your own: cc_contact_step_with's " \
  "predictor callback, docs/integrate.md)"

/* --------------------------------------------------------------------- errors */

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

int ccz_fail(const ctx *c, const char *fmt, ...) {
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

/* The entry's name for messages: "mlp/W0.npy" -> "mlp/W0.npy" (sanitised, truncated). */
static void entry_label(char *dst, size_t cap, const entry *e) { sanitize(dst, cap, e->name, e->name_len); }

static int find_eocd(const ctx *c, const unsigned char *buf, size_t size, size_t *at) {
  if (size < 22) return ccz_fail(c, "is %zu bytes, too short for a zip; " NPZ_EXPECTED, size);
  size_t lowest = size > 22 + 65535 ? size - 22 - 65535 : 0;
  for (size_t i = size - 22 + 1; i-- > lowest;) {
    if (u32(buf + i) == 0x06054b50u && i + 22 + u16(buf + i + 20) == size) {
      *at = i;
      return CC_OK;
    }
  }
  return ccz_fail(c, "no zip end-of-central-directory record; " NPZ_EXPECTED);
}

/* Fills a with the entries of the zip in buf (borrowing buf). */
int ccz_read_archive(const ctx *c, const unsigned char *buf, size_t size, archive *a) {
  size_t eocd = 0;
  int rc = find_eocd(c, buf, size, &eocd);
  if (rc) return rc;
  const unsigned char *e = buf + eocd;
  uint64_t n_entries = u16(e + 10), cd_size = u32(e + 12), cd_offset = u32(e + 16);
  if (u16(e + 4) != 0 || u16(e + 6) != 0 || u16(e + 8) != u16(e + 10))
    return ccz_fail(c, "zip end record names several disks; expected a single-file .npz");
  size_t cd_end_limit = eocd;
  if (eocd >= 20 && u32(buf + eocd - 20) == 0x07064b50u) { /* zip64 end-of-central-directory locator */
    uint64_t z = u64(buf + eocd - 20 + 8);
    if (z > eocd - 20 || eocd - 20 - z < 56 || u32(buf + z) != 0x06064b50u)
      return ccz_fail(c, "zip64 end record locator points outside the file; expected a zip64 end record before it");
    const unsigned char *z64 = buf + z;
    if (u32(z64 + 16) != 0 || u32(z64 + 20) != 0 || u64(z64 + 24) != u64(z64 + 32))
      return ccz_fail(c, "zip64 end record names several disks; expected a single-file .npz");
    n_entries = u64(z64 + 32);
    cd_size = u64(z64 + 40);
    cd_offset = u64(z64 + 48);
    cd_end_limit = (size_t)z;
  } else if (n_entries == 0xFFFFu || cd_size == 0xFFFFFFFFu || cd_offset == 0xFFFFFFFFu) {
    return ccz_fail(c, "zip end record defers to a zip64 record that is missing; expected a zip64 locator");
  }
  if (cd_offset > cd_end_limit || cd_size > cd_end_limit - cd_offset)
    return ccz_fail(c, "zip central directory (offset %llu, %llu bytes) lies outside the file; expected it before "
                "the end record", (unsigned long long)cd_offset, (unsigned long long)cd_size);
  if (n_entries == 0) return ccz_fail(c, "zip holds no entries; expected the arrays of a predictor weights file");
  if (n_entries > cd_size / 46)
    return ccz_fail(c, "zip end record counts %llu entries in a %llu-byte central directory; expected at most %llu",
                (unsigned long long)n_entries, (unsigned long long)cd_size, (unsigned long long)(cd_size / 46));
  a->entries = calloc((size_t)n_entries, sizeof(entry));
  if (a->entries == NULL) return ccz_fail(c, "out of memory for %llu zip entries", (unsigned long long)n_entries);
  a->n = 0;
  const unsigned char *p = buf + cd_offset, *end = buf + cd_offset + cd_size;
  for (uint64_t k = 0; k < n_entries; ++k) {
    if ((size_t)(end - p) < 46 || u32(p) != 0x02014b50u)
      return ccz_fail(c, "zip central directory entry %llu is truncated or has a bad signature; expected %llu "
                  "entries", (unsigned long long)k, (unsigned long long)n_entries);
    uint32_t flags = u16(p + 8), method = u16(p + 10), crc = u32(p + 16);
    uint64_t csize = u32(p + 20), usize = u32(p + 24), offset = u32(p + 42);
    size_t name_len = u16(p + 28), extra_len = u16(p + 30), comment_len = u16(p + 32);
    uint32_t disk = u16(p + 34);
    if ((size_t)(end - p) - 46 < name_len + extra_len + comment_len)
      return ccz_fail(c, "zip central directory entry %llu runs past the directory; expected %zu bytes of name, "
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
            return ccz_fail(c, "entry '%s': zip64 extra field is short; expected 8 bytes per deferred size or offset",
                        label);
          *want[i] = u64(f);
          f += 8;
        }
      }
      x += 4 + len;
    }
    if (disk != 0 && disk != 0xFFFFu)
      return ccz_fail(c, "entry '%s' lies on disk %u; expected a single-file .npz", label, disk);
    if (flags & 0x1u) return ccz_fail(c, "entry '%s' is encrypted; expected a plain numpy.savez file", label);
    if (method != 0)
      return ccz_fail(c, "compressed entry '%s' (zip method %u): save with numpy.savez, not savez_compressed", label,
                  method);
    if (csize != usize)
      return ccz_fail(c, "entry '%s' is stored (method 0) with %llu bytes in and %llu out; expected equal sizes", label,
                  (unsigned long long)csize, (unsigned long long)usize);
    /* the local file header: same name, stored, followed by the data */
    if (offset > size || size - offset < 30 || u32(buf + offset) != 0x04034b50u)
      return ccz_fail(c, "entry '%s': no local file header at offset %llu; expected one (signature PK\\3\\4)", label,
                  (unsigned long long)offset);
    const unsigned char *l = buf + offset;
    size_t l_name = u16(l + 26), l_extra = u16(l + 28);
    if (u16(l + 8) != 0)
      return ccz_fail(c, "compressed entry '%s' (zip method %u in its local header): save with numpy.savez, not "
                  "savez_compressed", label, u16(l + 8));
    if (l_name != name_len || memcmp(l + 30, en->name, name_len) != 0)
      return ccz_fail(c, "entry '%s': its local file header names another entry; expected the same name", label);
    uint64_t data_at = offset + 30 + l_name + l_extra;
    if (data_at > size || size - data_at < usize)
      return ccz_fail(c, "entry '%s' (%llu bytes at offset %llu) runs past the end of the file (%zu bytes); expected "
                  "the whole entry", label, (unsigned long long)usize, (unsigned long long)data_at, size);
    en->data = buf + data_at;
    en->size = (size_t)usize;
    if (crc32_of(en->data, en->size) != crc)
      return ccz_fail(c, "entry '%s' fails its CRC-32 check (the file is corrupt); expected CRC %08x", label, crc);
    for (size_t i = 0; i < a->n; ++i)
      if (a->entries[i].name_len == name_len && memcmp(a->entries[i].name, en->name, name_len) == 0)
        return ccz_fail(c, "entry '%s' appears twice; expected each array once", label);
    a->n++;
    p += 46 + name_len + extra_len + comment_len;
  }
  return CC_OK;
}

/* The entry named `name` + ".npy", or NULL. */
const entry *ccz_lookup(const archive *a, const char *name) {
  size_t n = strlen(name);
  for (size_t i = 0; i < a->n; ++i) {
    const entry *e = &a->entries[i];
    if (e->name_len == n + 4 && memcmp(e->name, name, n) == 0 && memcmp(e->name + n, ".npy", 4) == 0) return e;
  }
  return NULL;
}

int ccz_has_prefix(const archive *a, const char *prefix) {
  size_t n = strlen(prefix);
  for (size_t i = 0; i < a->n; ++i)
    if (a->entries[i].name_len >= n && memcmp(a->entries[i].name, prefix, n) == 0) return 1;
  return 0;
}

/* ------------------------------------------------------------------------ .npy */

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
int ccz_parse_npy(const ctx *c, const entry *e, npy *out) {
  char label[MAX_NAME];
  entry_label(label, sizeof label, e);
  memset(out, 0, sizeof *out);
  const unsigned char *b = e->data;
  if (e->size < 10 || memcmp(b, "\x93NUMPY", 6) != 0)
    return ccz_fail(c, "entry '%s' is not an .npy array (no \\x93NUMPY magic); expected numpy's .npy format", label);
  unsigned major = b[6];
  size_t hlen, start;
  if (major == 1) {
    hlen = u16(b + 8);
    start = 10;
  } else if (major == 2 || major == 3) {
    if (e->size < 12) return ccz_fail(c, "entry '%s': .npy header is truncated; expected a 12-byte preamble", label);
    hlen = u32(b + 8);
    start = 12;
  } else {
    return ccz_fail(c, "entry '%s' is .npy version %u; expected version 1, 2 or 3", label, major);
  }
  if (hlen > e->size - start)
    return ccz_fail(c, "entry '%s': .npy header of %zu bytes runs past the entry (%zu bytes); expected a whole "
                "header", label, hlen, e->size);
  cursor k = {(const char *)b + start, (const char *)b + start + hlen};
  char key[32], descr[32] = "";
  int seen_descr = 0, seen_order = 0, seen_shape = 0, fortran = 0;
  if (!eat(&k, '{')) goto bad_header;
  while (!eat(&k, '}')) {
    if (!quoted(&k, key, sizeof key) || !eat(&k, ':')) goto bad_header;
    if (strcmp(key, "descr") == 0 && !seen_descr) {
      if (!quoted(&k, descr, sizeof descr)) {
        return ccz_fail(c, "entry '%s' has a structured or unreadable dtype; expected '<f8', '<U<n>' or an integer",
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
          return ccz_fail(c, "entry '%s' has more than %d dimensions; expected at most 2", label, MAX_NDIM);
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
    return ccz_fail(c, "entry '%s' has dtype '%s'; expected '<f8', '<U<n>' or a little-endian integer", label,
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
    return ccz_fail(c, "entry '%s' has dtype '%s'; expected '<f8' (little-endian float64), '<U<n>' or a "
                "little-endian integer", label, out->descr);
  }
  size_t count = 1;
  for (int i = 0; i < out->ndim; ++i) {
    if (out->shape[i] != 0 && count > SIZE_MAX / out->shape[i]) goto too_big;
    count *= out->shape[i];
  }
  if (fortran && out->ndim > 2)
    return ccz_fail(c, "entry '%s' has %d dimensions in Fortran order; expected C order (fortran_order False)", label,
                out->ndim);
  out->fortran = fortran && out->ndim == 2;
  if (count > SIZE_MAX / out->itemsize) goto too_big;
  size_t body = e->size - start - hlen;
  if (count * out->itemsize != body)
    return ccz_fail(c, "entry '%s' holds %zu data bytes; expected %zu for dtype '%s' and its shape", label, body,
                count * out->itemsize, out->descr);
  out->count = count;
  out->data = b + start + hlen;
  return CC_OK;
too_big:
  return ccz_fail(c, "entry '%s' has a shape beyond the file's size; expected a weights array", label);
bad_header:
  return ccz_fail(c, "entry '%s' has an unreadable .npy header; expected {'descr': ..., 'fortran_order': ..., "
              "'shape': (...)}", label);
}

void ccz_shape_text(char *dst, size_t cap, const npy *a) {
  size_t j = (size_t)snprintf(dst, cap, "(");
  for (int i = 0; i < a->ndim && j < cap; ++i)
    j += (size_t)snprintf(dst + j, cap - j, a->ndim == 1 ? "%zu," : (i ? ", %zu" : "%zu"), a->shape[i]);
  if (j < cap) snprintf(dst + j, cap - j, ")");
}
