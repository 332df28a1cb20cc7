// crane_pair: the integrator's example of the native contact core (C++17, links libcontainer_contact).
//
//   crane_pair [WEIGHTS] [--seconds T] [--drop H] [--mass KG]
//       Stepping mode. Loads WEIGHTS (default: the shipped weights.npz this was built beside),
//       lands a container (B) on a fixed one (A) and steps the pair at 1 kHz: each step
//       cc_contact_step (candidate pair -> predictor -> force law -> wrenches), then a
//       semi-implicit Euler update of the free body. Prints the cost of each call (median and
//       p99 over the run, std::chrono::steady_clock), the predictor's share (cc_predict on the
//       same pair), and the final rest state.
//   crane_pair WEIGHTS --poses IN.bin --out OUT.bin
//       Batch mode: cc_predict on every pose of IN.bin, answers to OUT.bin (formats below).
//
// Exit status: 0 done; 2 the weights file was refused (one line on stderr naming the file);
// 3 an input or output file was refused or the core returned an error; 64 bad usage.
//
// Batch files (little-endian, no padding):
//   IN.bin:  uint64 n, uint64 rows_A, uint64 rows_B (each 1 = one size for every pose, or n),
//            then float64 p_AB (n, 3) [m], R_AB (n, 3, 3) row-major, size_A (rows_A, 3) [m],
//            size_B (rows_B, 3) [m];
//   OUT.bin: float64 point_A (n, 3) [m], normal_A (n, 3), depth (n) [m]; nothing else.
//
// The scene's constants are the testbed's (named where they come from below); nothing here is
// tuned to make the landing look good.
#include <algorithm>
#include <cerrno>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

#include "container_contact.h"
#include "container_contact_step.h"

#ifndef CC_DEFAULT_WEIGHTS
#define CC_DEFAULT_WEIGHTS "learned_contact/shipped/weights.npz"
#endif

namespace {

constexpr int kExitWeights = 2, kExitInput = 3, kExitUsage = 64;
constexpr double kPi = 3.14159265358979323846;

using Vec3 = std::array<double, 3>;
using Mat3 = std::array<double, 9>;  // row-major

// The model owns its arrays until cc_model_free: a small RAII holder.
struct Model {
  cc_model m{};
  ~Model() { cc_model_free(&m); }
};

struct Step {
  cc_step *s = nullptr;
  ~Step() { cc_step_free(s); }
};

Vec3 mul(const Mat3 &R, const Vec3 &v) {
  return {R[0] * v[0] + R[1] * v[1] + R[2] * v[2], R[3] * v[0] + R[4] * v[1] + R[5] * v[2],
          R[6] * v[0] + R[7] * v[1] + R[8] * v[2]};
}
Vec3 mul_transposed(const Mat3 &R, const Vec3 &v) {
  return {R[0] * v[0] + R[3] * v[1] + R[6] * v[2], R[1] * v[0] + R[4] * v[1] + R[7] * v[2],
          R[2] * v[0] + R[5] * v[1] + R[8] * v[2]};
}
Mat3 mul(const Mat3 &A, const Mat3 &B) {
  Mat3 C{};
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) C[3 * r + c] = A[3 * r] * B[c] + A[3 * r + 1] * B[3 + c] + A[3 * r + 2] * B[6 + c];
  return C;
}
Vec3 cross(const Vec3 &a, const Vec3 &b) {
  return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}
double norm(const Vec3 &a) { return std::sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2]); }

// R = Rz(yaw) Ry(pitch) Rx(roll) (the testbed's roll-pitch-yaw convention).
Mat3 rpy(double roll, double pitch, double yaw) {
  const double cr = std::cos(roll), sr = std::sin(roll), cp = std::cos(pitch), sp = std::sin(pitch);
  const double cy = std::cos(yaw), sy = std::sin(yaw);
  const Mat3 Rx{1, 0, 0, 0, cr, -sr, 0, sr, cr}, Ry{cp, 0, sp, 0, 1, 0, -sp, 0, cp}, Rz{cy, -sy, 0, sy, cy, 0, 0, 0, 1};
  return mul(Rz, mul(Ry, Rx));
}

