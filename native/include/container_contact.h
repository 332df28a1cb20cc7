/* container_contact.h: the learned container-contact model as a C library (C11, C ABI).
 *
 * One native core, called by the testbed (Python) and by a C or C++ simulator alike:
 *   - cc_model_load:  read a predictor's weights file (.npz, the format in docs/integrate.md);
 *   - cc_predict:     contact point and normal of box pairs, as the testbed judged them;
 *   - cc_depth:       the separating-axis penetration depth of box pairs;
 *   - the contact step (candidate pairs -> predictor -> force law -> wrenches), declared below.
 *
 * Conventions (Drake's monogram notation): A and B are the two boxes of a pair; p_AB is B's
 * centre measured in A's frame [m]; R_AB is B's orientation in A (row-major 3x3); sizes are
 * full box extents [m]. All arrays are float64, C-contiguous, row-major. Nothing here
 * allocates except cc_model_load; every function is thread-safe for distinct outputs.
 * Depends on libc and libm only.
 */
#ifndef CONTAINER_CONTACT_H
#define CONTAINER_CONTACT_H

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

/* The export macro (Box2D's B2_API habit). Building the shared library: CC_BUILD_SHARED (the
 * Makefile sets it, with -fvisibility=hidden, so that only the CC_API functions are exported and the
 * core's internal cci_ / ccs_ / ccz_ functions cannot clash inside a large simulator). Using the
 * Windows DLL: define CC_USE_SHARED before including this header. A static build or vendored
 * sources need neither. */
#if defined(_WIN32) || defined(__CYGWIN__)
#if defined(CC_BUILD_SHARED)
#define CC_API __declspec(dllexport)
#elif defined(CC_USE_SHARED)
#define CC_API __declspec(dllimport)
#else
#define CC_API
#endif
#elif defined(__GNUC__) && __GNUC__ >= 4
#define CC_API __attribute__((visibility("default")))
#else
#define CC_API
#endif

/* Versions (MuJoCo's mj_version() habit): the header's, and the library's at run time. A program
 * checks CC_ABI_VERSION == cc_abi_version() before anything else (CC_CHECK_VERSION() does): the
 * ABI version changes whenever a struct or a signature does, so a library built from other headers
 * is refused instead of misread. CC_VERSION is major * 10000 + minor * 100 + patch. */
#define CC_VERSION_MAJOR 0
#define CC_VERSION_MINOR 11
#define CC_VERSION_PATCH 0
#define CC_VERSION (CC_VERSION_MAJOR * 10000 + CC_VERSION_MINOR * 100 + CC_VERSION_PATCH)
#define CC_ABI_VERSION 4 /* 4: cc_model.size_range, cc_status_name; 3: cc_step_force_law_given; CC_API exports; 2: cc_step_sleep gained pair_reuse */
#define CC_CHECK_VERSION() (cc_abi_version() == CC_ABI_VERSION)
#define CC_MAX_LAYERS 8      /* hidden + output layers of one network */
#define CC_MAX_DOMAIN 11     /* the resting expert's gate bounds */

/* The library's CC_VERSION and CC_ABI_VERSION, as it was built. */
CC_API int cc_version(void);
CC_API int cc_abi_version(void);

/* Status codes (learned_contact.interface.raise_for_status gives their Python errors). */
enum cc_status {
  CC_OK = 0,
  CC_BAD_POSE = 1,         /* a non-finite p_AB or R_AB */
  CC_SIZE_A_UNSUPPORTED = 2,
  CC_SIZE_B_UNSUPPORTED = 3,
  CC_SIZE_A_NOT_FINITE = 4,
  CC_SIZE_B_NOT_FINITE = 5,
  CC_BAD_ROTATION = 6,     /* R_AB not a proper rotation within 1e-6 */
  CC_BAD_ARGUMENT = 7,     /* a null pointer, a zero-row size array, an unknown model kind */
  CC_FILE_ERROR = 8        /* cc_model_load: the file is missing, unreadable or not the format */
};

