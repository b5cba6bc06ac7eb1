// Call overhead of the C# binding versus the C library itself.
//   mono LocdBench.exe [--sizes 100,10000,1000000] [--threads T] [--seconds S]
// For each n it times, per call, with a Stopwatch around the C# call, and reads
// the C library's own in-call time (stats ms_total, measured inside C), for:
//   raw    Native.locd_engine_find_pairs_f32_into on pinned arrays (P/Invoke only)
//   buffer Engine.FindPairs(boxes, n, ref buffer)  (safe layer, reused buffer)
//   array  Engine.FindPairs(boxes) -> new uint[]   (safe layer, allocates the result)
// and prints the medians: C# wall time, C time, and their difference (overhead).
using System;
using System.Collections.Generic;
using System.Diagnostics;

namespace Locd.Bench
{
    public static unsafe class Program
    {
        static double Median(List<double> v)
        {
            var a = v.ToArray();
            Array.Sort(a);
            return a.Length == 0 ? 0 : (a[(a.Length - 1) / 2] + a[a.Length / 2]) / 2;
        }

        // Uniform boxes at constant density: about half an overlap per box at every n.
        static float[] Scene(int n, ulong seed)
        {
            ulong s = seed;
            Func<double> u = () => {
                ulong z = (s += 0x9E3779B97F4A7C15UL);
                z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9UL;
                z = (z ^ (z >> 27)) * 0x94D049BB133111EBUL;
                return ((z ^ (z >> 31)) >> 11) * (1.0 / 9007199254740992.0);
            };
            double side = 2 * Math.Pow(n, 1.0 / 3);
            var b = new float[6 * n];
            for (int i = 0; i < n; i++)
                for (int a = 0; a < 3; a++) {
                    double lo = u() * side;
                    b[6 * i + a] = (float)lo;
                    b[6 * i + 3 + a] = (float)(lo + u() * 2);
                }
            return b;
        }

        delegate long Call();

        static void Measure(string name, int n, Engine e, Call call, double seconds, int minReps)
        {
            var wall = new List<double>();
            var c = new List<double>();
            var diff = new List<double>();
            long pairs = call(); // warm-up: JIT, buffers
            var total = Stopwatch.StartNew();
            while (wall.Count < minReps || total.Elapsed.TotalSeconds < seconds) {
                var sw = Stopwatch.StartNew();
                call();
                double w = sw.Elapsed.TotalMilliseconds;
                double inC = e.Stats.MsTotal;
                wall.Add(w);
                c.Add(inC);
                diff.Add(w - inC);
                if (wall.Count >= 100000)
                    break;
            }
            Console.WriteLine("| {0,9:N0} | {1,-6} | {2,10:N0} | {3,5} | {4,12:F4} | {5,12:F4} | {6,14:F2} |",
                              n, name, pairs, wall.Count, Median(wall), Median(c), Median(diff) * 1000);
        }

        public static int Main(string[] args)
        {
            var sizes = new List<int> { 100, 10000, 1000000 };
            int threads = 0;
            double seconds = 2;
            for (int a = 0; a < args.Length; a++) {
                if (args[a] == "--sizes" && a + 1 < args.Length) {
                    sizes.Clear();
                    foreach (string s in args[++a].Split(','))
                        sizes.Add(int.Parse(s));
                } else if (args[a] == "--threads" && a + 1 < args.Length) {
                    threads = int.Parse(args[++a]);
                } else if (args[a] == "--seconds" && a + 1 < args.Length) {
                    seconds = double.Parse(args[++a], System.Globalization.CultureInfo.InvariantCulture);
                } else {
                    Console.Error.WriteLine("usage: LocdBench.exe [--sizes 100,10000,1000000] [--threads T] [--seconds S]");
                    return 2;
                }
            }
            using (var e = new Engine(threads)) {
                Console.WriteLine("locd {0}, mono {1}, {2} engine threads, {3} logical CPUs",
                                  Engine.NativeVersion, Environment.Version, e.Threads, Environment.ProcessorCount);
                Console.WriteLine("| n         | path   | pairs      | calls | C# ms/call   | C ms/call    | overhead us/call |");
                Console.WriteLine("|----------:|--------|-----------:|------:|-------------:|-------------:|---------------:|");
                foreach (int n in sizes) {
                    var boxes = Scene(n, (ulong)n);
                    uint[] buffer = new uint[2];
                    e.FindPairs(boxes, n, ref buffer); // size the buffer once
                    IntPtr h = e.NativeHandle;
                    int minReps = n >= 1000000 ? 5 : 20;
                    Measure("raw", n, e, () => {
                        UIntPtr count;
                        fixed (float* b = boxes)
                        fixed (uint* p = buffer) {
                            int st = Native.locd_engine_find_pairs_f32_into(h, b, (UIntPtr)(uint)n, 0, p,
                                                                             (UIntPtr)(uint)(buffer.Length / 2), &count);
                            if (st != 0)
                                throw new Exception("status " + st);
                        }
                        return (long)(ulong)count;
                    }, seconds, minReps);
                    Measure("buffer", n, e, () => e.FindPairs(boxes, n, ref buffer), seconds, minReps);
                    Measure("array", n, e, () => e.FindPairs(boxes).Length / 2, seconds, minReps);
                }
            }
            return 0;
        }
    }
}