// exp([phi]x) by Rodrigues' formula.
Mat3 rotation_of(const Vec3 &phi) {
  const double a = norm(phi);
  if (a < 1e-300) return {1, 0, 0, 0, 1, 0, 0, 0, 1};
  const Vec3 k{phi[0] / a, phi[1] / a, phi[2] / a};
  const double c = std::cos(a), s = std::sin(a), t = 1.0 - c;
  return {t * k[0] * k[0] + c,        t * k[0] * k[1] - s * k[2], t * k[0] * k[2] + s * k[1],
          t * k[0] * k[1] + s * k[2], t * k[1] * k[1] + c,        t * k[1] * k[2] - s * k[0],
          t * k[0] * k[2] - s * k[1], t * k[1] * k[2] + s * k[0], t * k[2] * k[2] + c};
}

// Re-orthonormalises R's columns (Gram-Schmidt) against the drift of repeated products.
void orthonormalise(Mat3 &R) {
  Vec3 x{R[0], R[3], R[6]}, y{R[1], R[4], R[7]};
  const double nx = norm(x);
  for (double &e : x) e /= nx;
  const double d = x[0] * y[0] + x[1] * y[1] + x[2] * y[2];
  for (int i = 0; i < 3; ++i) y[i] -= d * x[i];
  const double ny = norm(y);
  for (double &e : y) e /= ny;
  const Vec3 z = cross(x, y);
  R = {x[0], y[0], z[0], x[1], y[1], z[1], x[2], y[2], z[2]};
}

// Median and p99 [us] of a sample (sorted in place); nearest-rank p99.
struct Cost {
  double median, p99;
  size_t n;
};
Cost cost_of(std::vector<double> &us) {
  if (us.empty()) return {NAN, NAN, 0};
  std::sort(us.begin(), us.end());
  const size_t n = us.size();
  const double median = n % 2 ? us[n / 2] : 0.5 * (us[n / 2 - 1] + us[n / 2]);
  const size_t rank = static_cast<size_t>(std::ceil(0.99 * static_cast<double>(n)));
  return {median, us[std::max<size_t>(rank, 1) - 1], n};
}

int load(const char *path, Model &model) {
  char err[1024];
  if (cc_model_load(path, &model.m, err, sizeof err) != CC_OK) {
    std::fprintf(stderr, "%s\n", err);
    return kExitWeights;
  }
  return 0;
}

// ------------------------------------------------------------------------- stepping mode

struct Options {
  double seconds = 3.0;  // [s] simulated
  double drop = 0.10;    // [m] gap between the boxes at the start (B at rest)
  double mass = 2200.0;  // [kg] B: a 20 ft container's tare mass (testbed/bodies/containers.py, 1CC)
};

