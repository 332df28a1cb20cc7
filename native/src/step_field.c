/* step_field.c: the exact static hydroelastic contact of two compliant boxes at any pose
 * (cc_static_contact; the force law's elastic part and its rotational damping, ccs_field_stiff).
 *
 * Each box's pressure is E d_f(x) / min(h) inside cell f (the points nearer face f than any other),
 * the piecewise-linear field Drake's medial-axis mesh carries exactly. Inside one cell pair (f of A,
 * g of B) the surface p_A = p_B is a flat convex polygon: the plane clipped by the two cells' twelve
 * half-spaces (Sutherland-Hodgman, from a square larger than both boxes). p is linear on it, so the
 * force is p(centroid) x area along the plane's normal, and the centre of pressure a per-triangle
 * closed form: exact, as the reference testbed/geometry/box_pressure.py (vertex enumeration, numpy)
 * and Drake's own surface (its tetrahedra cut the same linear pieces finer) agree.
 *
 * The normal stiffness dF/dd, B moved by -n (n: the force's direction, A into B), in closed form:
 * per polygon, its pressure rises uniformly (the plane moves by s = (gB . n) / ((gA - gB) . m) along
 * its normal m) and each edge on a cell boundary moves within the plane by
 * v = (db - (a . m) s) / (a . nu), nu the edge's outward in-plane normal, db = -(a . n) for B's own
 * half-spaces (they move with B) and 0 for A's. So dP/dd = area x dp + sum over edges of v x (the
 * integral of p along the edge); edges on the boxes' surfaces carry p = 0. */
#include <math.h>
#include <string.h>

#include "step_internal.h"

#define MAXV 20 /* 4 + 12 clips */

typedef struct {
  double x[MAXV][3];
  int on[MAXV]; /* the half-space whose plane holds edge (x[i], x[i+1]); -1: the start square */
  int n;
} polygon;

static double dot3(const double *a, const double *b);

/* Clips *P by a . x <= b (half-space index id) into *out; returns out's vertex count, or -1 when *P is
 * kept whole (out untouched: no copy). */
static int clip(const polygon *P, polygon *out, const double a[3], double b, int id) {
  out->n = 0;
  double sl[MAXV]; /* each vertex's slack, once */
  /* A half-space whose slack is the same over the whole polygon but for round-off (its plane parallel
   * to the polygon's) keeps all of it or none: round-off must not decide a cut. A polygon lying ON the
   * plane (slack zero within round-off) is kept for B's half-spaces and dropped for A's: two aligned
   * boxes of one width put the surface of each end cell exactly on a medial plane, of B's (cells A+y,
   * B-z) and of A's (A+z, B+y) alike; each one-sided limit (B a hair wider or narrower) holds one of the
   * two, of the same pressure, so exactly one is counted. Any tilt the slacks resolve is cut exactly
   * below, which finds where along the rim one piece gives way to the other. */
  double least = INFINITY, most = -INFINITY, size = fabs(b);
  for (int i = 0; i < P->n; ++i) {
    const double *x = P->x[i];
    sl[i] = a[0] * x[0] + a[1] * x[1] + a[2] * x[2] - b;
    least = py_min(least, sl[i]);
    most = py_max(most, sl[i]);
    size = py_max(size, fabs(a[0] * x[0]) + fabs(a[1] * x[1]) + fabs(a[2] * x[2]));
  }
  if (most <= 0 && most - least > 0) return -1; /* wholly inside, not a round-off case: nothing to cut */
  /* the slacks' round-off, and no less than 0.1 nm: a plane within 1e-8 rad of a rim piece's (tilts a
   * resting stack sits at) is taken as that piece's own; the exact cut there moved the force by 4e-5
   * between poses 1e-14 rad apart, the piece's share at most O(tilt) */
  double tol = py_max(64 * 2.220446049250313e-16 * (1.0 + size), 1e-10 * sqrt(dot3(a, a)));
  if (most - least <= tol) {
    int on_plane = most <= tol && least >= -tol;
    return (on_plane ? id < 6 : least > 0) ? 0 : -1;
  }
  if (least > 0) return 0; /* wholly outside */
  for (int i = 0; i < P->n; ++i) {
    int j = (i + 1) % P->n;
    const double *xi = P->x[i], *xj = P->x[j];
    double si = sl[i], sj = sl[j];
    /* exact signs, no tolerance: an edge is cut only where its ends lie on opposite sides, so the cut
     * lies on it (t in [0, 1]); a tolerance here once let a plane nearly parallel to the polygon
     * (t from two round-off-sized slacks) put a vertex metres outside an earlier half-space */
    int in_i = si <= 0, in_j = sj <= 0;
    if (in_i) {
      if (out->n >= MAXV) return out->n = 0;
      memcpy(out->x[out->n], xi, sizeof(double[3]));
      out->on[out->n] = P->on[i]; /* the edge leaving x_i keeps its plane until cut */
      ++out->n;
    }
    if (in_i != in_j) {
      double t = py_min(1.0, py_max(0.0, si / (si - sj)));
      if (out->n >= MAXV) return out->n = 0;
      for (int c = 0; c < 3; ++c) out->x[out->n][c] = xi[c] + t * (xj[c] - xi[c]);
      /* entering (out -> in): the new vertex starts the rest of edge i (its plane);
       * leaving (in -> out): the new vertex starts the clip edge (plane id) */
      out->on[out->n] = in_i ? id : P->on[i];
      ++out->n;
    }
  }
  return out->n;
}