/* The enumerator's name of a cc_status ("CC_OK", "CC_BAD_POSE", ...; "CC_UNKNOWN_STATUS" for any other
 * value): a static string, for logs. */
CC_API const char *cc_status_name(int status);

enum cc_kind { CC_KIND_IMPROVED = 1, CC_KIND_PAPER = 2 };
enum cc_activation { CC_TANH = 0, CC_SILU = 1, CC_RELU = 2 };

/* One multilayer perceptron: y = L_last(act(... act(L_0((x - x_mean) / x_std)))).
 * dims[0] inputs, dims[i + 1] outputs of layer i; W[i] is (dims[i], dims[i + 1]) row-major
 * (x @ W + b), b[i] is (dims[i + 1]). The arrays are borrowed (owned by the loader or caller). */
typedef struct cc_mlp {
  int n_layers;
  int dims[CC_MAX_LAYERS + 1];
  int activation;                   /* enum cc_activation */
  const double *x_mean, *x_std;     /* (dims[0]) */
  const double *W[CC_MAX_LAYERS];
  const double *b[CC_MAX_LAYERS];
} cc_mlp;

/* A predictor: it answers sizes that match one of supported_sizes within 1e-3 m per axis, or
 * that lie inside size_range where has_size_range is 1.
 * kind CC_KIND_IMPROVED: exact face-on-face integral + geometric estimate +
 * main network (+ resting expert when has_expert); CC_KIND_PAPER: the seed paper's MLP. */
typedef struct cc_model {
  int kind;                         /* enum cc_kind */
  int n_sizes;
  const double *supported_sizes;    /* (n_sizes, 3) full extents [m] */
  cc_mlp main;
  int has_expert;
  cc_mlp expert;
  int n_domain;                     /* 11 (format 3) or 9 (format 2): the expert gate's bounds */
  double domain[CC_MAX_DOMAIN];
  int format_version;
  int has_size_range;               /* 1: a size inside size_range answers too (a box of any size in range) */
  double size_range[6];             /* lowest (3) then highest (3) full extents [m], each axis inclusive */
  void *storage;                    /* owned memory when cc_model_load made it, else NULL */
} cc_model;

/* Reads a predictor file (an uncompressed .npz as numpy.savez writes it; docs/integrate.md).
 * Returns CC_OK or CC_FILE_ERROR with one line in err (which file, which entry, what was
 * expected). The model owns its arrays until cc_model_free. */
CC_API int cc_model_load(const char *path, cc_model *out, char *err, size_t err_len);
CC_API void cc_model_free(cc_model *model);

/* Contact answers of n poses. p_AB (n, 3) [m]; R_AB (n, 3, 3); size_A (rows_A, 3) and size_B
 * (rows_B, 3) full extents [m], rows 1 (broadcast to every pose) or n. Writes point_A (n, 3)
 * [m] in A's frame, normal_A (n, 3) unit A->B, depth (n) [m] separating-axis depth (depth may
 * be NULL). Poses outside the trained depth range are clipped (the testbed's outside="clip").
 * Returns a cc_status; on an input error *bad_row (may be NULL) is the first bad row and the
 * outputs are unspecified. */
CC_API int cc_predict(const cc_model *model, size_t n, const double *p_AB, const double *R_AB,
               const double *size_A, size_t rows_A, const double *size_B, size_t rows_B,
               double *point_A, double *normal_A, double *depth, size_t *bad_row);

/* The separating-axis penetration depth of n poses [m] (negative: separated by that much),
 * with the same input checks as cc_predict. */
CC_API int cc_depth(const cc_model *model, size_t n, const double *p_AB, const double *R_AB,
             const double *size_A, size_t rows_A, const double *size_B, size_t rows_B,
             double *depth, size_t *bad_row);

/* ---------------------------------------------------------------- the contact step
 * (declared by native/include/container_contact_step.h) */

#ifdef __cplusplus
}
#endif
#endif /* CONTAINER_CONTACT_H */