int run_steps(const Model &model, const Options &opt) {
  const cc_model &m = model.m;
  const double h = 1e-3;  // [s] the simulator's step: 1 kHz
  const double g = 9.81;  // [m/s^2]
  // Both boxes have the model's first supported size (the shipped files: a 20 ft container).
  const double *size = m.supported_sizes;
  const double sizes[6] = {size[0], size[1], size[2], size[0], size[1], size[2]};
  const double mass = opt.mass;
  // a solid uniform box: I = m / 12 diag(y^2 + z^2, x^2 + z^2, x^2 + y^2), about its centre Bo
  const double Ixx = mass / 12.0 * (size[1] * size[1] + size[2] * size[2]);
  const double Iyy = mass / 12.0 * (size[0] * size[0] + size[2] * size[2]);
  const double Izz = mass / 12.0 * (size[0] * size[0] + size[1] * size[1]);
  const double I_Bo[18] = {0, 0, 0, 0, 0, 0, 0, 0, 0, Ixx, 0, 0, 0, Iyy, 0, 0, 0, Izz};
  const uint8_t is_free[2] = {0, 1};
  const double masses[2] = {INFINITY, mass};
  const cc_step_scene scene{2, sizes, is_free, masses, I_Bo, nullptr};
  // The testbed's learned law defaults (its LearnedDynamicsConfig) and the fitted stiffness at the
  // law's 1e8 Pa modulus, for a simulator stepping at h; a simulator sets mu to its own friction.
  const cc_step_params params = cc_step_default_params(h);
  int status = CC_OK;
  Step step;
  step.s = cc_step_create(&scene, &params, &status);
  if (step.s == nullptr) {
    std::fprintf(stderr, "crane_pair: cc_step_create refused the scene (status %d)\n", status);
    return kExitInput;
  }

  // A: fixed at the origin. B: above it by `drop`, off-centre by a few cm, tilted a little and
  // yawed, as a spreader sets a box down: first touch at an edge, then it settles face on face.
  double p[6] = {0, 0, 0, 0.05, -0.03, 0.5 * (size[2] + size[2]) + opt.drop};
  Mat3 R_B = rpy(0.5 * kPi / 180.0, -0.3 * kPi / 180.0, 2.0 * kPi / 180.0);
  double R[18] = {1, 0, 0, 0, 1, 0, 0, 0, 1};
  Vec3 v{0, 0, 0}, w{0, 0, 0};
  double wv[6] = {0, 0, 0, 0, 0, 0}, vv[6] = {0, 0, 0, 0, 0, 0}, wrench[12];

  const size_t n_steps = static_cast<size_t>(std::llround(opt.seconds / h));
  std::vector<double> step_us, predict_us;
  step_us.reserve(n_steps);
  predict_us.reserve(n_steps);
  size_t touching_steps = 0;
  double last_fn = 0.0;
  for (size_t k = 0; k < n_steps; ++k) {
    std::copy(R_B.begin(), R_B.end(), R + 9);
    std::copy(w.begin(), w.end(), wv + 3);
    std::copy(v.begin(), v.end(), vv + 3);
    size_t bad_row = 0;
    const auto t0 = std::chrono::steady_clock::now();
    const int rc = cc_contact_step(&m, step.s, p, R, wv, vv, wrench, &bad_row);
    const auto t1 = std::chrono::steady_clock::now();
    if (rc != CC_OK) {
      std::fprintf(stderr, "crane_pair: cc_contact_step returned %d at step %zu (pair row %zu)\n", rc, k, bad_row);
      return kExitInput;
    }
    step_us.push_back(std::chrono::duration<double, std::micro>(t1 - t0).count());
    // the predictor's share: cc_predict alone on the same candidate pair (one pair per call)
    cc_step_pairs pairs{};
    cc_step_view(step.s, &pairs);
    last_fn = 0.0;
    if (pairs.n > 0) {
      double point[3], normal[3], depth;
      const auto q0 = std::chrono::steady_clock::now();
      const int prc = cc_predict(&m, 1, pairs.p_AB, pairs.R_AB, pairs.size_A, 1, pairs.size_B, 1, point, normal,
                                 &depth, nullptr);
      const auto q1 = std::chrono::steady_clock::now();
      if (prc == CC_OK) predict_us.push_back(std::chrono::duration<double, std::micro>(q1 - q0).count());
      last_fn = pairs.fn[0];
      if (last_fn > 0.0) ++touching_steps;
    }
    // semi-implicit Euler on B: velocities from the wrench, then the pose from the new velocities
    const Vec3 tau{wrench[6], wrench[7], wrench[8]}, f{wrench[9], wrench[10], wrench[11]};
    for (int i = 0; i < 3; ++i) v[i] += h * f[i] / mass;
    v[2] -= h * g;
    // angular: I_W dw/dt = tau - w x (I_W w), with I_W = R I_B R^T
    const Vec3 w_B = mul_transposed(R_B, w);
    const Vec3 Iw_B{Ixx * w_B[0], Iyy * w_B[1], Izz * w_B[2]};
    const Vec3 gyro = cross(w, mul(R_B, Iw_B));
    const Vec3 rhs_B = mul_transposed(R_B, Vec3{tau[0] - gyro[0], tau[1] - gyro[1], tau[2] - gyro[2]});
    const Vec3 dw = mul(R_B, Vec3{rhs_B[0] / Ixx, rhs_B[1] / Iyy, rhs_B[2] / Izz});
    for (int i = 0; i < 3; ++i) w[i] += h * dw[i];
    for (int i = 0; i < 3; ++i) p[3 + i] += h * v[i];
    R_B = mul(rotation_of(Vec3{h * w[0], h * w[1], h * w[2]}), R_B);
    orthonormalise(R_B);
  }

  const Cost c_step = cost_of(step_us), c_pred = cost_of(predict_us);
  const double stacked = 0.5 * (size[2] + size[2]);
  const double height = p[5];
  const double tilt = std::acos(std::min(1.0, std::fabs(R_B[8]))) * 180.0 / kPi;
  bool finite = std::isfinite(height) && std::isfinite(norm(v)) && std::isfinite(norm(w));
  for (double e : R_B) finite = finite && std::isfinite(e);
  std::printf("crane_pair: %s model (format %d), a %.3f x %.3f x %.3f m box of %.0f kg landed from %.3f m\n",
              m.kind == CC_KIND_IMPROVED ? "improved" : "paper", m.format_version, size[0], size[1], size[2], mass,
              opt.drop);
  std::printf("stepped %zu steps at %.0f Hz (%.3f s simulated), in contact %zu steps\n", n_steps, 1.0 / h,
              static_cast<double>(n_steps) * h, touching_steps);
  std::printf("cost per cc_contact_step call [us]: median %.2f, p99 %.2f (%zu calls)\n", c_step.median, c_step.p99,
              c_step.n);
  std::printf("cost per cc_predict call, one pair [us]: median %.2f, p99 %.2f (%zu calls)\n", c_pred.median,
              c_pred.p99, c_pred.n);
  std::printf("rest: height %.6f m (stacked %.6f m, %+.1f um), offset (%.4f, %.4f) m, tilt %.4f deg, "
              "|v| %.2e m/s, |w| %.2e rad/s, normal force %.0f N (weight %.0f N)\n",
              height, stacked, (height - stacked) * 1e6, p[3], p[4], tilt, norm(v), norm(w), last_fn, mass * g);
  // one machine-readable line (tests/native/test_integrator_kit.py reads it)
  std::printf("result height_m=%.9f stacked_m=%.9f speed_mps=%.6e spin_radps=%.6e tilt_deg=%.6f fn_N=%.3f "
              "weight_N=%.3f finite=%d step_median_us=%.3f step_p99_us=%.3f predict_median_us=%.3f "
              "predict_p99_us=%.3f\n",
              height, stacked, norm(v), norm(w), tilt, last_fn, mass * g, finite ? 1 : 0, c_step.median, c_step.p99,
              c_pred.median, c_pred.p99);
  return 0;
}