/* Cell f of a box of half extents h: rows a . x <= b in its own frame (a[6][3], b[6]). */
static void cell(const double *h, int f, double a[6][3], double b[6]) {
  int axis = f / 2;
  double side = (f % 2) ? -1.0 : 1.0;
  memset(a, 0, sizeof(double[6][3]));
  a[0][axis] = side;
  b[0] = h[axis];
  int row = 1;
  for (int g = 0; g < 6; ++g) {
    if (g == f) continue;
    int ax = g / 2;
    double s = (g % 2) ? -1.0 : 1.0;
    a[row][ax] += s;
    a[row][axis] -= side;
    b[row] = h[ax] - h[axis];
    ++row;
  }
}

/* May cell f of a box (half extents h) meet the axis-aligned box [lo, hi] of its frame? (necessary:
 * somewhere in it d_f <= d_g, for each g on its own). */
static int cell_may_meet(const double *lo, const double *hi, const double *h, int f) {
  int axis = f / 2;
  double min_df = h[axis] - ((f % 2) ? -lo[axis] : hi[axis]);
  for (int ax = 0; ax < 3; ++ax) {
    double min_abs = (lo[ax] <= 0 && hi[ax] >= 0) ? 0.0 : py_min(fabs(lo[ax]), fabs(hi[ax]));
    double max_d = h[ax] - min_abs;
    for (int s = 0; s < 2; ++s)
      if (2 * ax + s != f && min_df > max_d + 1e-12) return 0;
  }
  return 1;
}

static double dot3(const double *a, const double *b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }

static void cross3(const double *a, const double *b, double *c) {
  c[0] = a[1] * b[2] - a[2] * b[1];
  c[1] = a[2] * b[0] - a[0] * b[2];
  c[2] = a[0] * b[1] - a[1] * b[0];
}

/* One cell pair's polygon: its area, pressure integral P, first moment Px, and for the stiffness,
 * per unit depth along u: the rise of P (dP). gA, cA: p_A = gA . x + cA; gB, cB likewise (A's frame). */
typedef struct {
  double m[3], P, Px[3], S2[9]; /* normal, integral of p, of p x, of p x x^T */
} piece;

typedef struct {
  piece at[40];
  int n;
} pieces;

/* Does the plane m . x = c miss the box [lo, hi] (all eight corners strictly on one side)? */
static int plane_misses_box(const double m[3], double c, const double lo[3], const double hi[3]) {
  double least = 0, most = 0; /* the extremes of m . x - c over the box */
  for (int k = 0; k < 3; ++k) {
    double a = m[k] * lo[k], b = m[k] * hi[k];
    least += py_min(a, b);
    most += py_max(a, b);
  }
  return least - c > 1e-12 || most - c < -1e-12;
}

