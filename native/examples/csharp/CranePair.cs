// CranePair.cs: the C# counterpart of crane_pair.cpp on the C API (ContainerContact.cs): checks the library's
// version and the structs' layout, answers three poses with cc_predict, lands a 20 ft box on a fixed one with
// cc_contact_step at 1 kHz (the testbed's defaults from cc_step_default_params; cc_step_default_sleep read back,
// sleeping left off for one pair), and checks Unity's frame conversion. One "key values" line per figure
// (tests/native/test_csharp.py reads them).
//
//   mcs -out:crane_pair_cs.exe ContainerContact.cs CranePair.cs && mono crane_pair_cs.exe WEIGHTS.npz
using System;
using System.Globalization;
using ContainerContact;

public static class CranePair
{
    const double G = 9.81, H = 1e-3;
    static readonly double[] Size20 = { 6.058, 2.438, 2.591 };

    static string F(double x) { return x.ToString("R", CultureInfo.InvariantCulture); }

    static double[] Rpy(double roll, double pitch, double yaw)
    {
        double cr = Math.Cos(roll), sr = Math.Sin(roll), cp = Math.Cos(pitch), sp = Math.Sin(pitch), cy = Math.Cos(yaw), sy = Math.Sin(yaw);
        return new[] { cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr,
                       sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr,
                       -sp, cp * sr, cp * cr };
    }

    static double[] Mul(double[] A, double[] B)
    {
        var C = new double[9];
        for (int r = 0; r < 3; ++r)
            for (int c = 0; c < 3; ++c)
                C[3 * r + c] = A[3 * r] * B[c] + A[3 * r + 1] * B[3 + c] + A[3 * r + 2] * B[6 + c];
        return C;
    }

    static double[] Rodrigues(double x, double y, double z)
    {
        double t = Math.Sqrt(x * x + y * y + z * z);
        if (t < 1e-300) return new double[] { 1, 0, 0, 0, 1, 0, 0, 0, 1 };
        double s = Math.Sin(0.5 * t) / t;
        return Unity.Matrix(Math.Cos(0.5 * t), x * s, y * s, z * s);
    }