// ---------------------------------------------------------------------------- batch mode

bool little_endian() {
  const uint16_t one = 1;
  uint8_t first;
  std::memcpy(&first, &one, 1);
  return first == 1;
}

int run_batch(const Model &model, const char *in_path, const char *out_path) {
  if (!little_endian()) {
    std::fprintf(stderr, "crane_pair: batch files are little-endian; this host is not\n");
    return kExitInput;
  }
  std::FILE *in = std::fopen(in_path, "rb");
  if (in == nullptr) {
    std::fprintf(stderr, "crane_pair: poses file %s cannot be opened (%s)\n", in_path, std::strerror(errno));
    return kExitInput;
  }
  uint64_t head[3];
  const bool head_ok = std::fread(head, sizeof head, 1, in) == 1;
  const uint64_t n = head_ok ? head[0] : 0, rows_A = head_ok ? head[1] : 0, rows_B = head_ok ? head[2] : 0;
  if (!head_ok || n == 0 || n > (uint64_t{1} << 32) || (rows_A != 1 && rows_A != n) || (rows_B != 1 && rows_B != n)) {
    std::fclose(in);
    std::fprintf(stderr, "crane_pair: poses file %s: header (n, rows_A, rows_B) is not n >= 1 with rows 1 or n\n",
                 in_path);
    return kExitInput;
  }
  std::vector<double> p(3 * n), R(9 * n), sA(3 * rows_A), sB(3 * rows_B);
  bool ok = std::fread(p.data(), sizeof(double), p.size(), in) == p.size() &&
            std::fread(R.data(), sizeof(double), R.size(), in) == R.size() &&
            std::fread(sA.data(), sizeof(double), sA.size(), in) == sA.size() &&
            std::fread(sB.data(), sizeof(double), sB.size(), in) == sB.size();
  ok = ok && std::fgetc(in) == EOF;  // exactly the declared size
  std::fclose(in);
  if (!ok) {
    std::fprintf(stderr, "crane_pair: poses file %s: expected %llu bytes after the header for n = %llu\n", in_path,
                 static_cast<unsigned long long>(8 * (12 * n + 3 * rows_A + 3 * rows_B)),
                 static_cast<unsigned long long>(n));
    return kExitInput;
  }
  std::vector<double> point(3 * n), normal(3 * n), depth(n);
  size_t bad_row = 0;
  const auto t0 = std::chrono::steady_clock::now();
  const int rc = cc_predict(&model.m, n, p.data(), R.data(), sA.data(), rows_A, sB.data(), rows_B, point.data(),
                            normal.data(), depth.data(), &bad_row);
  const auto t1 = std::chrono::steady_clock::now();
  if (rc != CC_OK) {
    std::fprintf(stderr, "crane_pair: cc_predict returned %d at row %zu of %s\n", rc, bad_row, in_path);
    return kExitInput;
  }
  std::FILE *out = std::fopen(out_path, "wb");
  ok = out != nullptr && std::fwrite(point.data(), sizeof(double), point.size(), out) == point.size() &&
       std::fwrite(normal.data(), sizeof(double), normal.size(), out) == normal.size() &&
       std::fwrite(depth.data(), sizeof(double), depth.size(), out) == depth.size();
  if (out != nullptr) ok = std::fclose(out) == 0 && ok;
  if (!ok) {
    std::fprintf(stderr, "crane_pair: cannot write %s\n", out_path);
    return kExitInput;
  }
  std::printf("crane_pair: %llu poses, one cc_predict call: %.3f us per pair\n", static_cast<unsigned long long>(n),
              std::chrono::duration<double, std::micro>(t1 - t0).count() / static_cast<double>(n));
  return 0;
}