/* The box of cell f of a box with half extents h, within [lo, hi] (its own frame): along f's axis a the
 * cell lies where s x_a is between max(0, h_a - min of the other h) and h_a, and its part in [lo, hi]
 * within D of face f, D the largest distance to the boundary anywhere in [lo, hi] (at most the least
 * over the axes of h_k - min |x_k|: a thin overlap keeps each cell's part thin). 0 when empty. */
static int cell_box(const double *h, int f, const double *lo, const double *hi, double *clo, double *chi) {
  int a = f / 2;
  double s = (f % 2) ? -1.0 : 1.0, other = INFINITY, D = INFINITY;
  for (int b = 0; b < 3; ++b) {
    if (b != a) other = py_min(other, h[b]);
    double min_abs = (lo[b] <= 0 && hi[b] >= 0) ? 0.0 : py_min(fabs(lo[b]), fabs(hi[b]));
    D = py_min(D, h[b] - min_abs);
  }
  double near = py_max(0.0, py_max(h[a] - other, h[a] - D - 1e-12));
  for (int k = 0; k < 3; ++k) {
    clo[k] = lo[k];
    chi[k] = hi[k];
  }
  if (s > 0) clo[a] = py_max(clo[a], near);
  else chi[a] = py_min(chi[a], -near);
  return clo[a] <= chi[a];
}

