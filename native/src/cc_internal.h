/* cc_internal.h: the predictor's internal pieces, shared by the files of native/src (not
 * part of the public API: names start with cci_ or CCI_).
 *
 * One pose at a time, no allocation: every function takes its scratch from the caller
 * (stack arrays of fixed size). Frames and units as in container_contact.h: p (3) [m] is
 * B's centre in A's frame, R (9) B's orientation in A, row-major (R[3 * i + j] is row i,
 * column j; column j is B's axis j in A), hA, hB (3) half extents [m].
 *
 * The arithmetic follows the numpy reference (learned_contact.model, testbed.geometry.boxes)
 * operation for operation wherever a result depends on its rounding; each function names the
 * Python function it ports. Compiled without fused multiply-adds (-ffp-contract=off), so the
 * answers agree with that reference to rounding (tests/learned/test_native_core.py: 1e-12).
 */
#ifndef CC_INTERNAL_H
#define CC_INTERNAL_H

#include <stddef.h>

#include "container_contact.h"

/* ------------------------------------------------------------------ constants
 * Each is the Python value named beside it; tests/learned/test_native_core.py compares
 * them (learned_contact._native.constants()) with the Python ones. */
#define CCI_SIZE_TOLERANCE 1e-3       /* [m] learned_contact.interface.SIZE_TOLERANCE */
#define CCI_ROTATION_TOLERANCE 1e-6   /* interface.ROTATION_TOLERANCE */
#define CCI_DOMAIN_DEPTH_LO (-0.01)   /* [m] interface.DOMAIN_DEPTH[0] */
#define CCI_DOMAIN_DEPTH_HI 0.05      /* [m] interface.DOMAIN_DEPTH[1] */
#define CCI_CLIP_MARGIN 0.05          /* [m] interface.CLIP_MARGIN */
#define CCI_POINT_STEP 0.5            /* [m] predictors.improved.POINT_STEP */
#define CCI_SYMMETRY_BAND 0.02        /* [m] model.encodings.SYMMETRY_BAND */
#define CCI_R_SLAB 0.01               /* model.expert.R_SLAB (the slab scale without an expert) */
#define CCI_LENGTH_SCALE (1.0 / 6.0)  /* [1/m] model.encodings.LENGTH_SCALE */
#define CCI_EDGE_BIAS 1e-3            /* [m] testbed.geometry.boxes.sat_normal's edge-axis bias */
#define CCI_PI 3.141592653589793      /* math.pi */
/* [rad] model.quadrature.POINT_TILT and NORMAL_TILT: np.radians(x) = x * (pi / 180) */
#define CCI_POINT_TILT_0 (20.0 * (CCI_PI / 180.0))
#define CCI_POINT_TILT_1 (30.0 * (CCI_PI / 180.0))
#define CCI_NORMAL_TILT_0 (2.0 * (CCI_PI / 180.0))
#define CCI_NORMAL_TILT_1 (4.0 * (CCI_PI / 180.0))
#define CCI_N_FEATURES 91             /* model.encodings.N_FEATURES */
#define CCI_PAPER_INPUTS 6            /* the paper network's inputs and outputs */
#define CCI_PAPER_OUTPUTS 4
#define CCI_IMPROVED_OUTPUTS 6        /* point correction (3), normal correction (3) */
#define CCI_MAX_VERTS 9               /* model.prior._MAX_VERTS: a quad clipped by 5 half-planes */
#define CCI_QUAD_VERTS 9              /* model.quadrature._MAX_VERTS: a triangle clipped by 6 */
#define CCI_MAX_WIDTH 1024            /* the widest layer a network may have (stack scratch) */

/* PAPER_FRAME (model.encodings): rows x', y', z' of the paper's spherical frame */
extern const double cci_paper_frame[3][3];

/* ------------------------------------------------------------------ helpers
 * Python's min and max of two floats: the first argument unless the second is strictly
 * smaller (larger), so ties and signed zeros come out as in the reference. */
static inline double cci_min(double a, double b) { return b < a ? b : a; }
static inline double cci_max(double a, double b) { return b > a ? b : a; }
/* min(max(x, lo), hi) */
static inline double cci_clamp(double x, double lo, double hi) { return cci_min(cci_max(x, lo), hi); }

/* ------------------------------------------------------------------ sat.c */
/* Separating-axis test (testbed.geometry.boxes.sat_axes, sat_overlap): fills axes (15 x 3)
 * (A's face normals, B's, the 9 edge crosses e_i x b_j normalised; zero when degenerate) and
 * overlap (15) [m] (positive: overlapping; +inf for a zero axis). */
void cci_sat_overlap(const double p[3], const double R[9], const double hA[3], const double hB[3],
                     double axes[15][3], double overlap[15]);
/* The minimum-overlap axis, face axes preferred within EDGE_BIAS (boxes.sat_normal): fills
 * normal (3) (unit, A towards B); returns the depth [m] and writes the axis index (0..14). */
