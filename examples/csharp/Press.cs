// Press.cs: the C# example of lamina-client (Mono or .NET; the same P/Invoke as Unity).
// Takes --frames node frames in order (the sequence must rise and every frame carry every
// node), then presses the scene's sphere into the top of the skin 2, 4 and 6 mm deep and
// checks that the skin pushes back harder each time. Exit 0: every check held; 1: one did
// not; 2: a bad argument.
//
//   cargo build --release -p lamina-client
//   mcs -out:lamina_press.exe examples/csharp/Lamina.cs examples/csharp/Press.cs
//   ./target/release/lamina run --prefix demo &
//   LD_LIBRARY_PATH=target/release mono lamina_press.exe --prefix demo
using System;
using System.Diagnostics;
using System.Threading;

static class Press
{
    // Holds the sphere at `centre` for `seconds`, commanding every 2 ms; the mean upward force
    // of the second half's feedback (N), and whether all of it was in contact.
    static double Hold(Lamina.Client client, double[] centre, double radius, double seconds, out bool inContact)
    {
        var clock = Stopwatch.StartNew();
        double sum = 0.0;
        int kept = 0;
        bool contact = true;
        ulong last = ulong.MaxValue;
        while (clock.Elapsed.TotalSeconds < seconds)
        {
            client.SendSphere(centre[0], centre[1], centre[2], radius);
            Lamina.Feedback fb = client.LatestFeedback();
            if (clock.Elapsed.TotalSeconds >= seconds / 2 && fb.Sequence != last)
            {
                sum += fb.Force[1];
                contact &= fb.InContact == 1;
                kept++;
            }
            last = fb.Sequence;
            Thread.Sleep(2);
        }
        inContact = kept > 0 && contact;
        return kept > 0 ? sum / kept : 0.0;
    }

    static int Run(string prefix, int frames)
    {
        using (var client = new Lamina.Client(prefix, 60000))
        {
            Lamina.TopologyInfo topo = client.Topology;
            Console.WriteLine("topology of '{0}': {1} nodes, {2} triangles, {3} springs, {4} layers, {5} surfaces",
                topo.Name, topo.NodeCount, topo.TriangleCount, topo.SpringCount, topo.LayerCount, topo.SurfaceCount);
            for (uint i = 0; i < topo.SurfaceCount; i++)
            {
                Lamina.SurfaceInfo s = client.Surface(i);
                Console.WriteLine("  surface {0}: grid {1} x {2}", s.Name, s.GridCols, s.GridRows);
            }

            int n = (int)topo.NodeCount;
            var x = new float[3 * n];
            Lamina.FrameInfo f = client.NextFrame(x, 10000);
            ulong first = f.Sequence, last = f.Sequence, gaps = 0;
            for (int k = 1; k < frames; k++)
            {
                f = client.NextFrame(x, 10000);
                if (f.Sequence <= last || f.NodeCount != topo.NodeCount)
                {
                    Console.Error.WriteLine("lamina_press: sequence {0} after {1}, {2} nodes of {3}", f.Sequence, last, f.NodeCount, n);
                    return 1;
                }
                gaps += f.Sequence - last - 1;
                last = f.Sequence;
            }
            Console.WriteLine("{0} frames, sequence {1}..{2}, {3} lost, {4} nodes each", frames, first, last, gaps, n);
            if (gaps * 50 > (ulong)frames)
            {
                Console.Error.WriteLine("lamina_press: more than 2 % of the frames lost");
                return 1;
            }

            // The top of the skin nearest the middle of the model in x and z (the models are y up).
            var lo = new double[] { double.PositiveInfinity, double.PositiveInfinity, double.PositiveInfinity };
            var hi = new double[] { double.NegativeInfinity, double.NegativeInfinity, double.NegativeInfinity };
            for (int i = 0; i < n; i++)
                for (int a = 0; a < 3; a++)
                {
                    lo[a] = Math.Min(lo[a], x[3 * i + a]);
                    hi[a] = Math.Max(hi[a], x[3 * i + a]);
                }
            int touch = 0;
            double best = double.PositiveInfinity;
            for (int i = 0; i < n; i++)
            {
                double dx = x[3 * i] - (lo[0] + hi[0]) / 2, dz = x[3 * i + 2] - (lo[2] + hi[2]) / 2;
                if (x[3 * i + 1] >= hi[1] - 1e-3 && dx * dx + dz * dz < best)
                {
                    best = dx * dx + dz * dz;
                    touch = i;
                }
            }
            double r = topo.Tool.RadiusM;
            double[] top = { x[3 * touch], x[3 * touch + 1], x[3 * touch + 2] };
            Console.WriteLine("pressing node {0} at ({1:F4}, {2:F4}, {3:F4}) m with a {4:F1} mm sphere", touch, top[0], top[1], top[2], r * 1e3);
            double previous = 0.0;
            bool contact;
            foreach (double depthMm in new[] { 2.0, 4.0, 6.0 })
            {
                double up = Hold(client, new[] { top[0], top[1] + r - depthMm * 1e-3, top[2] }, r, 0.5, out contact);
                Console.WriteLine("depth {0:F1} mm: force up {1:F4} N, in contact {2}", depthMm, up, contact ? "yes" : "no");
                if (!contact || up <= previous)
                {
                    Console.Error.WriteLine("lamina_press: the force does not rise with depth");
                    return 1;
                }
                previous = up;
            }
            Hold(client, new[] { top[0], top[1] + r + 0.02, top[2] }, r, 0.1, out contact);
            Console.WriteLine("ok");
            return 0;
        }
    }

    static int Main(string[] args)
    {
        string prefix = "lamina";
        int frames = 1000;
        for (int i = 0; i < args.Length; i++)
        {
            if (args[i] == "--prefix" && i + 1 < args.Length) prefix = args[++i];
            else if (args[i] == "--frames" && i + 1 < args.Length)
            {
                if (!int.TryParse(args[++i], out frames) || frames < 2 || frames > 1000000)
                {
                    Console.Error.WriteLine("lamina_press: --frames {0}: give a whole number from 2 to 1000000", args[i]);
                    return 2;
                }
            }
            else
            {
                Console.Error.WriteLine("usage: lamina_press.exe [--prefix P] [--frames N]");
                return 2;
            }
        }
        try
        {
            return Run(prefix, frames);
        }
        catch (Lamina.LaminaException e)
        {
            Console.Error.WriteLine("lamina_press: " + e.Message);
            return 1;
        }
    }
}
