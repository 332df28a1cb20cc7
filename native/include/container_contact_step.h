/* container_contact_step.h: the learned contact step as a C library (C11, C ABI).
 *
 * One step of the learned closed loop, for a simulator that owns the bodies (C/C++, MuJoCo,
 * Drake): body poses and velocities in, the contact wrench on every body out.
 *
 *   candidate pairs (sort-and-sweep broad phase on the world boxes grown by margin / 2, then
 *   bounding spheres and the six face axes within margin)
 *   -> the predictor (cc_predict: point and normal in A's frame, A = the lower body index)
 *   -> the force law (a Winkler foundation over the face overlap with Hunt-Crossley
 *      dissipation, linearly implicit: the touching pairs solved together by projected
 *      Gauss-Seidel sweeps warm-started from the last step; anchored stick friction capped at
 *      mu fn, or regularised Coulomb; regularised torsional friction; all explicit)
 *   -> wrenches on both bodies of every pair.
 * testbed/effects/learned_dynamics/README.md derives the law; these are its numerics.
 *
 * Two ways to call it:
 *   - fused: cc_contact_step(model, step, ...): the shipped predictor (a cc_model) inside;
 *   - split, for another predictor (a user's ONNX or Python model): cc_step_candidates (broad
 *     phase and each candidate pair's pose p_AB, R_AB; read them with cc_step_view), with
 *     sleeping on cc_step_sleep_plan (which candidates to ask), the caller's predictor on those
 *     poses, then cc_step_force_law with its point_A, normal_A.
 * Both give the same answers for the same predictor answers.
 *
 * Units SI: [m], [s], [kg], [N], [N m]. Frames (Drake's monogram notation): W the world; B a
 * body's frame, origin Bo at the box's centre, axes along its edges (the geometry is a box of
 * full extents size centred at Bo; the centre of mass may be elsewhere: inertias are about
 * Bo). For a pair, A is the body of the lower index, B the higher; p_AB is B's origin in A,
 * R_AB B's orientation in A. All arrays float64 (int64 / uint8 where said), C-contiguous,
 * row-major: R (m, 3, 3) is m row-major 3x3 matrices, R[i][r][c] = R + 9 i + 3 r + c, with
 * v_W = R_WB v_B. Wrench rows are (torque about the body origin Bo [N m], force [N]), in W.
 *
 * Memory: cc_step_create allocates the step (a copy of the scene, the held state, a workspace
 * that grows with the candidate pairs to the most seen, then stays); nothing else allocates.
 * One cc_step per thread; distinct cc_steps are independent.
 */
#ifndef CONTAINER_CONTACT_STEP_H
#define CONTAINER_CONTACT_STEP_H

#include <stddef.h>
#include <stdint.h>

#include "container_contact.h"

