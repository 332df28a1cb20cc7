// ContainerContact.cs: the C API (container_contact.h, container_contact_step.h) for C# and Unity, through
// P/Invoke. Compiled and run by the tests with Mono (tests/native/test_csharp.py); any .NET or Unity
// runtime loads the same declarations. The library: libcontainer_contact.so (Linux, `make -C native`),
// container_contact.dll (Windows, `make -C native dll CC=x86_64-w64-mingw32-gcc`).
//
// Conventions kept here so that a caller cannot get them wrong:
// - every import is Cdecl (the C ABI's default on every platform; Windows x86 would otherwise use stdcall);
// - a path is passed as NUL-terminated UTF-8 bytes, never as a platform-ANSI string;
// - the model is an opaque block of unmanaged memory (cc_model's layout is the library's business);
// - cc_step_params and cc_step_scene are mirrored field for field (doubles, ints, pointers: the same
//   offsets under C's and C#'s sequential layout on 64-bit platforms, which CheckLayout asserts);
// - arrays are double[] (blittable: pinned for the call, no copy), row-major as the headers say.
using System;
using System.Runtime.InteropServices;
using System.Text;

namespace ContainerContact
{
    [StructLayout(LayoutKind.Sequential)]
    public struct StepParams
    {
        public double Margin, H, Dissipation, Mu, StickHw, StickZeta, Slip, Stiction;
        public int Torsional, Grid, Sweeps, NTypes;
        public IntPtr Kappa; // (n_types, n_types) [Pa/m]; cc_step_default_params points it at the library's own
    }

    [StructLayout(LayoutKind.Sequential)]
    public struct StepScene
    {
        public UIntPtr NBodies;
        public IntPtr Size, Free, Mass, IBo, TypeIndex;
    }

    [StructLayout(LayoutKind.Sequential)]
    public struct StepSleep
    {
        public int Enabled;
        public double VSleep, WSleep, TSleep, EpsP, EpsR;
        public int PairReuse;
    }

    public static class Native
    {
        public const string Library = "container_contact"; // libcontainer_contact.so / container_contact.dll
        public const int AbiVersion = 4;                  // CC_ABI_VERSION of the headers these mirror
        public const int ModelBytes = 4096;               // more than sizeof(cc_model) on any platform

        [DllImport(Library, CallingConvention = CallingConvention.Cdecl)] public static extern int cc_version();
        [DllImport(Library, CallingConvention = CallingConvention.Cdecl)] public static extern int cc_abi_version();
        [DllImport(Library, CallingConvention = CallingConvention.Cdecl)] public static extern IntPtr cc_status_name(int status);
        /// <summary>The status's enumerator name ("CC_OK", ...): a static ASCII string of the library's.</summary>
        public static string StatusName(int status) => Marshal.PtrToStringAnsi(cc_status_name(status));
        [DllImport(Library, CallingConvention = CallingConvention.Cdecl)]
        public static extern int cc_model_load(byte[] pathUtf8, IntPtr model, byte[] err, UIntPtr errLen);
        [DllImport(Library, CallingConvention = CallingConvention.Cdecl)] public static extern void cc_model_free(IntPtr model);
        [DllImport(Library, CallingConvention = CallingConvention.Cdecl)]
        public static extern int cc_predict(IntPtr model, UIntPtr n, double[] pAB, double[] RAB, double[] sizeA, UIntPtr rowsA,
                                            double[] sizeB, UIntPtr rowsB, double[] pointA, double[] normalA, double[] depth,
                                            out UIntPtr badRow);
        [DllImport(Library, CallingConvention = CallingConvention.Cdecl)] public static extern StepParams cc_step_default_params(double h);
        [DllImport(Library, CallingConvention = CallingConvention.Cdecl)] public static extern StepSleep cc_step_default_sleep();
        [DllImport(Library, CallingConvention = CallingConvention.Cdecl)]
        public static extern IntPtr cc_step_create(ref StepScene scene, ref StepParams parameters, out int status);
        [DllImport(Library, CallingConvention = CallingConvention.Cdecl)] public static extern void cc_step_free(IntPtr step);
        [DllImport(Library, CallingConvention = CallingConvention.Cdecl)]
        public static extern int cc_step_set_sleep(IntPtr step, ref StepSleep sleep);
        [DllImport(Library, CallingConvention = CallingConvention.Cdecl)]
        public static extern int cc_contact_step(IntPtr model, IntPtr step, double[] pWB, double[] RWB, double[] wWB, double[] vWB,
                                                 double[] wrenchW, out UIntPtr badRow);

        /// <summary>Throws unless the loaded library is the ABI these declarations mirror (MuJoCo's mj_version check).</summary>
        public static void CheckVersion()
        {
            int abi = cc_abi_version();
            if (abi != AbiVersion)
                throw new InvalidOperationException($"container_contact: the library's ABI version is {abi}; these declarations mirror {AbiVersion}");
        }

