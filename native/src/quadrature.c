/* quadrature.c: the exact centre of pressure of a face-on-face contact for one pose (the C
 * twin of learned_contact.model.quadrature.face_on_face; read that module's docstring for what
 * is computed and why: the exact integral of Drake's linear pressure over its contact
 * surface, 16 polygons of pairs of fan triangles plus 32 edge slivers).
 *
 * Frames and units: A's frame; p (3) [m] B's centre in A, R (9) row-major (column j = B's
 * axis j in A), hA, hB (3) half extents [m], n (3) the separating-axis normal (unit, A->B)
 * that picks the two faces. "Face coordinates" are (x[uA], x[vA], sigma_A x[a]) of a point x
 * in A: the two in-plane axes of A's face and the height along its outward normal, so that
 * A's face is |u| <= hA[uA], |v| <= hA[vA] at height hA[a].
 *
 * The work follows the form the former numba kernel had: the sides of both faces' fan
 * triangles and the edge clips computed once per pose; a polygon pair skipped where its
 * area is zero by construction; a clip that keeps every vertex copies none; the weighted
 * means summed as they come. The arithmetic follows the numpy reference wherever a result
 * depends on its rounding (the clip distances, the polygon vertices, areas and pressure
 * moments, the sliver intervals, widths and fades: dot_lr and dot_c sum in the numpy path's
 * orders); the skipped pairs and strips are those whose weight is zero but for rounding.
 * Where the faces do not overlap (weight 0) the point is A's face centre's height with the
 * in-plane coordinates 0 and the normal the two face normals' bisector, as there. */
#include <math.h>

#include "cc_internal.h"

/* Rows of the per-pose scratch `frame` (16 x 3): A's fan corners (0-3), B's fan corners
 * (4-7), A's face centre (8), B's face centre (9) [m], A's face normal (10), B's face normal
 * towards A (11), all in A, and B's fan corners in face coordinates (12-15) [m]. */
enum { F_CA = 0, F_CB = 4, F_TOP = 8, F_CENTRE_B = 9, F_NA = 10, F_NB = 11, F_LOCAL_B = 12 };
/* Rows of `planes` (32 x 6): (normal (3), limit [m], a point's two in-plane coordinates [m])
 * of A's triangles' sides (i * 3 + k, 0-11), B's triangles' sides in A's face plane
 * (12 + j * 3 + k); (normal (3), limit) of the edge clips of B's edges (24 + j) and A's (28 + i). */
enum { P_SIDE_A = 0, P_SIDE_B = 12, P_EDGE_B = 24, P_EDGE_A = 28 };
/* Rows of `items` (11 x 12): the current clip's signed distance per vertex (0), the values of
 * A's 12 sides at B's face centre and fan corners (1-5) and of B's 12 sides at A's fan corners
 * (6-9) [m^2], the overlap below B's face at A's fan corners and face centre (10, 0-4) [m]. */
enum { V_SIDE_A = 1, V_SIDE_B = 6, V_DEPTH_B = 10 };

/* A's fan corners (+u +v), (-u +v), (-u -v), (+u -v) (quadrature._FAN); in face coordinates
 * the outward unit normal of A's edge i (corner i -> i + 1) */
static const double FAN_U[4] = {1.0, -1.0, -1.0, 1.0};
static const double FAN_V[4] = {1.0, 1.0, -1.0, -1.0};
static const double OUT_U[4] = {0.0, -1.0, 0.0, 1.0};
static const double OUT_V[4] = {1.0, 0.0, -1.0, 0.0};

typedef struct {
  double frame[16][3];
  double planes[32][6];
  double items[11][12];
  double poly[2][CCI_QUAD_VERTS][3]; /* ping-pong polygon buffers [m] in A */
} scratch;

/* Sutherland-Hodgman (model.clipping.clip_halfspace for one polygon): poly[*src] (count
 * vertices) clipped to (n0, n1, n2) . x <= limit. Returns the count; *src is left where every
 * vertex is inside (nothing copied), else the clipped polygon is written to the other buffer
 * and *src set to it. Vertices beyond the budget overwrite the last row, as the numpy path's
 * scatter does; items[0] takes each vertex's signed distance, in the numpy path's order. */
