// Lamina.cs: P/Invoke declarations of lamina-client's C ABI (client/include/lamina.h) and a
// small IDisposable wrapper, for .NET, Mono and Unity. The library is found by its name,
// "lamina_client": liblamina_client.so on the loader's path (LD_LIBRARY_PATH, or a Unity
// project's Assets/Plugins). Like the C handle, a Lamina.Client is used on the thread that
// opened it (Unity: the main thread).
using System;
using System.Runtime.InteropServices;
using System.Text;

namespace Lamina
{
    /// <summary>LaminaStatus: what a call did.</summary>
    public enum Status : int
    {
        Ok = 0, NullPointer = 1, InvalidArgument = 2, BadHandle = 3, WrongThread = 4, Connect = 5,
        Timeout = 6, CoreGone = 7, Protocol = 8, BufferTooSmall = 9, NoTool = 10, Ipc = 11, Panic = 12,
    }

    [StructLayout(LayoutKind.Sequential)]
    public struct ToolInfo
    {
        public uint Source;
        public uint Reserved;
        public double RadiusM;
        public double MinRadiusM;
        public double StiffnessNPerM;
        [MarshalAs(UnmanagedType.ByValArray, SizeConst = 3)] public double[] DeviceOriginM;
        [MarshalAs(UnmanagedType.ByValArray, SizeConst = 9)] public double[] DeviceRotation;
        public double PositionScale;
        public double ForceScale;
    }

    [StructLayout(LayoutKind.Sequential)]
    public struct TopologyInfo
    {
        public ulong Revision;
        public uint NodeCount;
        public uint TriangleCount;
        public uint LayerCount;
        public uint SurfaceCount;
        public uint SpringCount;
        public uint RestPositionCount;
        public ToolInfo Tool;
        [MarshalAs(UnmanagedType.ByValArray, SizeConst = 65)] public byte[] ModelName;
        public string Name { get { return Native.Text(ModelName); } }
    }

    [StructLayout(LayoutKind.Sequential)]
    public struct LayerInfo
    {
        public uint FirstNode;
        public uint NodeCount;
        public uint Tissue;
        [MarshalAs(UnmanagedType.ByValArray, SizeConst = 33)] public byte[] NameBytes;
        public string Name { get { return Native.Text(NameBytes); } }
    }

    [StructLayout(LayoutKind.Sequential)]
    public struct SurfaceInfo
    {
        public uint Tissue;
        public uint GridCols;
        public uint GridRows;
        public uint IndexCount;
        [MarshalAs(UnmanagedType.ByValArray, SizeConst = 33)] public byte[] NameBytes;
        public string Name { get { return Native.Text(NameBytes); } }
    }

    [StructLayout(LayoutKind.Sequential)]
    public struct FrameInfo
    {
        public ulong Sequence;
        public ulong Tick;
        public double SimTimeS;
        public ulong PublishTimeNs;
        public uint NodeCount;
        public uint Reserved;
    }

    [StructLayout(LayoutKind.Sequential)]
    public struct Feedback
    {
        public ulong Sequence;
        public ulong Tick;
        public ulong PublishTimeNs;
        public uint InContact;
        public uint Reserved;
        [MarshalAs(UnmanagedType.ByValArray, SizeConst = 3)] public double[] Force;
        [MarshalAs(UnmanagedType.ByValArray, SizeConst = 9)] public double[] Stiffness;
        [MarshalAs(UnmanagedType.ByValArray, SizeConst = 3)] public double[] XRef;
    }

    /// <summary>The exported functions, one to one.</summary>
    public static class Native
    {
        const string Lib = "lamina_client";
        public const uint AbiVersion = 2;

        [DllImport(Lib)] public static extern uint lamina_abi_version();
        [DllImport(Lib)] public static extern UIntPtr lamina_last_error_copy(byte[] buffer, UIntPtr capacity);
        [DllImport(Lib)] public static extern IntPtr lamina_status_name(int status);
        [DllImport(Lib)] public static extern Status lamina_open(byte[] prefix, uint timeoutMs, out ulong client);
        [DllImport(Lib)] public static extern Status lamina_close(ulong client);
        [DllImport(Lib)] public static extern Status lamina_topology_info(ulong client, out TopologyInfo info);
        [DllImport(Lib)] public static extern Status lamina_layer_info(ulong client, uint index, out LayerInfo info);
        [DllImport(Lib)] public static extern Status lamina_surface_info(ulong client, uint index, out SurfaceInfo info);
        [DllImport(Lib)] public static extern Status lamina_rest_positions(ulong client, [Out] float[] positions, UIntPtr capacityNodes, out UIntPtr count);
        [DllImport(Lib)] public static extern Status lamina_next_frame(ulong client, uint timeoutMs, [Out] float[] positions, UIntPtr capacityNodes, out FrameInfo info);
        [DllImport(Lib)] public static extern Status lamina_latest_frame(ulong client, uint timeoutMs, [Out] float[] positions, UIntPtr capacityNodes, out FrameInfo info);
        [DllImport(Lib)] public static extern Status lamina_send_sphere(ulong client, double x, double y, double z, double radiusM);
        [DllImport(Lib)] public static extern Status lamina_send_grasp(ulong client, double x, double y, double z, double radiusM, uint closed);
        [DllImport(Lib)] public static extern Status lamina_send_scalpel(ulong client, double x, double y, double z, double bladeLengthM);
        [DllImport(Lib)] public static extern Status lamina_latest_feedback(ulong client, uint timeoutMs, out Feedback feedback);