        /// <summary>Throws unless the mirrored structs have the C layout's sizes and offsets (64-bit).</summary>
        public static void CheckLayout()
        {
            if (Marshal.SizeOf(typeof(StepParams)) != 88 || (int)Marshal.OffsetOf(typeof(StepParams), "Kappa") != 80 ||
                Marshal.SizeOf(typeof(StepScene)) != 48 || Marshal.SizeOf(typeof(StepSleep)) != 56)
                throw new InvalidOperationException("container_contact: a struct's layout is not C's (a 64-bit process is needed)");
        }

        public static byte[] Utf8Path(string path)
        {
            byte[] text = Encoding.UTF8.GetBytes(path);
            byte[] z = new byte[text.Length + 1];
            Array.Copy(text, z, text.Length);
            return z;
        }
    }

    /// <summary>A loaded predictor: the opaque cc_model in unmanaged memory.</summary>
    public sealed class Model : IDisposable
    {
        public IntPtr Handle { get; private set; }

        public Model(string path)
        {
            Handle = Marshal.AllocHGlobal(Native.ModelBytes);
            byte[] err = new byte[512];
            int status = Native.cc_model_load(Native.Utf8Path(path), Handle, err, (UIntPtr)err.Length);
            if (status != 0)
            {
                Marshal.FreeHGlobal(Handle);
                Handle = IntPtr.Zero;
                throw new ArgumentException(Encoding.UTF8.GetString(err).TrimEnd('\0'));
            }
        }

        public void Dispose()
        {
            if (Handle == IntPtr.Zero) return;
            Native.cc_model_free(Handle);
            Marshal.FreeHGlobal(Handle);
            Handle = IntPtr.Zero;
        }
    }

    /// <summary>A contact step over fixed bodies (cc_step_create copies the scene and the parameters).</summary>
    public sealed class Step : IDisposable
    {
        public IntPtr Handle { get; private set; }

        public Step(double[] size, byte[] free, double[] mass, double[] iBo, StepParams parameters)
        {
            int m = free.Length;
            if (size.Length != 3 * m || mass.Length != m || iBo.Length != 9 * m) throw new ArgumentException("array sizes");
            var pins = new[] { GCHandle.Alloc(size, GCHandleType.Pinned), GCHandle.Alloc(free, GCHandleType.Pinned),
                               GCHandle.Alloc(mass, GCHandleType.Pinned), GCHandle.Alloc(iBo, GCHandleType.Pinned) };
            try
            {
                var scene = new StepScene { NBodies = (UIntPtr)m, Size = pins[0].AddrOfPinnedObject(), Free = pins[1].AddrOfPinnedObject(),
                                            Mass = pins[2].AddrOfPinnedObject(), IBo = pins[3].AddrOfPinnedObject(), TypeIndex = IntPtr.Zero };
                Handle = Native.cc_step_create(ref scene, ref parameters, out int status);
                if (Handle == IntPtr.Zero)
                    throw new ArgumentException($"cc_step_create refused the scene ({Native.StatusName(status)})");
            }
            finally
            {
                foreach (var pin in pins) pin.Free();
            }
        }

        public void Dispose()
        {
            if (Handle == IntPtr.Zero) return;
            Native.cc_step_free(Handle);
            Handle = IntPtr.Zero;
        }
    }

    /// <summary>Unity's frame (left-handed, y up; quaternions x, y, z, w) to the library's (right-handed, z up;
    /// rotation matrices, row-major) and back. The map S swaps y and z: p = S p_Unity, R = S R_Unity S. S is a
    /// reflection (det -1), so it turns a left-handed frame into a right-handed one; a rotation by t about axis a
    /// in Unity is one by -t about S a here, which is the quaternion (w, -x, -z, -y) in (w, x, y, z) order.</summary>
    public static class Unity
    {
        public static double[] Position(double x, double y, double z) { return new[] { x, z, y }; }

        /// <summary>Unity's quaternion (x, y, z, w) as this library's row-major rotation matrix.</summary>
        public static double[] Rotation(double x, double y, double z, double w)
        {
            return Matrix(w, -x, -z, -y);
        }

        /// <summary>The rotation matrix (row-major) of a unit quaternion (w, x, y, z) in a right-handed frame.</summary>
        public static double[] Matrix(double w, double x, double y, double z)
        {
            return new[] { 1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y),
                           2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x),
                           2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y) };
        }

        /// <summary>A force or a point back to Unity: S v (its own inverse).</summary>
        public static double[] ToUnity(double[] v) { return new[] { v[0], v[2], v[1] }; }
    }
}