static inline int clip(scratch *w, int *src, int count, double n0, double n1, double n2, double limit) {
  double(*in)[3] = w->poly[*src];
  double *dist = w->items[0];
  int outside = 0;
  for (int i = 0; i < count; ++i) {
    double s = (in[i][0] * n0 + in[i][2] * n2) + in[i][1] * n1 - limit;
    dist[i] = s;
    outside |= !(s <= 0.0);
  }
  if (!outside) return count;
  int dst = 1 - *src;
  double(*out)[3] = w->poly[dst];
  int n_out = 0;
  double x0 = in[0][0], x1 = in[0][1], x2 = in[0][2], si = dist[0];
  for (int i = 0; i < count; ++i) {
    int j = i + 1 < count ? i + 1 : 0;
    double y0 = in[j][0], y1 = in[j][1], y2 = in[j][2], sj = dist[j];
    int inside = si <= 0.0;
    if (inside) {
      int r = n_out < CCI_QUAD_VERTS - 1 ? n_out : CCI_QUAD_VERTS - 1;
      out[r][0] = x0;
      out[r][1] = x1;
      out[r][2] = x2;
      ++n_out;
    }
    if (inside != (sj <= 0.0)) {
      double d = si - sj;
      double t = si / (d == 0.0 ? 1.0 : d);
      int r = n_out < CCI_QUAD_VERTS - 1 ? n_out : CCI_QUAD_VERTS - 1;
      out[r][0] = x0 + t * (y0 - x0);
      out[r][1] = x1 + t * (y1 - x1);
      out[r][2] = x2 + t * (y2 - x2);
      ++n_out;
    }
    x0 = y0; x1 = y1; x2 = y2; si = sj;
  }
  *src = dst;
  return n_out < CCI_QUAD_VERTS ? n_out : CCI_QUAD_VERTS;
}

/* The three sides of the triangle (frame rows t0, t1, t2) as planes perpendicular to A's
 * face (face_on_face's triangle clips and _side_value): planes[row + k] = (outward normal
 * (3), normal . p0, p0's in-plane coordinates (2)) of side k (p0 -> p1), outward = away from
 * the opposite vertex; the numpy path's cross product with A's face normal sigma_A e_a,
 * whose component along e_a is 0, from its in-plane components. */
static inline void side_planes(scratch *w, int t0, int t1, int t2, int row, int uA, int vA, double sigma_A) {
  const int rows[3] = {t0, t1, t2};
  int a = 3 - uA - vA;
  double(*f)[3] = w->frame;
  for (int k = 0; k < 3; ++k) {
    int r0 = rows[k], r1 = rows[(k + 1) % 3], ro = rows[(k + 2) % 3];
    double ou = sigma_A * (f[r1][vA] - f[r0][vA]), ov = -(sigma_A * (f[r1][uA] - f[r0][uA]));
    double toward = ou * (f[ro][uA] - f[r0][uA]) + ov * (f[ro][vA] - f[r0][vA]);
    double flip = toward > 0.0 ? -1.0 : 1.0;
    double *pl = w->planes[row + k];
    pl[uA] = ou * flip;
    pl[vA] = ov * flip;
    pl[a] = 0.0;
    pl[3] = pl[uA] * f[r0][uA] + pl[vA] * f[r0][vA];
    pl[4] = f[r0][uA];
    pl[5] = f[r0][vA];
  }
}

/* The clip that keeps a face's own part near its outer edge e0 -> e1 (frame rows) of the face
 * centred at frame row `centre` (face_on_face with _inward): planes[row] = (g, c), g =
 * -(share nA + w_in), c = -(share face_level + w_in . e0), w_in the unit inward perpendicular to
 * the edge in A's face plane (from the in-plane components alone: the numpy path's values), share
 * the face's box's part of the overlap (f_A or f_B; one half for equal fields). */