#ifdef __cplusplus
extern "C" {
#endif

#define CC_STEP_ROW 8    /* a held pair's row: anchor in A (3), anchor in B (3) [m], stuck (1), fn [N] (1) */
#define CC_STEP_BODY 12  /* a body's history row: v_W (3), w_W (3) [m/s, rad/s], tau_W (3), f_W (3) [N m, N] */
#define CC_STEP_NO_MEMORY 32  /* a status beside enum cc_status: an allocation failed */

/* The bodies, fixed for the step's life. n_bodies = m. */
typedef struct cc_step_scene {
  size_t n_bodies;
  const double *size;        /* (m, 3) full box extents [m] (each a size the predictor supports) */
  const uint8_t *free;       /* (m) 1 = a free body, 0 = fixed (world-welded: never moves) */
  const double *mass;        /* (m) [kg]; INFINITY (or any non-finite value) for a fixed body */
  const double *I_Bo;        /* (m, 3, 3) rotational inertia about Bo in B [kg m^2]; unused for fixed bodies */
  const int64_t *type_index; /* (m) each body's row of params.kappa (0 <= t < n_types); NULL = all 0 */
} cc_step_scene;

/* The force law's parameters (the testbed's LearnedDynamicsConfig; its defaults in brackets). */
typedef struct cc_step_params {
  double margin;        /* [m] candidate margin: boxes closer than this are predicted [0.05] */
  double h;             /* [s] the simulator's time step (> 0) */
  double dissipation;   /* [s/m] Hunt-Crossley d [5.0] */
  double mu;            /* [-] Coulomb friction coefficient; 0 = frictionless [0.4] */
  double stick_hw;      /* [-] stick spring: k_t = stick_hw^2 m_red / h^2; 0 = regularised Coulomb [0.3] */
  double stick_zeta;    /* [-] stick damping ratio: c_t = 2 stick_zeta stick_hw m_red / h [0.5] */
  double slip;          /* [m/s] regularisation speed of the regularised Coulomb and torsional laws (> 0) [1e-4] */
  double stiction;      /* [-] cap of h c / m_red of the regularised laws, in [0, 1] [0.5] */
  int torsional;        /* 1 = regularised torsional friction about the normal, 0 = none [1] */
  int grid;             /* the elastic force: 0 = the exact field contact at any pose (cc_static_contact),
                         * with Hunt-Crossley's torque from its damping inertia [0]; >= 1: the Winkler
                         * foundation on the face overlap with that many midpoints (cc_step_elastic;
                         * right only on level, aligned faces), damped at the point only */
  int sweeps;           /* projected Gauss-Seidel sweeps of the implicit normal force (>= 1) [4] */
  int n_types;          /* rows of kappa (>= 1) */
  const double *kappa;  /* (n_types, n_types) [Pa/m] Winkler foundation stiffness per type pair, symmetric;
                           the pair (i, j) uses kappa[type_index[i] * n_types + type_index[j]]. Per
                           body pair: n_types = m, type_index = 0..m-1. Copied by cc_step_create. */
} cc_step_params;

/* The testbed's defaults (LearnedDynamicsConfig's, the values in brackets above) for a simulator
 * stepping at h [s]: one container type pair with the fitted kappa at the law's 1e8 Pa
 * (4.1017e7 Pa/m, the same for every shipped ISO type pair; type_index NULL). Set mu to the
 * simulator's friction and n_types / kappa for other moduli or sizes. (Box2D's b2DefaultWorldDef habit.) */
CC_API cc_step_params cc_step_default_params(double h);

typedef struct cc_step cc_step; /* opaque: scene, parameters, held state, workspace */

/* Copies scene and params (checked: finite sizes > 0, h > 0, grid >= 0, sweeps >= 1, kappa finite
 * >= 0, type_index in range); NULL with *status (may be NULL) CC_BAD_ARGUMENT or
 * CC_STEP_NO_MEMORY. The held state starts empty (cc_step_forget). */
CC_API cc_step *cc_step_create(const cc_step_scene *scene, const cc_step_params *params, int *status);
CC_API void cc_step_free(cc_step *step);
/* The scene's body count m. */
CC_API size_t cc_step_n_bodies(const cc_step *step);
/* Replaces the parameters (same checks; the scene and held state stay). */
CC_API int cc_step_set_params(cc_step *step, const cc_step_params *params);
/* Forgets the held state: no pair held, no body's last step (as before the first step). */
CC_API void cc_step_forget(cc_step *step);

/* The fused step. p_WB (m, 3) [m] body origins in W; R_WB (m, 3, 3); w_WB (m, 3) [rad/s]
 * angular velocities in W; v_WB (m, 3) [m/s] velocities of the body origins Bo in W (a fixed
 * body's rows are read for its pose; its velocities should be 0). Writes wrench_W (m, 6):
 * per body (torque about Bo [N m], force [N]) in W, the sum over its pairs (0 for a body in
 * no contact). With sleeping on (cc_step_set_sleep) the predictor is asked only about the
 * candidates of awake islands (cc_step_sleep_plan). Commits the held state for the next call
 * (see cc_step_held_get). Returns
 * CC_OK, or cc_predict's status (then *bad_row (may be NULL) is the candidate pair's row, the
 * wrenches are zero and the held state is unchanged), or CC_STEP_NO_MEMORY. */
CC_API int cc_contact_step(const cc_model *model, cc_step *step, const double *p_WB, const double *R_WB,
                    const double *w_WB, const double *v_WB, double *wrench_W, size_t *bad_row);
/* A predictor of the caller's own (a user's ONNX model through onnxruntime's C API, a network in C, ...)
 * for cc_contact_step_with: answers n pairs, p_AB (n, 3) [m], R_AB (n, 3, 3), size_A, size_B (n, 3) full
 * extents [m] (A's frame, as cc_predict), writing point_A and normal_A (n, 3) (the point in A [m], the unit
 * normal from A into B). Returns CC_OK, or any other status (then *bad_row, if it sets it, names the pair:
 * the step's wrenches are zero and its held state unchanged, as for cc_predict's refusal). user: the
 * caller's pointer, passed through. Called once per step with the candidates sleeping leaves to ask. */
typedef int (*cc_predict_fn)(void *user, size_t n, const double *p_AB, const double *R_AB, const double *size_A,
                             const double *size_B, double *point_A, double *normal_A, size_t *bad_row);

/* cc_contact_step with the caller's predictor instead of a cc_model: the same candidates, sleeping, force
 * law and held state; with cc_predict wrapped in a cc_predict_fn it gives cc_contact_step's answers.
 * CC_BAD_ARGUMENT for a NULL predict. */
CC_API int cc_contact_step_with(cc_predict_fn predict, void *user, cc_step *step, const double *p_WB,
                                const double *R_WB, const double *w_WB, const double *v_WB, double *wrench_W,
                                size_t *bad_row);

/* cc_contact_step, timed: seconds (3) [s] receives the wall time (C11 timespec_get) of the
 * candidates, the predictor and the force law, for a host that reports the predictor's share. */
CC_API int cc_contact_step_timed(const cc_model *model, cc_step *step, const double *p_WB, const double *R_WB,
                          const double *w_WB, const double *v_WB, double *wrench_W, size_t *bad_row,
                          double seconds[3]);

/* Split step, part 1: the candidate pairs of the poses p_WB, R_WB (kept for part 2); *n_pairs
 * their count k. cc_step_view then gives ia, ib, p_AB, R_AB, size_A, size_B of each. */
CC_API int cc_step_candidates(cc_step *step, const double *p_WB, const double *R_WB, size_t *n_pairs);
/* Split step, part 2: the force law on the last cc_step_candidates' pairs, with the
 * predictor's point_A (k, 3) [m] (A's frame) and unit normal_A (k, 3) (A's frame, from A into
 * B) of each (NULL when k = 0); the velocities as in cc_contact_step. Writes wrench_W (m, 6)
 * and commits the held state, as cc_contact_step. Returns CC_OK, or CC_BAD_ARGUMENT (a null
 * array, or no cc_step_candidates since the last force law: run the two parts in turn). */
CC_API int cc_step_force_law(cc_step *step, const double *w_WB, const double *v_WB, const double *point_A,
                      const double *normal_A, double *wrench_W);

/* cc_step_force_law with the caller's own elastic answer per candidate pair instead of the law's
 * (params.grid): elastic (k, 3) rows (F [N] the normal force magnitude along normal_A, 0 where
 * apart; dF/dd [N/m] its normal stiffness, for the implicit step; area [m^2] the contact's, for the
 * torsional friction's radius, 0 for none), at the modulus the scene runs at. The law's damping
 * (Hunt-Crossley on F, at the point: no surface torque without the field's second moment) and
 * friction act on it as on the law's own. Every value must be finite (else CC_BAD_ARGUMENT). */
CC_API int cc_step_force_law_given(cc_step *step, const double *w_WB, const double *v_WB, const double *point_A,
                            const double *normal_A, const double *elastic, double *wrench_W);

/* The latest step's candidate pairs (k of them, A = ia < B = ib), borrowed from the step:
 * valid until its next call. The force law's fields are zero until cc_step_force_law or
 * cc_contact_step has run on these pairs. */
typedef struct cc_step_pairs {
  size_t n;                  /* k */
  const int64_t *ia, *ib;    /* (k) body indices, ascending by (ia, ib) */
  const double *p_AB;        /* (k, 3) [m] */
  const double *R_AB;        /* (k, 3, 3) */
  const double *size_A, *size_B; /* (k, 3) [m] full extents */
  const double *point_A, *normal_A; /* (k, 3) the predictor's answers used (A's frame) */
  const double *fn;          /* (k) [N] normal force (0 = not touching) */
  const double *f_W;         /* (k, 3) [N] total force on B (normal + friction), in W, at p_W (minus it on A) */
  const double *p_W;         /* (k, 3) [m] contact point in W (0 where not touching) */
  const double *n_W;         /* (k, 3) unit normal A -> B in W (0 where not touching) */
  const double *area;        /* (k) [m^2] face-overlap area */
  size_t n_broad;            /* the broad phase's candidates before the narrow tests (>= k) */
} cc_step_pairs;
CC_API void cc_step_view(const cc_step *step, cc_step_pairs *out);

/* The held state, for a host that keeps it itself (Drake's abstract state): s pairs held
 * (those stuck or with positive normal force at the last step), keys (s) int64 = ia * m + ib
 * ascending, rows (s, CC_STEP_ROW): the stick's material points in A's and B's frames [m],
 * stuck flag (1.0 / 0.0), the last normal force [N] (the next solve's warm start); history
 * (m, CC_STEP_BODY): each body's v_W, w_W at the last step and the normal wrench (tau_W, f_W)
 * the law applied then; a row of NaN = no last step. */
CC_API size_t cc_step_held_count(const cc_step *step);
CC_API void cc_step_held_get(const cc_step *step, int64_t *keys, double *rows, double *history);
/* Replaces the held state (copied); CC_BAD_ARGUMENT if keys do not ascend or a key is out of
 * range (then the state is unchanged). history may be NULL: no body's last step. */
CC_API int cc_step_held_set(cc_step *step, size_t s, const int64_t *keys, const double *rows, const double *history);

/* ---------------------------------------------------------------- sleeping
 * A settled yard's contacts need not be asked again every step. With sleeping enabled
 * (cc_step_set_sleep; off at cc_step_create), each step:
 *   - a free body is at rest when |v_WB| < v_sleep and |w_WB| < w_sleep; its rest time grows
 *     by h per step at rest and drops to 0 otherwise;
 *   - islands: the connected components of the candidate pairs over the free bodies (a fixed
 *     body never joins two islands); a pair with a fixed body belongs to its free body's;
 *   - an island whose bodies have all been at rest for t_sleep falls asleep: that step its
 *     pairs are still asked and each body's pose is kept as its sleeping pose;
 *   - an asleep island's pairs are not asked: each reuses the answer (point_A, normal_A) it got
 *     at the previous step, while the force law runs on the current poses and velocities;
 *   - it wakes (its pairs are asked) when any body leaves rest, when a body has moved from its
 *     sleeping pose by more than eps_p at any point of its box (|dp| + angle x the half
 *     diagonal) or turned by more than eps_R, when a candidate pair of the island was not a
 *     candidate at the previous step (a new contact, a link to another island: an awake body
 *     touching it joins its island and wakes it), or when the host wakes a body
 *     (cc_step_sleep_wake: a rope or another external force changes). A woken island whose
 *     bodies are still at rest falls asleep again at once at its new poses, so a reused answer
 *     is never from poses further than eps_p / eps_R from the current ones.
 * Pair reuse (pair_reuse = 1; off unless set): besides the asleep islands, a candidate pair of
 * an awake island whose answer was kept at the previous step reuses it when B's pose in A is
 * within eps_p at any point of B's box (|dp_AB| + angle x B's half diagonal) and eps_R in angle
 * of the pose that answer was asked at (half the relative motion island sleeping allows: each
 * of its two bodies may move eps_p), unless the host woke one of its bodies since. The answer
 * is a function of the pair's relative pose alone, so the bound holds at any speed; a moving
 * pair is asked again as soon as it has moved that far.
 * The sleeping state lives in the step (not in cc_step_held_get's held state): cc_step_forget
 * and cc_step_sleep_reset clear it. */
typedef struct cc_step_sleep {
  int enabled;    /* 1 = sleeping on */
  double v_sleep; /* [m/s] rest speed of the body origin (>= 0) */
  double w_sleep; /* [rad/s] rest angular speed (>= 0) */
  double t_sleep; /* [s] time at rest before an island sleeps (>= 0) */
  double eps_p;   /* [m] largest motion of any point of a sleeping body before its island wakes (>= 0) */
  double eps_R;   /* [rad] largest rotation of a sleeping body before its island wakes (>= 0) */
  int pair_reuse; /* 1 = pair reuse (above) too; 0 = island sleeping alone */
} cc_step_sleep;

/* The testbed's sleeping defaults (its SleepingConfig: on, rest below 1e-3 m/s and 1e-3 rad/s for 0.3 s,
 * woken at 0.1 mm or 1e-6 rad, no pair reuse; testbed/effects/learned_dynamics/step.py says why each). */
CC_API cc_step_sleep cc_step_default_sleep(void);

/* The latest step's sleeping figures. */
typedef struct cc_step_sleep_counts {
  size_t asked;          /* candidate pairs the predictor was asked about */
  size_t reused;         /* candidate pairs that reused their last answer (asleep, or by pair reuse) */
  size_t islands;        /* islands with at least one candidate pair */
  size_t islands_asleep; /* of those, asleep */
  size_t bodies_asleep;  /* free bodies in asleep islands (those with a candidate pair) */
} cc_step_sleep_counts;

/* Sets the sleeping parameters (NULL = off); CC_BAD_ARGUMENT for a negative or non-finite
 * figure (then nothing changes). Turning it off or on clears the sleeping state. */
CC_API int cc_step_set_sleep(cc_step *step, const cc_step_sleep *sleep);
/* Clears the sleeping state: every body awake with no rest time, no answer kept. */
CC_API void cc_step_sleep_reset(cc_step *step);
/* The host wakes bodies (n of them, body indices): their islands are asked at the next step. */
CC_API void cc_step_sleep_wake(cc_step *step, size_t n, const int64_t *bodies);
/* Split step, between cc_step_candidates and the predictor: updates the rest times and the
 * islands with the step's velocities w_WB, v_WB (m, 3) (as cc_contact_step's) and writes
 * ask (k): 1 = ask the predictor about this candidate, 0 = asleep: its last answer is already
 * in the view's point_A, normal_A (cc_step_view). Pass cc_step_force_law point_A, normal_A
 * (k, 3) holding the predictor's answers on the asked rows and these on the others.
 * *n_asked (may be NULL) counts the 1s. With sleeping off every row is asked. The fused
 * cc_contact_step does all this itself. CC_BAD_ARGUMENT without candidates. */
CC_API int cc_step_sleep_plan(cc_step *step, const double *w_WB, const double *v_WB, uint8_t *ask, size_t *n_asked);
CC_API void cc_step_sleep_get_counts(const cc_step *step, cc_step_sleep_counts *out);

/* The exact static hydroelastic contact of two compliant boxes at one pose, any orientation
 * (corners, edges, any yaw; native/src/step_field.c): the integrals of Drake's medial-axis pressure
 * fields over their equal-pressure surface, in A's frame. */
typedef struct cc_field_contact {
  double force[3];          /* [N] on B, the integral of p n dA (n from A into B) */
  double moment[3];         /* [N m] about A's origin */
  double cop[3];            /* [m] the centre of pressure (zeros without a surface) */
  double first_moment[3];   /* [N m] the integral of p x dA */
  double pressure_integral; /* [N] the integral of p dA */
  double area;              /* [m^2] the surface's area */
  double dforce_ddepth[9];  /* [N/m] row-major J: d(force) = J u dd when B moves by -u dd */
  double stiffness;         /* [N/m] n . J n along the force's direction n: dF/dd */
  double damping_inertia[9]; /* [N m^2] row-major: the integral of p (r x m)(r x m)^T dA, r from the centre of
                              * pressure, m the surface's normal: Hunt-Crossley's torque on B is
                              * -d damping_inertia (w_B - w_A) (d [s/m]; the force's part is d F v_n) */
  int pieces;               /* cell pairs carrying part of the surface */
} cc_field_contact;

/* p_AB (3) [m], R_AB (9, row-major), half extents hA, hB (3) [m], moduli [Pa]; *out zeroed apart. */
CC_API void cc_static_contact(const double p_AB[3], const double R_AB[9], const double hA[3], const double hB[3],
                       double modulus_A, double modulus_B, cc_field_contact *out);

/* The force law's elastic part for one pose (p_AB (3) [m], R_AB (9), half extents hA, hB (3)
 * [m]): out[0] the Winkler foundation force kappa x the penetration volume over the face
 * overlap [N], out[1] the overlap area [m^2], out[2] the normal stiffness dF/dd = kappa x the
 * wetted area [N/m]; on the face pair of least overlap among the six face axes; zeros when
 * that overlap is not positive. grid: quadrature points across the overlap (>= 1). */
CC_API void cc_step_elastic(const double p_AB[3], const double R_AB[9], const double hA[3], const double hB[3],
                     double kappa, int grid, double out[3]);

/* ---------------------------------------------------------------- host helpers
 * Body state from a host's arrays and wrenches back; m bodies. */

/* Drake: x the plant state [q; v] (quaternion floating joints: q = [w x y z, p_WB], v =
 * [w_WB, v_WB]); q_start, v_start (m) each free body's first index in x (v_start counted from
 * x[0], i.e. num_positions + the velocity start); fixed bodies (free[i] = 0) take fixed_p
 * (m, 3), fixed_R (m, 3, 3) and zero velocity. Writes p, R, w, v (m, 3 / 3x3). */
CC_API void cc_step_bodies_from_drake(size_t m, const double *x, const int64_t *q_start, const int64_t *v_start,
                               const double *fixed_p, const double *fixed_R, const uint8_t *free,
                               double *p_WB, double *R_WB, double *w_WB, double *v_WB);
/* MuJoCo (after mj_step1): xpos (nbody, 3), xmat (nbody, 9), qvel (nv); body (m) each body's
 * id; dof (m) each free body's free joint's first dof (qvel[dof..]: v_W of Bo, w in B), -1 if
 * fixed. Writes p, R, w (in W), v. */
CC_API void cc_step_bodies_from_mujoco(size_t m, const double *xpos, const double *xmat, const double *qvel,
                                const int64_t *body, const int64_t *dof, const uint8_t *free,
                                double *p_WB, double *R_WB, double *w_WB, double *v_WB);
/* MuJoCo: xfrc_applied (nbody, 6) [force, torque about the COM xipos, in W] of each free body
 * from wrench_W (m, 6) (torque about Bo = xpos, force); every other row zeroed. */
CC_API void cc_step_wrench_to_mujoco(size_t m, size_t nbody, const double *wrench_W, const int64_t *body,
                              const uint8_t *free, const double *xpos, const double *xipos, double *xfrc_applied);

#ifdef __cplusplus
}
#endif
#endif /* CONTAINER_CONTACT_STEP_H */