static void cell_pair(const double aH[12][3], const double bH[12], const double gA[3], double cA, const double gB[3],
                      double cB, double ext, cc_field_contact *out, pieces *kept, const double *boxA, const double *boxB,
                      const double *p, const double *R) {
  double diff[3] = {gA[0] - gB[0], gA[1] - gB[1], gA[2] - gB[2]};
  double norm = sqrt(dot3(diff, diff));
  /* where the two fields (nearly) coincide (the end cells of two aligned boxes of one width, side by
   * side in a stack) p_A = p_B holds on a volume, not a surface: the plane is round-off's choice, and
   * its sliver's force jumped by 4e-5 of a stack's weight between poses 1e-12 rad apart (a standing
   * vibration of 1e-6 m/s in the loop). Their limit, no surface, is taken below a gradient difference
   * of 1e-6 of the gradients (fields tilted 1e-6 rad apart). */
  if (!(norm > 1e-6 * (sqrt(dot3(gA, gA)) + sqrt(dot3(gB, gB))))) return;
  double m[3] = {-diff[0] / norm, -diff[1] / norm, -diff[2] / norm}; /* A into B */
  double c = (cA - cB) / norm;                                       /* m . x = c */
  /* the plane must cross both cells' boxes within the overlap (A's in A's frame, B's in B's) */
  if (plane_misses_box(m, c, boxA, boxA + 3)) return;
  double mB[3] = {R[0] * m[0] + R[3] * m[1] + R[6] * m[2], R[1] * m[0] + R[4] * m[1] + R[7] * m[2],
                  R[2] * m[0] + R[5] * m[1] + R[8] * m[2]};
  if (plane_misses_box(mB, c - dot3(m, p), boxB, boxB + 3)) return;
  double t[3] = {fabs(m[0]) < 0.9 ? 1.0 : 0.0, fabs(m[0]) < 0.9 ? 0.0 : 1.0, 0.0}, e1[3], e2[3];
  cross3(m, t, e1);
  double l1 = sqrt(dot3(e1, e1));
  for (int k = 0; k < 3; ++k) e1[k] /= l1;
  cross3(m, e1, e2);
  polygon buf[2], *cur = &buf[0], *nxt = &buf[1];
  polygon P;
  P.n = 4;
  static const double corner[4][2] = {{-1, -1}, {1, -1}, {1, 1}, {-1, 1}};
  for (int i = 0; i < 4; ++i) {
    for (int k = 0; k < 3; ++k) P.x[i][k] = c * m[k] + ext * (corner[i][0] * e1[k] + corner[i][1] * e2[k]);
    P.on[i] = -1;
  }
  *cur = P;
  for (int r = 0; r < 12 && cur->n >= 3; ++r) {
    if (clip(cur, nxt, aH[r], bH[r], r) < 0) continue;
    polygon *t = cur;
    cur = nxt;
    nxt = t;
  }
  if (cur->n < 3) return;
  P = *cur;
  double area = 0, Pint = 0, Px[3] = {0, 0, 0}, S2[9] = {0};
  const double *x0 = P.x[0];
  double p0 = dot3(gA, x0) + cA;
  for (int i = 1; i + 1 < P.n; ++i) {
    const double *x1 = P.x[i], *x2 = P.x[i + 1];
    double d1[3] = {x1[0] - x0[0], x1[1] - x0[1], x1[2] - x0[2]}, d2[3] = {x2[0] - x0[0], x2[1] - x0[1], x2[2] - x0[2]}, cr[3];
    cross3(d1, d2, cr);
    double A = 0.5 * fabs(dot3(cr, m));
    double p1 = dot3(gA, x1) + cA, p2 = dot3(gA, x2) + cA;
    area += A;
    Pint += A * (p0 + p1 + p2) / 3.0;
    for (int k = 0; k < 3; ++k)
      Px[k] += A / 12.0 * ((p0 + p1 + p2) * (x0[k] + x1[k] + x2[k]) + p0 * x0[k] + p1 * x1[k] + p2 * x2[k]);
    /* the integral of p x x^T over the triangle: the sum over vertex triples (a, b, c) of p_c x_a x_b^T
     * times the integral of l_a l_b l_c (barycentric: A/10 all equal, A/30 two equal, A/60 all
     * different), i.e. A/60 [P (S S^T + sum x x^T) + S Q^T + Q S^T + 2 sum p x x^T] with P = sum p,
     * S = sum x, Q = sum p x */
    const double *xv[3] = {x0, x1, x2};
    double pv[3] = {p0, p1, p2}, Ps = p0 + p1 + p2, S[3], Q[3];
    for (int k = 0; k < 3; ++k) {
      S[k] = x0[k] + x1[k] + x2[k];
      Q[k] = p0 * x0[k] + p1 * x1[k] + p2 * x2[k];
    }
    for (int k = 0; k < 3; ++k)
      for (int l = 0; l < 3; ++l) {
        double sum = Ps * S[k] * S[l] + S[k] * Q[l] + Q[k] * S[l];
        for (int a = 0; a < 3; ++a) sum += (Ps + 2.0 * pv[a]) * xv[a][k] * xv[a][l];
        S2[3 * k + l] += A / 60.0 * sum;
      }
  }
  if (!(area > 0)) return;
  if (kept->n < 40) {
    piece *pc = &kept->at[kept->n++];
    memcpy(pc->m, m, sizeof(double[3]));
    pc->P = Pint;
    memcpy(pc->Px, Px, sizeof(double[3]));
    memcpy(pc->S2, S2, sizeof(double[9]));
  }
  for (int k = 0; k < 3; ++k) {
    out->force[k] += Pint * m[k];
    out->first_moment[k] += Px[k];
  }
  double mom[3];
  cross3(Px, m, mom);
  for (int k = 0; k < 3; ++k) out->moment[k] += mom[k];
  out->pressure_integral += Pint;
  out->area += area;
  out->pieces += 1;
  /* the stiffness, linear in B's displacement -u: dP = w . u, and d(force) = m (w . u) */
  double dm = dot3(diff, m); /* (gA - gB) . m = -norm */
  double gA_m = dot3(gA, m);
  double w[3]; /* area x dp/du: the plane moves by s = gB . u / dm, the pressure rises by gA . m s */
  for (int k = 0; k < 3; ++k) w[k] = area * gA_m * gB[k] / dm;
  double cr[3], d1[3], d2[3];
  for (int k = 0; k < 3; ++k) {
    d1[k] = P.x[1][k] - P.x[0][k];
    d2[k] = P.x[2][k] - P.x[0][k];
  }
  cross3(d1, d2, cr);
  double orient = dot3(cr, m) >= 0 ? 1.0 : -1.0; /* counter-clockwise about m: outward = edge x m */
  for (int i = 0; i < P.n; ++i) {
    int id = P.on[i];
    if (id < 0) continue;
    const double *xi = P.x[i], *xj = P.x[(i + 1) % P.n];
    double edge[3] = {xj[0] - xi[0], xj[1] - xi[1], xj[2] - xi[2]}, nu[3];
    double L = sqrt(dot3(edge, edge));
    if (!(L > 0)) continue;
    cross3(edge, m, nu);
    for (int k = 0; k < 3; ++k) nu[k] *= orient / L;
    double a_nu = dot3(aH[id], nu);
    if (fabs(a_nu) < 1e-12) continue;
    /* the edge's outward rate: v = (db - (a . m) s) / (a . nu), db = -a . u for B's half-spaces */
    double p_mid = 0.5 * (dot3(gA, xi) + dot3(gA, xj)) + cA; /* the integral of p along it over L */
    double a_m = dot3(aH[id], m), q = L * p_mid / a_nu;
    for (int k = 0; k < 3; ++k) w[k] += q * ((id >= 6 ? -aH[id][k] : 0.0) - a_m * gB[k] / dm);
  }
  for (int k = 0; k < 3; ++k)
    for (int l = 0; l < 3; ++l) out->dforce_ddepth[3 * k + l] += m[k] * w[l];
}