static inline void edge_plane(scratch *w, int e0, int e1, int centre, double face_level, int row, int uA, int vA,
                       double sigma_A, double share) {
  int a = 3 - uA - vA;
  double(*f)[3] = w->frame;
  double du = f[centre][uA] - f[e0][uA], dv = f[centre][vA] - f[e0][vA];
  double gu = f[e1][uA] - f[e0][uA], gv = f[e1][vA] - f[e0][vA];
  double length = cci_max(sqrt(gu * gu + gv * gv), 1e-12);
  gu = gu / length;
  gv = gv / length;
  double s = du * gu + dv * gv;
  du = du - s * gu;
  dv = dv - s * gv;
  length = cci_max(sqrt(du * du + dv * dv), 1e-12);
  double wu = du / length, wv = dv / length;
  double *pl = w->planes[row];
  pl[uA] = -wu;
  pl[vA] = -wv;
  pl[a] = -(share * sigma_A);
  pl[3] = -(share * face_level + (wu * f[e0][uA] + wv * f[e0][vA]));
}

/* planes[row][:3] . frame[r] - planes[row][3] [m]: a point's signed distance as clip computes it. */
static inline double plane_dist(const scratch *w, int r, int row) {
  const double *x = w->frame[r], *pl = w->planes[row];
  return (x[0] * pl[0] + x[2] * pl[2]) + x[1] * pl[1] - pl[3];
}

/* Where the point frame[r] [m] lies from the triangle side planes[row] (quadrature._side_value;
 * <= 0 inside), from the in-plane components. */
static inline double side_value(const scratch *w, int row, int r, int uA, int vA) {
  const double *x = w->frame[r], *pl = w->planes[row];
  return pl[uA] * (x[uA] - pl[4]) + pl[vA] * (x[vA] - pl[5]);
}

/* The part of [t0, t1] of a segment (t in [0, 1]) where a linear function, s0 at t = 0 and s1
 * at t = 1, is <= 0; *t1 = -1 where s0 and s1 are both > 0 (face_on_face's sliver interval). */
static inline void interval(double s0, double s1, double *t0, double *t1) {
  if (s0 > 0.0) {
    if (s1 > 0.0) {
      *t1 = -1.0;
    } else if (s1 <= 0.0) {
      double d = s0 - s1;
      *t0 = cci_max(*t0, s0 / (d == 0.0 ? 1.0 : d));
    }
  } else if (s0 <= 0.0 && s1 > 0.0) {
    double d = s0 - s1;
    *t1 = cci_min(*t1, s0 / (d == 0.0 ? 1.0 : d));
  }
}

/* A sliver strip over an edge interval `length` [m] long, h0, h1 [m] wide at its ends, the
 * pressure rising linearly across it from the edge: its area on its surface, which rises `rise`
 * per unit of width (1, 45 deg, for equal fields), times the pressure's scale `scale` (0.5 / the
 * box's share: 1 for equal fields) [m^2], the strip centroid's distance from the edge [m] (area x
 * it is the strip's weight), the centroid's place along the interval (0 at its start, 1 at its
 * end), the centre of pressure's distance from the edge [m] and its place along the interval. */
typedef struct {
  double area, y_bar, along, y_p, along_p;
} strip_t;

static inline strip_t strip(double h0, double h1, double length, double rise, double scale) {
  strip_t s;
  double hs = h0 + h1;
  double hsum = hs > 0.0 ? hs : 1.0;
  double h2 = h0 * h0 + h0 * h1 + h1 * h1;
  s.area = sqrt(1.0 + rise * rise) * length * 0.5 * hs * scale;
  s.y_bar = h2 / (3.0 * hsum);
  s.along = (h0 + 2.0 * h1) / (3.0 * hsum);
  h2 = h2 > 0.0 ? h2 : 1.0;
  s.y_p = hsum * (h0 * h0 + h1 * h1) / (2.0 * h2);
  s.along_p = (h0 * h0 + 2.0 * h0 * h1 + 3.0 * h1 * h1) / (4.0 * h2);
  return s;
}

/* x . y of two vectors in face coordinates, summed left to right over A's axes. */
static inline double dot_lr(double xu, double xv, double xz, double yu, double yv, double yz, int a) {
  if (a == 0) return (xz * yz + xu * yu) + xv * yv;
  if (a == 1) return (xv * yv + xz * yz) + xu * yu;
  return (xu * yu + xv * yv) + xz * yz;
}