int usage() {
  std::fprintf(stderr,
               "usage: crane_pair [WEIGHTS] [--seconds T] [--drop H] [--mass KG]\n"
               "       crane_pair WEIGHTS --poses IN.bin --out OUT.bin\n");
  return kExitUsage;
}

bool number(const char *text, double &out) {
  char *end = nullptr;
  out = std::strtod(text, &end);
  return end != text && *end == '\0' && std::isfinite(out);
}

}  // namespace

int main(int argc, char **argv) {
  const char *weights = CC_DEFAULT_WEIGHTS, *poses = nullptr, *out = nullptr;
  Options opt;
  int i = 1;
  if (i < argc && argv[i][0] != '-') weights = argv[i++];
  for (; i < argc; ++i) {
    const std::string a = argv[i];
    if (i + 1 >= argc) return usage();
    const char *value = argv[++i];
    if (a == "--poses") poses = value;
    else if (a == "--out") out = value;
    else if (a == "--seconds" && number(value, opt.seconds) && opt.seconds > 0) continue;
    else if (a == "--drop" && number(value, opt.drop) && opt.drop >= 0) continue;
    else if (a == "--mass" && number(value, opt.mass) && opt.mass > 0) continue;
    else return usage();
  }
  if ((poses == nullptr) != (out == nullptr)) return usage();
  if (!CC_CHECK_VERSION()) {  // a library built from other headers: refuse it rather than misread its structs
    std::fprintf(stderr, "crane_pair: the library's ABI version is %d; this program was built with %d\n",
                 cc_abi_version(), CC_ABI_VERSION);
    return kExitInput;
  }
  Model model;
  if (const int rc = load(weights, model)) return rc;
  return poses ? run_batch(model, poses, out) : run_steps(model, opt);
}