        /// <summary>The text of a NUL-terminated UTF-8 field.</summary>
        public static string Text(byte[] bytes)
        {
            if (bytes == null) return "";
            int n = Array.IndexOf(bytes, (byte)0);
            return Encoding.UTF8.GetString(bytes, 0, n < 0 ? bytes.Length : n);
        }

        /// <summary>The last error message of this thread.</summary>
        public static string LastError()
        {
            int len = (int)lamina_last_error_copy(null, UIntPtr.Zero);
            var buffer = new byte[len + 1];
            lamina_last_error_copy(buffer, (UIntPtr)buffer.Length);
            return Encoding.UTF8.GetString(buffer, 0, len);
        }
    }

    /// <summary>A failed call: its status and the library's message.</summary>
    public class LaminaException : Exception
    {
        public readonly Status Status;
        public LaminaException(string call, Status status)
            : base(call + ": " + Marshal.PtrToStringAnsi(Native.lamina_status_name((int)status)) + ": " + Native.LastError())
        {
            Status = status;
        }
    }

    /// <summary>A connection to one Lamina core; Dispose closes it.</summary>
    public sealed class Client : IDisposable
    {
        ulong handle;
        public readonly TopologyInfo Topology;

        static void Check(Status s, string call)
        {
            if (s != Status.Ok) throw new LaminaException(call, s);
        }

        /// <summary>Joins the core on `prefix`, waiting up to `timeoutMs` for its topology.</summary>
        public Client(string prefix = "lamina", uint timeoutMs = 10000)
        {
            if (Native.lamina_abi_version() != Native.AbiVersion)
                throw new InvalidOperationException("liblamina_client speaks ABI " + Native.lamina_abi_version() + ", this file " + Native.AbiVersion);
            Check(Native.lamina_open(Encoding.UTF8.GetBytes(prefix + "\0"), timeoutMs, out handle), "lamina_open");
            Check(Native.lamina_topology_info(handle, out Topology), "lamina_topology_info");
        }

        public LayerInfo Layer(uint index)
        {
            LayerInfo info;
            Check(Native.lamina_layer_info(handle, index, out info), "lamina_layer_info");
            return info;
        }

        public SurfaceInfo Surface(uint index)
        {
            SurfaceInfo info;
            Check(Native.lamina_surface_info(handle, index, out info), "lamina_surface_info");
            return info;
        }

        /// <summary>The oldest queued frame into `positions` (x y z per node, m; 3 floats per node).</summary>
        public FrameInfo NextFrame(float[] positions, uint timeoutMs = 1000)
        {
            FrameInfo info;
            Check(Native.lamina_next_frame(handle, timeoutMs, positions, (UIntPtr)(positions.Length / 3), out info), "lamina_next_frame");
            return info;
        }

        /// <summary>The newest frame into `positions`, older queued ones dropped.</summary>
        public FrameInfo LatestFrame(float[] positions, uint timeoutMs = 1000)
        {
            FrameInfo info;
            Check(Native.lamina_latest_frame(handle, timeoutMs, positions, (UIntPtr)(positions.Length / 3), out info), "lamina_latest_frame");
            return info;
        }

        /// <summary>The sphere's centre at (x, y, z), m, model frame; radius 0: the scene's.</summary>
        public void SendSphere(double x, double y, double z, double radiusM)
        {
            Check(Native.lamina_send_sphere(handle, x, y, z, radiusM), "lamina_send_sphere");
        }

        public void SendGrasp(double x, double y, double z, double radiusM, bool closed)
        {
            Check(Native.lamina_send_grasp(handle, x, y, z, radiusM, closed ? 1u : 0u), "lamina_send_grasp");
        }

        /// <summary>The scalpel's tip at (x, y, z), m, model frame, its cutting edge straight up
        /// (+y) from the tip, bladeLengthM long (0: the scene's).</summary>
        public void SendScalpel(double x, double y, double z, double bladeLengthM)
        {
            Check(Native.lamina_send_scalpel(handle, x, y, z, bladeLengthM), "lamina_send_scalpel");
        }

        public Feedback LatestFeedback(uint timeoutMs = 1000)
        {
            Feedback fb;
            Check(Native.lamina_latest_feedback(handle, timeoutMs, out fb), "lamina_latest_feedback");
            return fb;
        }

        public void Dispose()
        {
            if (handle != 0) Native.lamina_close(handle);
            handle = 0;
        }
    }
}