    static int Main(string[] args)
    {
        Native.CheckLayout();
        Native.CheckVersion();
        Console.WriteLine($"version {Native.cc_version()} abi {Native.cc_abi_version()}");
        using (var model = new Model(args[0]))
        {
            // three poses of a 20 ft box on another (B's centre in A, B's orientation in A)
            var poses = new[] { (new[] { 0.01, 0.0, 2.589 }, Rpy(0, 0, 0)), (new[] { 0.3, -0.1, 2.588 }, Rpy(0.004, -0.002, 0.03)),
                                (new[] { 1.2, 0.4, 2.585 }, Rpy(0.02, 0.03, 0.6)) };
            int n = poses.Length;
            double[] p = new double[3 * n], R = new double[9 * n], point = new double[3 * n], normal = new double[3 * n], depth = new double[n];
            for (int i = 0; i < n; ++i)
            {
                Array.Copy(poses[i].Item1, 0, p, 3 * i, 3);
                Array.Copy(poses[i].Item2, 0, R, 9 * i, 9);
            }
            int status = Native.cc_predict(model.Handle, (UIntPtr)n, p, R, Size20, (UIntPtr)1, Size20, (UIntPtr)1, point, normal, depth, out UIntPtr bad);
            if (status != 0) { Console.Error.WriteLine($"cc_predict: {Native.StatusName(status)} at row {bad}"); return 1; }
            Console.WriteLine($"status_names {Native.StatusName(0)} {Native.StatusName(2)} {Native.StatusName(99)}");
            for (int i = 0; i < n; ++i)
                Console.WriteLine($"predict{i} {F(point[3 * i])} {F(point[3 * i + 1])} {F(point[3 * i + 2])} " +
                                  $"{F(normal[3 * i])} {F(normal[3 * i + 1])} {F(normal[3 * i + 2])} {F(depth[i])}");

            // the landing: A fixed at the origin, B (2.2 t) 0.1 m above it, off centre, tilted and yawed a little
            double mass = 2200.0, Ixx = mass / 12 * (Size20[1] * Size20[1] + Size20[2] * Size20[2]),
                   Iyy = mass / 12 * (Size20[0] * Size20[0] + Size20[2] * Size20[2]), Izz = mass / 12 * (Size20[0] * Size20[0] + Size20[1] * Size20[1]);
            var size = new double[6]; Array.Copy(Size20, size, 3); Array.Copy(Size20, 0, size, 3, 3);
            var I = new double[] { 0, 0, 0, 0, 0, 0, 0, 0, 0, Ixx, 0, 0, 0, Iyy, 0, 0, 0, Izz };
            using (var step = new Step(size, new byte[] { 0, 1 }, new[] { double.PositiveInfinity, mass }, I, Native.cc_step_default_params(H)))
            {
                // sleeping pays on a yard of resting stacks; one landing pair gains nothing from it, and with it on the
                // pair rests to ~3e-4 m/s instead of 3e-14 m/s (its reused answer is the one at the pose it fell
                // asleep at), so it is set off here: the defaults' struct is read back and passed as a yard would
                var sleep = Native.cc_step_default_sleep();
                Console.WriteLine($"sleep {sleep.Enabled} {F(sleep.VSleep)} {F(sleep.WSleep)} {F(sleep.TSleep)} {F(sleep.EpsP)} {F(sleep.EpsR)} {sleep.PairReuse}");
                sleep.Enabled = 0;
                if (Native.cc_step_set_sleep(step.Handle, ref sleep) != 0) { Console.Error.WriteLine("cc_step_set_sleep refused"); return 1; }
                double[] pw = { 0, 0, 0, 0.05, -0.03, Size20[2] + 0.1 }, v = new double[3], w = new double[3], wrench = new double[12];
                double[] RB = Rpy(0.5 * Math.PI / 180, -0.3 * Math.PI / 180, 2.0 * Math.PI / 180);
                for (int k = 0; k < 3000; ++k)
                {
                    var Rw = new double[18];
                    Rw[0] = Rw[4] = Rw[8] = 1;
                    Array.Copy(RB, 0, Rw, 9, 9);
                    double[] ww = { 0, 0, 0, w[0], w[1], w[2] }, vv = { 0, 0, 0, v[0], v[1], v[2] };
                    if (Native.cc_contact_step(model.Handle, step.Handle, pw, Rw, ww, vv, wrench, out UIntPtr row) != 0)
                    { Console.Error.WriteLine($"cc_contact_step failed at row {row}"); return 1; }
                    for (int i = 0; i < 3; ++i) v[i] += H * wrench[9 + i] / mass;
                    v[2] -= H * G;
                    // I_W dw/dt = tau - w x (I_W w), I_W = R diag(I) R^T
                    double[] wB = new double[3], rhs = new double[3];
                    for (int i = 0; i < 3; ++i) wB[i] = RB[i] * w[0] + RB[3 + i] * w[1] + RB[6 + i] * w[2];
                    double[] IwB = { Ixx * wB[0], Iyy * wB[1], Izz * wB[2] }, IwW = new double[3];
                    for (int i = 0; i < 3; ++i) IwW[i] = RB[3 * i] * IwB[0] + RB[3 * i + 1] * IwB[1] + RB[3 * i + 2] * IwB[2];
                    double[] tau = { wrench[6] - (w[1] * IwW[2] - w[2] * IwW[1]), wrench[7] - (w[2] * IwW[0] - w[0] * IwW[2]),
                                     wrench[8] - (w[0] * IwW[1] - w[1] * IwW[0]) };
                    for (int i = 0; i < 3; ++i) rhs[i] = RB[i] * tau[0] + RB[3 + i] * tau[1] + RB[6 + i] * tau[2];
                    double[] dB = { rhs[0] / Ixx, rhs[1] / Iyy, rhs[2] / Izz };
                    for (int i = 0; i < 3; ++i) w[i] += H * (RB[3 * i] * dB[0] + RB[3 * i + 1] * dB[1] + RB[3 * i + 2] * dB[2]);
                    for (int i = 0; i < 3; ++i) pw[3 + i] += H * v[i];
                    RB = Mul(Rodrigues(H * w[0], H * w[1], H * w[2]), RB);
                }
                double speed = Math.Sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]), spin = Math.Sqrt(w[0] * w[0] + w[1] * w[1] + w[2] * w[2]);
                Console.WriteLine($"rest {F(pw[5])} {F(Size20[2])} {F(speed)} {F(spin)} {F(wrench[11])} {F(mass * G)}");
            }
        }

        // Unity's frame: the converted quaternion's matrix is S R_Unity S (S swaps y and z), on random rotations
        var rng = new Random(7);
        double worst = 0, worstDet = 0;
        for (int k = 0; k < 1000; ++k)
        {
            double x = rng.NextDouble() - 0.5, y = rng.NextDouble() - 0.5, z = rng.NextDouble() - 0.5, s = rng.NextDouble() - 0.5;
            double l = Math.Sqrt(x * x + y * y + z * z + s * s);
            x /= l; y /= l; z /= l; s /= l;
            double[] Ru = Unity.Matrix(s, x, y, z), S = { 1, 0, 0, 0, 0, 1, 0, 1, 0 }, want = Mul(S, Mul(Ru, S)), got = Unity.Rotation(x, y, z, s);
            for (int i = 0; i < 9; ++i) worst = Math.Max(worst, Math.Abs(got[i] - want[i]));
            double det = got[0] * (got[4] * got[8] - got[5] * got[7]) - got[1] * (got[3] * got[8] - got[5] * got[6]) + got[2] * (got[3] * got[7] - got[4] * got[6]);
            worstDet = Math.Max(worstDet, Math.Abs(det - 1));
        }
        Console.WriteLine($"unity {F(worst)} {F(worstDet)}");
        return 0;
    }
}