/* x . y of two vectors in face coordinates, summed over A's axes in the order of the numpy
 * path's einsum on contiguous operands: (x0 y0 + x2 y2) + x1 y1. */
static inline double dot_c(double xu, double xv, double xz, double yu, double yv, double yz, int a) {
  if (a == 0) return (xz * yz + xv * yv) + xu * yu;
  if (a == 1) return (xv * yv + xu * yu) + xz * yz;
  return (xu * yu + xz * yz) + xv * yv;
}

/* The sliver's fade: a smoothstep of how far [m] its centre lies inside the other face's
 * rectangle, in units of the overlap there [m]. */
static inline double fade(double inside, double overlap) {
  double u = cci_clamp(inside / (overlap > 0.0 ? overlap : 1.0), 0.0, 1.0);
  return u * u * (3.0 - 2.0 * u);
}

/* quadrature.faces for one pose: A's face axis *a and side *sigma_A (A's face normal
 * sigma_A e_a), B's face axis *m and side *s_B (B's face normal s_B b_m points towards A). */
static void faces(const double R[9], const double n[3], int *a, double *sigma_A, int *m, double *s_B) {
  int aa = 0;
  for (int k = 1; k < 3; ++k)
    if (fabs(n[k]) > fabs(n[aa])) aa = k;
  *a = aa;
  *sigma_A = n[aa] >= 0.0 ? 1.0 : -1.0;
  int mm = 0;
  double along_m = 0.0;
  for (int k = 0; k < 3; ++k) {
    double along = (n[0] * R[k] + n[1] * R[3 + k]) + n[2] * R[6 + k]; /* n . b_k */
    if (k == 0 || fabs(along) > fabs(along_m)) {
      mm = k;
      along_m = along;
    }
  }
  *m = mm;
  *s_B = along_m > 0.0 ? -1.0 : 1.0;
}

double cci_face_tilt(const double R[9], const double n[3]) {
  int a, m;
  double sigma_A, s_B;
  faces(R, n, &a, &sigma_A, &m, &s_B);
  return acos(cci_clamp(fabs(R[3 * a + m]), 0.0, 1.0));
}