void cc_static_contact(const double p[3], const double R[9], const double hA[3], const double hB[3], double E_A,
                       double E_B, cc_field_contact *out) {
  memset(out, 0, sizeof(*out));
  /* in contact where no face axis separates them, as the law has always judged it (boxes that only
   * touch, at zero depth, would leave 1e-20 N of round-off in the integrals otherwise) */
  int owner, axis;
  if (!(ccs_face_axis_overlap(p, R, hA, hB, &owner, &axis) > 0)) return;
  /* the overlap's bounds in each frame */
  double loA[3], hiA[3], loB[3], hiB[3], pBA[3];
  for (int a = 0; a < 3; ++a) {
    double ext = fabs(R[3 * a]) * hB[0] + fabs(R[3 * a + 1]) * hB[1] + fabs(R[3 * a + 2]) * hB[2];
    loA[a] = py_max(p[a] - ext, -hA[a]);
    hiA[a] = py_min(p[a] + ext, hA[a]);
    pBA[a] = -(R[a] * p[0] + R[3 + a] * p[1] + R[6 + a] * p[2]);
  }
  for (int a = 0; a < 3; ++a) {
    double ext = fabs(R[a]) * hA[0] + fabs(R[3 + a]) * hA[1] + fabs(R[6 + a]) * hA[2];
    loB[a] = py_max(pBA[a] - ext, -hB[a]);
    hiB[a] = py_min(pBA[a] + ext, hB[a]);
  }
  for (int a = 0; a < 3; ++a)
    if (loA[a] > hiA[a] || loB[a] > hiB[a]) return; /* apart */
  pieces kept;
  kept.n = 0;
  double minA = py_min(hA[0], py_min(hA[1], hA[2])), minB = py_min(hB[0], py_min(hB[1], hB[2]));
  double ext = 4.0 * (hA[0] + hA[1] + hA[2] + hB[0] + hB[1] + hB[2]) + 2.0 * sqrt(dot3(p, p));
  for (int g = 0; g < 6; ++g) {
    double boxB[6];
    if (!cell_may_meet(loB, hiB, hB, g) || !cell_box(hB, g, loB, hiB, boxB, boxB + 3)) continue;
    double aB[6][3], bB[6];
    cell(hB, g, aB, bB);
    int axB = g / 2;
    double sB = (g % 2) ? -1.0 : 1.0, kB = E_B / minB;
    /* B's field and cell in A's frame: x_B = R^T (x - p) */
    double gB[3] = {-sB * kB * R[3 * 0 + axB], -sB * kB * R[3 * 1 + axB], -sB * kB * R[3 * 2 + axB]};
    double cB = kB * hB[axB] - dot3(gB, p);
    double aH[12][3], bH[12];
    for (int r = 0; r < 6; ++r) {
      for (int k = 0; k < 3; ++k) aH[6 + r][k] = R[3 * k] * aB[r][0] + R[3 * k + 1] * aB[r][1] + R[3 * k + 2] * aB[r][2];
      bH[6 + r] = bB[r] + dot3(aH[6 + r], p);
    }
    for (int f = 0; f < 6; ++f) {
      double boxA[6];
      if (!cell_may_meet(loA, hiA, hA, f) || !cell_box(hA, f, loA, hiA, boxA, boxA + 3)) continue;
      double aA[6][3], bA[6];
      cell(hA, f, aA, bA);
      for (int r = 0; r < 6; ++r) {
        memcpy(aH[r], aA[r], sizeof(double[3]));
        bH[r] = bA[r];
      }
      int axA = f / 2;
      double sA = (f % 2) ? -1.0 : 1.0, kA = E_A / minA;
      double gA[3] = {0, 0, 0};
      gA[axA] = -sA * kA;
      cell_pair((const double(*)[3])aH, bH, gA, kA * hA[axA], gB, cB, ext, out, &kept, boxA, boxB, p, R);
    }
  }
  if (!(out->pressure_integral > 0)) {
    memset(out, 0, sizeof(*out));
    return;
  }
  double F = sqrt(dot3(out->force, out->force));
  if (!(F > 0)) return;
  double n[3] = {out->force[0] / F, out->force[1] / F, out->force[2] / F}, Jn[3];
  for (int k = 0; k < 3; ++k) Jn[k] = dot3(out->dforce_ddepth + 3 * k, n);
  out->stiffness = dot3(Jn, n);
  for (int k = 0; k < 3; ++k) out->cop[k] = out->first_moment[k] / out->pressure_integral;
  /* the damping inertia about the centre of pressure c: per piece M (S2 - Px c^T - c Px^T + P c c^T) M^T,
   * M = [m]x (so that M r = m x r; (r x m)(r x m)^T = M r r^T M^T) */
  const double *c = out->cop;
  for (int q = 0; q < kept.n; ++q) {
    const piece *pc = &kept.at[q];
    double C[9], M[9] = {0, -pc->m[2], pc->m[1], pc->m[2], 0, -pc->m[0], -pc->m[1], pc->m[0], 0}, MC[9];
    for (int k = 0; k < 3; ++k)
      for (int l = 0; l < 3; ++l)
        C[3 * k + l] = pc->S2[3 * k + l] - pc->Px[k] * c[l] - c[k] * pc->Px[l] + pc->P * c[k] * c[l];
    for (int k = 0; k < 3; ++k)
      for (int l = 0; l < 3; ++l) MC[3 * k + l] = M[3 * k] * C[l] + M[3 * k + 1] * C[3 + l] + M[3 * k + 2] * C[6 + l];
    for (int k = 0; k < 3; ++k)
      for (int l = 0; l < 3; ++l)
        out->damping_inertia[3 * k + l] += MC[3 * k] * M[3 * l] + MC[3 * k + 1] * M[3 * l + 1] + MC[3 * k + 2] * M[3 * l + 2];
  }
}

/* The force law's elastic part: the exact field contact at the modulus the pair's kappa stands for
 * (two equal fields in series: kappa = E / (min h_A + min h_B)); *F = |force| [N], *area [m^2],
 * *k_n = dF/dd [N/m] (never below 0). */
void ccs_field_stiff(const double *p, const double *R, const double *hA, const double *hB, double kappa, double *F,
                     double *area, double *k_n, double *J) {
  double E = kappa * (py_min(hA[0], py_min(hA[1], hA[2])) + py_min(hB[0], py_min(hB[1], hB[2])));
  cc_field_contact c;
  cc_static_contact(p, R, hA, hB, E, E, &c);
  *F = sqrt(dot3(c.force, c.force));
  *area = c.area;
  *k_n = c.stiffness > 0 ? c.stiffness : 0.0;
  memcpy(J, c.damping_inertia, sizeof(double[9]));
}