double cci_sat_normal(const double p[3], const double axes[15][3], const double overlap[15], double normal[3],
                      int *axis);
/* The separating-axis penetration depth [m] of one pose (negative: separated). */
double cci_sat_depth(const double p[3], const double R[9], const double hA[3], const double hB[3]);

/* ------------------------------------------------------------------ prior.c */
/* The geometric estimate (model.prior.patch_estimate) for one pose: fills point (3) [m] in A,
 * normal (3) unit A->B, overlap (15) [m]; returns the depth [m], writes the SAT axis index
 * and the patch volume [m^3]. */
double cci_patch_estimate(const double p[3], const double R[9], const double hA[3], const double hB[3],
                          double overlap[15], double point[3], double normal[3], int *axis, double *weight);
/* model.encodings.canonicalise for one pose: S (3) signs of p, then cci_reflect by S. */
void cci_canonicalise(const double p[3], const double R[9], double S[3], double p_c[3], double R_c[9]);
/* model.encodings.reflect: the pose reflected by diag(S), B's columns sign-fixed to a
 * non-negative sum: p_c (3) [m], R_c (9). */
void cci_reflect(const double p[3], const double R[9], const double S[3], double p_c[3], double R_c[9]);
/* half (3) = band_weight(|p_k|) / 2 (model.encodings.band_weight, frame_blend). */
void cci_band_half_weights(const double p[3], double band, double half[3]);
/* model.encodings.features for one canonical pose: fills x (N_FEATURES) and the estimate
 * point_est (3) [m], normal_est (3), overlap (15) [m] (the prior's); returns the depth [m]. */
double cci_features(const double p_c[3], const double R_c[9], const double hA[3], const double hB[3],
                    double x[CCI_N_FEATURES], double point_est[3], double normal_est[3], double overlap[15]);

/* ------------------------------------------------------------------ quadrature.c */
/* The tilt [rad] between the two faces the normal n (3) (unit, A->B) picks
 * (model.quadrature.faces, face_on_face's tilt). */
double cci_face_tilt(const double R[9], const double n[3]);
/* The exact centre of pressure of B's face pressed on A's face (model.quadrature.face_on_face)
 * for one pose, faces picked by n (3): fills point (3) [m] in A and normal (3) unit A->B;
 * returns the weight [m^3] (the integral of the pressure, 0 where the faces do not
 * overlap) and writes the tilt [rad]. */
double cci_face_on_face(const double p[3], const double R[9], const double hA[3], const double hB[3],
                        const double n[3], double point[3], double normal[3], double *tilt);
/* model.quadrature.hand_over: 1 up to band0, 0 from band1 on [rad], a C1 smoothstep between. */
static inline double cci_hand_over(double tilt, double band0, double band1) {
  double u = cci_clamp((tilt - band0) / (band1 - band0), 0.0, 1.0);
  return 1.0 - u * u * (3.0 - 2.0 * u);
}

/* ------------------------------------------------------------------ mlp.c */
/* y = mlp(x) for one row (model.mlp.NumpyMLP.__call__): x (dims[0]), y (dims[n_layers]);
 * h0, h1 scratch of CCI_MAX_WIDTH. The caller has checked the shapes (cci_check_mlp). */
void cci_mlp_forward(const cc_mlp *mlp, const double *x, double *y, double *h0, double *h1);
/* CC_OK when the network has n_in inputs, n_out outputs, 1..CC_MAX_LAYERS layers, a known
 * activation, non-null arrays and no layer wider than CCI_MAX_WIDTH; else CC_BAD_ARGUMENT. */
int cci_check_mlp(const cc_mlp *mlp, int n_in, int n_out);
/* The input checks of cc_predict (interface.check_numpy's, in its order) against n_sizes
 * supported sizes (n_sizes, 3) [m] and, unless NULL, the size range (2, 3) [m], without a model: a cc_status and the first bad row. */
int cci_check_inputs(const double *supported, int n_sizes, const double *size_range, size_t n, const double *p,
                     const double *R, const double *sA, size_t rows_A, const double *sB, size_t rows_B,
                     size_t *bad_row);
/* The activations' tanh: plain arithmetic within a few 1e-15 of np.tanh (mlp.c says how). */
double cci_tanh(double x);
/* 1 (the default): the networks run on AVX vectors where the CPU has them; 0: plain C only
 * (the same bits; the tests compare the two). Not thread-safe: set it before calling. */
void cci_set_vector_path(int on);

/* ------------------------------------------------------------------ predict.c */
/* learned_contact.model.expert.weights for one canonical pose (the main network's and the
 * expert's weight, the slab scale included); domain (n_domain: 11 or 9) read only when
 * has_expert. Exposed for the tests. */
void cci_expert_weights(const double p_c[3], const double R_c[9], const double hA[3], const double hB[3],
                        double depth, const double overlap[15], const double *domain, int n_domain, int has_expert,
                        double *w_main, double *w_expert);

#endif /* CC_INTERNAL_H */