double cci_face_on_face(const double p[3], const double R[9], const double hA[3], const double hB[3],
                        const double n[3], double point[3], double normal[3], double *tilt_out) {
  scratch work;
  scratch *w = &work;
  double(*frame)[3] = w->frame;
  double(*items)[12] = w->items;
  int a, m;
  double sigma_A, s_B;
  faces(R, n, &a, &sigma_A, &m, &s_B);
  int uA = (a + 1) % 3, vA = (a + 2) % 3, uB = (m + 1) % 3, vB = (m + 2) % 3;
  double U = hA[uA], V = hA[vA], L = hA[a]; /* A's face: |u| <= U, |v| <= V at height L */
  /* the fields' depths (half each box's smallest extent) and each box's share of the overlap
   * (quadrature.face_on_face: f_A, f_B, ratio_AB, ratio_BA; 0.5, 0.5, 1, 1 for equal fields) */
  double H_A = cci_min(cci_min(hA[0], hA[1]), hA[2]), H_B = cci_min(cci_min(hB[0], hB[1]), hB[2]);
  double f_A = H_A / (H_A + H_B), f_B = H_B / (H_A + H_B), ratio_AB = H_A / H_B, ratio_BA = H_B / H_A;
  double *top = frame[F_TOP], *cB = frame[F_CENTRE_B], *nA = frame[F_NA], *nB = frame[F_NB];
  double h_top = sigma_A * hA[a], h_bottom = s_B * hB[m];
  for (int c = 0; c < 3; ++c) {
    top[c] = h_top * (c == a ? 1.0 : 0.0);
    nA[c] = sigma_A * (c == a ? 1.0 : 0.0);
    cB[c] = p[c] + h_bottom * R[3 * c + m];
    nB[c] = s_B * R[3 * c + m];
  }
  for (int k = 0; k < 4; ++k) {
    double fu = FAN_U[k], fv = FAN_V[k];
    for (int c = 0; c < 3; ++c) {
      frame[F_CA + k][c] = top[c] + (fu * hA[uA] * (c == uA ? 1.0 : 0.0) + fv * hA[vA] * (c == vA ? 1.0 : 0.0));
      frame[F_CB + k][c] = cB[c] + (fu * hB[uB] * R[3 * c + uB] + fv * hB[vB] * R[3 * c + vB]);
    }
  }
  for (int i = 0; i < 4; ++i) {
    int in = (i + 1) % 4;
    side_planes(w, F_TOP, F_CA + i, F_CA + in, P_SIDE_A + 3 * i, uA, vA, sigma_A);
    side_planes(w, F_CENTRE_B, F_CB + i, F_CB + in, P_SIDE_B + 3 * i, uA, vA, sigma_A);
    edge_plane(w, F_CB + i, F_CB + in, F_CENTRE_B, L, P_EDGE_B + i, uA, vA, sigma_A, f_B);
    edge_plane(w, F_CA + i, F_CA + in, F_TOP, L, P_EDGE_A + i, uA, vA, sigma_A, f_A);
  }
  /* each side's value at the other face's fan corners (and at B's centre) */
  for (int k = 0; k < 12; ++k) {
    items[V_SIDE_A][k] = side_value(w, P_SIDE_A + k, F_CENTRE_B, uA, vA);
    for (int r = 0; r < 4; ++r) {
      items[V_SIDE_A + 1 + r][k] = side_value(w, P_SIDE_A + k, F_CB + r, uA, vA);
      items[V_SIDE_B + r][k] = side_value(w, P_SIDE_B + k, F_CA + r, uA, vA);
    }
  }
  /* face coordinates of B's centre, face centre, face normal, axes u and v and fan corners */
  double p0 = p[uA], p1 = p[vA], p2 = sigma_A * p[a];
  double o0 = cB[uA], o1 = cB[vA], o2 = sigma_A * cB[a];
  double nB0 = nB[uA], nB1 = nB[vA], nB2 = sigma_A * nB[a];
  double bu0 = R[3 * uA + uB], bu1 = R[3 * vA + uB], bu2 = sigma_A * R[3 * a + uB];
  double bv0 = R[3 * uA + vB], bv1 = R[3 * vA + vB], bv2 = sigma_A * R[3 * a + vB];
  for (int k = 0; k < 4; ++k) {
    frame[F_LOCAL_B + k][0] = frame[F_CB + k][uA];
    frame[F_LOCAL_B + k][1] = frame[F_CB + k][vA];
    frame[F_LOCAL_B + k][2] = sigma_A * frame[F_CB + k][a];
  }
  double facing = cci_max(-nB2, 1e-6); /* cos of the tilt */
  /* the overlap below B's face (face_on_face's depth_B_at [m]) at A's fan corners and face centre */
  for (int r = 0; r < 5; ++r) {
    double xu = r < 4 ? FAN_U[r] * U : 0.0, xv = r < 4 ? FAN_V[r] * V : 0.0;
    items[V_DEPTH_B][r] = dot_c(nB0, nB1, nB2, o0 - xu, o1 - xv, o2 - L, a) / facing;
  }
  double weight = 0.0, w_poly = 0.0, depth_sum = 0.0, sum_u = 0.0, sum_v = 0.0;
  /* the 16 polygons (A's triangle i, B's triangle j), clipped in face_on_face's order */
  for (int j = 0; j < 4; ++j) {
    int jn = (j + 1) % 4;
    if (o2 > L && frame[F_LOCAL_B + j][2] > L && frame[F_LOCAL_B + jn][2] > L) continue; /* wholly above A's face */
    int eb = P_EDGE_B + j;
    if (plane_dist(w, F_CENTRE_B, eb) > 0.0 && plane_dist(w, F_CB + j, eb) > 0.0 && plane_dist(w, F_CB + jn, eb) > 0.0)
      continue; /* wholly outside its own edge clip */
    for (int i = 0; i < 4; ++i) {
      if (nB2 < 0.0 && items[V_DEPTH_B][4] < 0.0 && items[V_DEPTH_B][i] < 0.0 && items[V_DEPTH_B][(i + 1) % 4] < 0.0)
        continue; /* B's face runs above A's triangle i: nothing of it overlaps */
      int apart = 0;
      for (int k = 0; k < 3; ++k) {
        int col = 3 * i + k;
        apart |= items[V_SIDE_A][col] > 0.0 && items[V_SIDE_A + 1 + j][col] > 0.0 && items[V_SIDE_A + 1 + jn][col] > 0.0;
      }
      if (apart) continue; /* a side of A's triangle has B's triangle wholly outside */
      for (int c = 0; c < 3; ++c) {
        w->poly[0][0][c] = cB[c];
        w->poly[0][1][c] = frame[F_CB + j][c];
        w->poly[0][2][c] = frame[F_CB + jn][c];
      }
      int count = 3, src = 0;
      /* A's triangle's 3 sides, A's face plane, the edge clips of B's edge j and A's edge i */
      for (int k = 0; k < 6; ++k) {
        if (count < 3) break; /* no area left */
        double n0, n1, n2, limit;
        if (k == 3) {
          n0 = nA[0]; n1 = nA[1]; n2 = nA[2]; limit = L;
        } else {
          int row = k < 3 ? P_SIDE_A + 3 * i + k : (k == 4 ? P_EDGE_B + j : P_EDGE_A + i);
          const double *pl = w->planes[row];
          n0 = pl[0]; n1 = pl[1]; n2 = pl[2]; limit = pl[3];
        }
        count = clip(w, &src, count, n0, n1, n2, limit);
      }
      if (count < 3) continue;
      /* quadrature._pressure_moments: fan from the first vertex, the pressure (half the overlap
       * below A's face, linear) integrated exactly over each triangle */
      double(*poly)[3] = w->poly[src];
      double q0 = poly[0][0], q1 = poly[0][1], q2 = poly[0][2];
      double pa = 0.5 * (L - sigma_A * poly[0][a]);
      double total = -0.0, wt = 0.0, f[3] = {0.0, 0.0, 0.0};
      for (int t = 0; t < count - 2; ++t) {
        double y0 = poly[t + 1][0], y1 = poly[t + 1][1], y2 = poly[t + 1][2];
        double z0 = poly[t + 2][0], z1 = poly[t + 2][1], z2 = poly[t + 2][2];
        double e10 = y0 - q0, e11 = y1 - q1, e12 = y2 - q2;
        double e20 = z0 - q0, e21 = z1 - q1, e22 = z2 - q2;
        double x0 = e11 * e22 - e12 * e21, x1 = e12 * e20 - e10 * e22, x2 = e10 * e21 - e11 * e20;
        double area = 0.5 * sqrt((x0 * x0 + x1 * x1) + x2 * x2);
        double pb = 0.5 * (L - sigma_A * poly[t + 1][a]);
        double pc = 0.5 * (L - sigma_A * poly[t + 2][a]);
        double ps = (pa + pb) + pc;
        total += area;
        wt += area * ps;
        f[0] += area * ((((ps * ((q0 + y0) + z0)) + pa * q0) + pb * y0) + pc * z0);
        f[1] += area * ((((ps * ((q1 + y1) + z1)) + pa * q1) + pb * y1) + pc * z1);
        f[2] += area * ((((ps * ((q2 + y2) + z2)) + pa * q2) + pb * y2) + pc * z2);
      }
      if (!(total > 0.0)) continue;
      double wp = wt / 3.0; /* the integral of the pressure */
      weight += wp;
      w_poly += wp;
      depth_sum += sigma_A * (f[a] / 12.0); /* the first moment along A's axis a */
      sum_u += f[uA] / 12.0;
      sum_v += f[vA] / 12.0;
    }
  }
  double sum_n0 = 0.0, sum_n1 = 0.0, sum_n2 = 0.0;
  /* B's slivers: B's edge j, inside the overlap (below A's face), clipped by A's triangle i */
  for (int j = 0; j < 4; ++j) {
    int jn = (j + 1) % 4;
    const double *ea = frame[F_LOCAL_B + j], *eb = frame[F_LOCAL_B + jn];
    double a0 = ea[0], a1 = ea[1], a2 = ea[2];
    double g0 = eb[0] - a0, g1 = eb[1] - a1, g2 = eb[2] - a2;
    double e_t0 = 0.0, e_t1 = 1.0;
    interval(-(L - a2), -(L - eb[2]), &e_t0, &e_t1);
    if (!(e_t1 > e_t0)) continue;
    double g_len = cci_max(sqrt(dot_lr(g0, g1, g2, g0, g1, g2, a)), 1e-12);
    double e0 = g0 / g_len, e1 = g1 / g_len, e2 = g2 / g_len;
    for (int i = 0; i < 4; ++i) {
      double t0 = e_t0, t1 = e_t1;
      for (int k = 0; k < 3; ++k) {
        int col = 3 * i + k;
        interval(items[V_SIDE_A + 1 + j][col], items[V_SIDE_A + 1 + jn][col], &t0, &t1);
        if (!(t1 > t0)) break; /* the edge misses the triangle */
      }
      if (!(t1 > t0)) continue;
      double u0 = a0 + t0 * g0, u1 = a1 + t0 * g1, u2 = a2 + t0 * g2;
      double v0 = a0 + t1 * g0, v1 = a1 + t1 * g1, v2 = a2 + t1 * g2;
      double h0 = f_B * cci_max(L - u2, 0.0); /* the strip's width at each end [m]: B's share of the overlap */
      double h1 = f_B * cci_max(L - v2, 0.0);
      double l0 = v0 - u0, l1 = v1 - u1, l2 = v2 - u2;
      strip_t s = strip(h0, h1, sqrt(dot_lr(l0, l1, l2, l0, l1, l2, a)), ratio_AB, 0.5 / f_B);
      double x0 = u0 + s.along * l0, x1 = u1 + s.along * l1, x2 = u2 + s.along * l2; /* the strip's centre */
      double w_strip = s.area * s.y_bar * fade(cci_min(U - fabs(x0), V - fabs(x1)), cci_max(L - x2, 0.0));
      if (!(w_strip > 0.0)) continue;
      /* inward: in A's face plane, perpendicular to the edge, towards the face's centre */
      double d0 = o0 - x0, d1 = o1 - x1;
      double sd = d0 * e0 + d1 * e1;
      double d2;
      d0 = d0 - sd * e0;
      d1 = d1 - sd * e1;
      d2 = -(sd * e2);
      double d = cci_max(sqrt(dot_lr(d0, d1, d2, d0, d1, d2, a)), 1e-12);
      d0 = d0 / d; d1 = d1 / d; d2 = d2 / d;
      weight += w_strip;
      sum_u += w_strip * ((u0 + s.along_p * l0) + s.y_p * d0); /* the strip's centre of pressure */
      sum_v += w_strip * ((u1 + s.along_p * l1) + s.y_p * d1);
      /* the normal: A's face normal plus B's side face's inward normal (in B's face plane) */
      sd = (d0 * nB0 + d1 * nB1) + d2 * nB2;
      d0 = d0 - sd * nB0; d1 = d1 - sd * nB1; d2 = d2 - sd * nB2;
      d = cci_max(sqrt((d0 * d0 + d1 * d1) + d2 * d2), 1e-12);
      d0 = ratio_AB * (d0 / d); d1 = ratio_AB * (d1 / d); d2 = 1.0 + ratio_AB * (d2 / d);
      d = cci_max(sqrt((d0 * d0 + d1 * d1) + d2 * d2), 1e-300);
      sum_n0 += w_strip * (d0 / d);
      sum_n1 += w_strip * (d1 / d);
      sum_n2 += w_strip * (d2 / d);
    }
  }
  /* A's slivers: A's edge i, inside the overlap (above B's face), clipped by B's triangle j */
  for (int i = 0; i < 4; ++i) {
    int in = (i + 1) % 4;
    double ou = OUT_U[i], ov = OUT_V[i];
    double a0 = FAN_U[i] * U, a1 = FAN_V[i] * V;
    double g0 = FAN_U[in] * U - a0, g1 = FAN_V[in] * V - a1;
    double e_t0 = 0.0, e_t1 = 1.0;
    interval(-items[V_DEPTH_B][i], -items[V_DEPTH_B][in], &e_t0, &e_t1);
    if (!(e_t1 > e_t0)) continue;
    /* the strip's normal: -(A's side face's inward normal -(ou, ov, 0)) - B's face normal */
    double m0 = ratio_BA * ou - nB0, m1 = ratio_BA * ov - nB1, m2 = -nB2;
    double d = cci_max(sqrt((m0 * m0 + m1 * m1) + m2 * m2), 1e-300);
    m0 = m0 / d; m1 = m1 / d; m2 = m2 / d;
    for (int j = 0; j < 4; ++j) {
      double t0 = e_t0, t1 = e_t1;
      for (int k = 0; k < 3; ++k) {
        int col = 3 * j + k;
        interval(items[V_SIDE_B + i][col], items[V_SIDE_B + in][col], &t0, &t1);
        if (!(t1 > t0)) break;
      }
      if (!(t1 > t0)) continue;
      double u0 = a0 + t0 * g0, u1 = a1 + t0 * g1;
      double v0 = a0 + t1 * g0, v1 = a1 + t1 * g1;
      double h0 = f_A * cci_max(dot_c(nB0, nB1, nB2, o0 - u0, o1 - u1, o2 - L, a) / facing, 0.0);
      double h1 = f_A * cci_max(dot_c(nB0, nB1, nB2, o0 - v0, o1 - v1, o2 - L, a) / facing, 0.0);
      double l0 = v0 - u0, l1 = v1 - u1;
      strip_t s = strip(h0, h1, fabs(l0 + l1), ratio_BA, 0.5 / f_A); /* the edge runs along u or v */
      double x0 = u0 + s.along * l0, x1 = u1 + s.along * l1;
      double qx0 = x0 - p0, qx1 = x1 - p1, qx2 = L - p2; /* how far inside B's face rectangle */
      double qu = dot_lr(bu0, bu1, bu2, qx0, qx1, qx2, a);
      double qv = dot_lr(bv0, bv1, bv2, qx0, qx1, qx2, a);
      double o_c = cci_max(dot_c(nB0, nB1, nB2, o0 - x0, o1 - x1, o2 - L, a) / facing, 0.0);
      double w_strip = s.area * s.y_bar * fade(cci_min(hB[uB] - fabs(qu), hB[vB] - fabs(qv)), o_c);
      if (!(w_strip > 0.0)) continue;
      weight += w_strip;
      sum_u += w_strip * ((u0 + s.along_p * l0) - s.y_p * ou);
      sum_v += w_strip * ((u1 + s.along_p * l1) - s.y_p * ov);
      sum_n0 += w_strip * m0;
      sum_n1 += w_strip * m1;
      sum_n2 += w_strip * m2;
    }
  }
  /* the weighted means: the point on the equal-pressure plane, half the mean overlap below A's
   * face; the polygons' normal is the bisector of the two face normals */
  double main_n[3];
  for (int c = 0; c < 3; ++c) main_n[c] = ratio_BA * (sigma_A * (c == a ? 1.0 : 0.0)) - s_B * R[3 * c + m];
  double length = sqrt((main_n[0] * main_n[0] + main_n[1] * main_n[1]) + main_n[2] * main_n[2]);
  for (int c = 0; c < 3; ++c) main_n[c] = main_n[c] / length;
  double safe = weight > 0.0 ? weight : 1.0;
  double depth_at = w_poly > 0.0 ? L - depth_sum / w_poly : 0.0; /* the polygons' pressure-weighted mean overlap */
  point[uA] = sum_u / safe;
  point[vA] = sum_v / safe;
  point[a] = sigma_A * (L - f_A * depth_at);
  double n0 = w_poly * main_n[uA] + sum_n0;
  double n1 = w_poly * main_n[vA] + sum_n1;
  double n2 = w_poly * (sigma_A * main_n[a]) + sum_n2;
  length = cci_max(sqrt((n0 * n0 + n1 * n1) + n2 * n2), 1e-300);
  if (weight > 0.0) {
    normal[uA] = n0 / length;
    normal[vA] = n1 / length;
    normal[a] = sigma_A * (n2 / length);
  } else {
    normal[0] = main_n[0];
    normal[1] = main_n[1];
    normal[2] = main_n[2];
  }
  *tilt_out = acos(cci_clamp(fabs(R[3 * a + m]), 0.0, 1.0));
  return weight;
}
