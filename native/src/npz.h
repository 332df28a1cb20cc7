/* npz.h: reading numpy's .npz archives (npz.c) for the weights reader (weights.c); not installed.
 * An archive is borrowed from the caller's buffer; every refusal is CC_FILE_ERROR with one
 * printable line in the context's err ("weights file PATH: ..."). No static mutable state. */
#ifndef CC_NPZ_H
#define CC_NPZ_H

#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include "container_contact.h"

#define MAX_NAME 256 /* longest entry name we report or match */
#define MAX_NDIM 8

/* where a refusal is written */
typedef struct ctx {
  const char *path;
  char *err;
  size_t err_len;
} ctx;

/* ------------------------------------------------------------ little-endian reads */

static inline uint32_t u16(const unsigned char *p) { return (uint32_t)p[0] | (uint32_t)p[1] << 8; }
static inline uint32_t u32(const unsigned char *p) {
  return (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 | (uint32_t)p[3] << 24;
}
static inline uint64_t u64(const unsigned char *p) { return (uint64_t)u32(p) | (uint64_t)u32(p + 4) << 32; }
static inline double f64(const unsigned char *p) {
  uint64_t bits = u64(p);
  double d;
  memcpy(&d, &bits, sizeof d); /* IEEE 754 binary64 with the host's integer byte order */
  return d;
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

/* One line "weights file PATH: <printf of fmt>" into c->err (control and non-ASCII bytes as '?');
 * returns CC_FILE_ERROR. */
int ccz_fail(const ctx *c, const char *fmt, ...);
/* Fills a with the entries of the zip in buf (borrowing buf; a->entries is malloc'd: free it). */
int ccz_read_archive(const ctx *c, const unsigned char *buf, size_t size, archive *a);
const entry *ccz_lookup(const archive *a, const char *name); /* entry `name` + ".npy", or NULL */
int ccz_has_prefix(const archive *a, const char *prefix);    /* some entry's name starts with prefix */
int ccz_parse_npy(const ctx *c, const entry *e, npy *out);   /* one entry's .npy header; the data's length checked */
void ccz_shape_text(char *dst, size_t cap, const npy *a);    /* "(3, 4)", "(5,)" */

#endif
