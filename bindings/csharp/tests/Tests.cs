// The C# binding's test suite, run under mono in CI (scripts/ci/steps/30-csharp.sh):
//   mono LocdTests.exe [JUNIT.xml] [--filter TEXT]
//   mono LocdTests.exe --child NAME     (one test body that may crash, run by Child.Expect)
// Environment: LOCD_LAYOUT = output of tests/layout.c (struct layout check),
//              LOCD_CLI    = path of the `locd` tool (cross-check with `locd pairs`).
using System;
using System.Collections.Generic;
using System.Diagnostics;
using System.IO;
using System.Runtime.CompilerServices;
using System.Runtime.InteropServices;
using System.Threading;

namespace Locd.Tests
{
    public static unsafe class Program
    {
        public static int Main(string[] args)
        {
            // A test that may crash the process runs its body in a child: LocdTests.exe --child NAME.
            if (args.Length == 2 && args[0] == "--child")
                return Child.Run(args[1]);
            string junit = null, filter = null;
            for (int a = 0; a < args.Length; a++) {
                if (args[a] == "--filter" && a + 1 < args.Length)
                    filter = args[++a];
                else
                    junit = args[a];
            }
            Console.WriteLine("locd native library " + Engine.NativeVersion);
            var h = new Harness();
            // Layout and basics
            h.Add("layout.sizes_match_library_init", SizesMatchLibraryInit);
            h.Add("layout.offsets_match_c_compiler", OffsetsMatchCCompiler);
            h.Add("status.every_code_known_to_c", EveryStatusKnownToC);
            h.Add("engine.defaults_and_options", DefaultsAndOptions);
            h.Add("native.pipeline_spheres", NativeRaw.PipelineSpheres);
            h.Add("native.service_create_destroy", NativeRaw.ServiceCreateDestroy);
            // Equality with the C library and a C# reference
            h.Add("equality.random_uniform_scenes", () => RandomScenes("uniform"));
            h.Add("equality.random_snapped_scenes", () => RandomScenes("snapped"));
            h.Add("equality.random_mixed_far_scenes", () => RandomScenes("mixed"));
            h.Add("equality.f64_far_from_origin", F64FarFromOrigin);
            h.Add("equality.every_overload_same_pairs", EveryOverloadSamePairs);
            h.Add("equality.thread_counts_same_order", ThreadCountsSameOrder);
            h.Add("equality.cli_pairs_file", CliPairsFile);
            h.Add("equality.parallel_callers", ParallelCallers);
            // Touching and degenerate boxes
            h.Add("touching.faces_edges_corners", TouchingFacesEdgesCorners);
            h.Add("touching.one_ulp_apart_is_no_pair", OneUlpApart);
            h.Add("degenerate.points_planes_identical", DegeneratePointsPlanesIdentical);
            h.Add("degenerate.empty_and_single", EmptyAndSingle);
            // Errors
            h.Add("errors.nan_and_inf_give_index", NanAndInfGiveIndex);
            h.Add("errors.inverted_box_first_bad_index", InvertedBoxFirstBadIndex);
            h.Add("errors.bad_options", BadOptions);
            h.Add("errors.managed_argument_checks", ManagedArgumentChecks);
            h.Add("errors.buffer_too_small", BufferTooSmall);
            h.Add("errors.detail_is_per_thread", DetailIsPerThread);
            // Statistics
            h.Add("stats.after_find", StatsAfterFind);
            // Lifetime
            h.Add("lifetime.dispose_twice_and_use_after", DisposeTwiceAndUseAfter);
            h.Add("lifetime.finalizer_releases_native", FinalizerReleasesNative);
            h.Add("lifetime.10000_create_destroy_no_growth", CreateDestroyNoGrowth);
            h.Add("lifetime.reused_buffer_no_allocation", ReusedBufferNoAllocation);
            // The two-set query (Between.cs)
            h.Add("between.random_sets_match_brute_force", Between.RandomSetsMatchBruteForce);
            h.Add("between.empty_sets_and_bad_box_index", Between.EmptySetsAndBadBoxIndex);
            // Levels 2 and 3
            h.Add("levels.workers_same_as_level1", Levels.Workers);
            h.Add("levels.service_same_as_level1_and_jobs", Levels.Service);
            // Jobs
            h.Add("jobs.result_equals_find", JobResultEqualsFind);
            h.Add("jobs.isdone_polling_and_wait_timeout", JobPollingAndTimeout);
            h.Add("jobs.error_mapping", JobErrorMapping);
            h.Add("jobs.keep_engine_alive_and_release", JobKeepsEngineAlive);
            // Scene (SceneTests.cs)
            SceneTests.Register(h);
            // Scene queries (SceneQueryTests.cs)
            SceneQueryTests.Register(h);
            return h.Run(junit, filter);
        }

        // ------------------------------------------------------------------
        // Layout
        // ------------------------------------------------------------------

        static void SizesMatchLibraryInit()
        {
            // The library writes sizeof(struct) into `size` in its init functions.
            Native.locd_engine_config cfg;
            Native.locd_engine_config_init(&cfg);
            Assert.Equal((uint)Marshal.SizeOf(typeof(Native.locd_engine_config)), cfg.size, "sizeof(locd_engine_config)");
            Assert.Equal((uint)sizeof(Native.locd_engine_config), cfg.size, "unmanaged sizeof(locd_engine_config)");
            Assert.Equal(1, cfg.level, "default level (offset of `level`)");
            Assert.Equal(2, cfg.cell_bias, "default cell_bias (offset of `cell_bias`)");
            Native.locd_stats st;
            Native.locd_stats_init(&st);
            Assert.Equal((uint)Marshal.SizeOf(typeof(Native.locd_stats)), st.size, "sizeof(locd_stats)");
            Assert.Equal((uint)sizeof(Native.locd_stats), st.size, "unmanaged sizeof(locd_stats)");
            // locd_grid has no init: the fit function fills it; check `size` and a sane depth.
            var boxes = Scenes.Uniform(new Rng(1), 10, 10, 1);
            Native.locd_grid g;
            fixed (float* b = boxes)
                Assert.Equal(0, Native.locd_grid_fit_f32(b, (UIntPtr)10u, 0, 1, 0, &g), "grid fit status");
            Assert.Equal((uint)Marshal.SizeOf(typeof(Native.locd_grid)), g.size, "sizeof(locd_grid)");
            Assert.True(g.depth >= 1 && g.depth <= 21, "grid depth " + g.depth + " in 1..21 (offset of `depth`)");
            Native.locd_service_config sc;
            Native.locd_service_config_init(&sc);
            Assert.Equal((uint)Marshal.SizeOf(typeof(Native.locd_service_config)), sc.size, "sizeof(locd_service_config)");
            Native.locd_pipeline_options po;
            Native.locd_pipeline_options_init(&po);
            Assert.Equal((uint)Marshal.SizeOf(typeof(Native.locd_pipeline_options)), po.size, "sizeof(locd_pipeline_options)");
            Assert.Equal((uint)sizeof(Native.locd_pipeline_options), po.size, "unmanaged sizeof(locd_pipeline_options)");
            Native.locd_pipeline_stats ps;
            Native.locd_pipeline_stats_init(&ps);
            Assert.Equal((uint)Marshal.SizeOf(typeof(Native.locd_pipeline_stats)), ps.size, "sizeof(locd_pipeline_stats)");
        }

        static void OffsetsMatchCCompiler()
        {
            string path = Environment.GetEnvironmentVariable("LOCD_LAYOUT");
            if (string.IsNullOrEmpty(path) || !File.Exists(path))
                throw new SkipException("LOCD_LAYOUT not set (the CI step builds tests/layout.c and sets it)");
            var types = new Dictionary<string, Type> {
                { "locd_allocator", typeof(Native.locd_allocator) },
                { "locd_engine_config", typeof(Native.locd_engine_config) },
                { "locd_stats", typeof(Native.locd_stats) },
                { "locd_grid", typeof(Native.locd_grid) },
                { "locd_service_config", typeof(Native.locd_service_config) },
                { "locd_pipeline_options", typeof(Native.locd_pipeline_options) },
                { "locd_stage_stats", typeof(Native.locd_stage_stats) },
                { "locd_pipeline_stats", typeof(Native.locd_pipeline_stats) },
                { "locd_scene_config", typeof(Native.locd_scene_config) },
                { "locd_scene_add_options", typeof(Native.locd_scene_add_options) },
                { "locd_scene_stats", typeof(Native.locd_scene_stats) },
                { "locd_query_filter", typeof(Native.locd_query_filter) },
            };
            int checkedCount = 0;
            foreach (string line in File.ReadAllLines(path)) {
                string[] parts = line.Split(' ');
                if (parts.Length != 2)
                    continue;
                long expected = long.Parse(parts[1]);
                string[] name = parts[0].Split('.');
                Type t;
                Assert.True(types.TryGetValue(name[0], out t), "C# mirror of " + name[0]);
                long actual = name.Length == 1 ? Marshal.SizeOf(t) : (long)Marshal.OffsetOf(t, name[1]);
                Assert.Equal(expected, actual, parts[0]);
                checkedCount++;
            }
            // Every field of the mirrors was covered by the C side.
            int fields = 0;
            foreach (var t in types.Values)
                fields += t.GetFields().Length + 1;
            Assert.Equal(fields, checkedCount, "sizes and offsets compared");
        }

        static void EveryStatusKnownToC()
        {
            string unknown = LocdException.StatusString((Status)12345);
            foreach (Status s in Enum.GetValues(typeof(Status))) {
                string text = LocdException.StatusString(s);
                Assert.True(!string.IsNullOrEmpty(text) && text != unknown, "C knows status " + s + " (" + (int)s + ")");
            }
        }

        static void DefaultsAndOptions()
        {
            using (var e = new Engine()) {
                Assert.Equal(Level.InProcess, e.Level, "default level");
                Assert.True(e.Threads >= 1, "default threads >= 1");
            }
            using (var e = new Engine(3)) {
                Assert.Equal(3, e.Threads, "threads");
            }
            var opt = new EngineOptions { Threads = 2, MaxDepth = 10, CellBias = 2, Cubes = true };
            using (var e = new Engine(opt)) {
                var boxes = Scenes.Uniform(new Rng(7), 500, 100, 8);
                Assert.SamePairs(Scenes.Brute(boxes), e.FindPairs(boxes, FindFlags.Sorted), "pairs with options");
                Assert.True(e.Stats.Depth <= 10, "depth limit honoured (" + e.Stats.Depth + ")");
            }
            string v = Engine.NativeVersion;
            uint packed = Native.locd_version();
            Assert.Equal((packed >> 16) + "." + ((packed >> 8) & 255) + "." + (packed & 255), v, "version string");
        }

        // ------------------------------------------------------------------
        // Equality
        // ------------------------------------------------------------------

        static float[] MakeScene(string kind, Rng r, int n)
        {
            switch (kind) {
            case "uniform": return Scenes.Uniform(r, n, 100, 4 + r.Uniform() * 10);
            case "snapped": return Scenes.Snapped(r, n, 20 + r.Below(40));
            default: return Scenes.Mixed(r, n, r.Below(2) == 0 ? 0 : 1e5);
            }
        }

        static void RandomScenes(string kind)
        {
            var r = new Rng(0xC0FFEE ^ (ulong)kind.GetHashCode());
            int[] sizes = { 2, 3, 17, 100, 500, 1500 };
            using (var e = new Engine()) {
                foreach (int n in sizes)
                    for (int rep = 0; rep < 3; rep++) {
                        var boxes = MakeScene(kind, r, n);
                        var reference = Scenes.Brute(boxes);
                        string what = kind + " n=" + n + " rep=" + rep;
                        Assert.SamePairs(reference, Engine.BruteForce(boxes), what + " C brute force vs C#");
                        Assert.SamePairs(reference, e.FindPairs(boxes, FindFlags.Sorted), what + " engine sorted");
                        Assert.SamePairs(reference, Scenes.Sorted(e.FindPairs(boxes)), what + " engine sweep order");
                        Assert.Equal((long)reference.Length / 2, e.Stats.Pairs, what + " stats.pairs");
                    }
            }
        }

        static void F64FarFromOrigin()
        {
            var r = new Rng(99);
            using (var e = new Engine()) {
                foreach (double offset in new[] { 0.0, 1e9, -1e15, 1e300 }) {
                    var f = Scenes.Uniform(r, 800, 100, 6);
                    var d = new double[f.Length];
                    for (int k = 0; k < f.Length; k++)
                        d[k] = offset + f[k] * (offset == 1e300 ? 1e280 : 1.0);
                    Assert.SamePairs(Scenes.Brute(d), e.FindPairs(d, FindFlags.Sorted), "f64 offset " + offset);
                    Assert.SamePairs(Scenes.Brute(d), Engine.BruteForce(d), "f64 C brute force offset " + offset);
                }
            }
        }

        static void EveryOverloadSamePairs()
        {
            var boxes = Scenes.Snapped(new Rng(5), 700, 30);
            var dboxes = Scenes.ToDouble(boxes);
            var reference = Scenes.Brute(boxes);
            int m = reference.Length / 2;
            using (var e = new Engine()) {
                Assert.SamePairs(reference, Scenes.Sorted(e.FindPairs(boxes)), "float[] -> uint[]");
                Assert.SamePairs(reference, Scenes.Sorted(e.FindPairs(dboxes)), "double[] -> uint[]");
                var buf = new uint[2 * m + 10];
                int got = e.FindPairs(boxes, 700, buf, FindFlags.Sorted);
                Assert.SamePairs(reference, Scenes.Prefix(buf, got), "float[] into caller buffer");
                got = e.FindPairs(dboxes, 700, buf, FindFlags.Sorted);
                Assert.SamePairs(reference, Scenes.Prefix(buf, got), "double[] into caller buffer");
                uint[] grow = null;
                got = e.FindPairs(boxes, 700, ref grow, FindFlags.Sorted);
                Assert.SamePairs(reference, Scenes.Prefix(grow, got), "float[] into growing buffer");
                grow = new uint[2];
                got = e.FindPairs(dboxes, 700, ref grow, FindFlags.Sorted);
                Assert.SamePairs(reference, Scenes.Prefix(grow, got), "double[] into growing buffer");
                // A prefix of the boxes: only pairs among the first 300.
                var sub = new float[300 * 6];
                Array.Copy(boxes, sub, sub.Length);
                got = e.FindPairs(boxes, 300, ref grow, FindFlags.Sorted);
                Assert.SamePairs(Scenes.Brute(sub), Scenes.Prefix(grow, got), "boxCount prefix");
                fixed (float* b = boxes)
                fixed (double* d = dboxes)
                fixed (uint* p = buf) {
                    long c = e.FindPairs(b, 700, p, buf.Length / 2, FindFlags.Sorted);
                    Assert.SamePairs(reference, Scenes.Prefix(buf, (int)c), "float* into uint*");
                    c = e.FindPairs(d, 700, p, buf.Length / 2, FindFlags.Sorted);
                    Assert.SamePairs(reference, Scenes.Prefix(buf, (int)c), "double* into uint*");
                    Assert.SamePairs(reference, e.FindPairs(b, 700, FindFlags.Sorted), "float* -> uint[]");
                    Assert.SamePairs(reference, e.FindPairs(d, 700, FindFlags.Sorted), "double* -> uint[]");
                }
            }
        }

        static void ThreadCountsSameOrder()
        {
            // The contract: the order does not depend on the thread count or the run.
            var boxes = Scenes.Mixed(new Rng(11), 3000, 0);
            uint[] first = null;
            foreach (int t in new[] { 1, 2, 3, 8 })
                using (var e = new Engine(t)) {
                    var p = e.FindPairs(boxes);
                    if (first == null)
                        first = p;
                    Assert.SamePairs(first, p, "sweep order with " + t + " threads");
                    Assert.SamePairs(first, e.FindPairs(boxes), "second run with " + t + " threads");
                }
            Assert.SamePairs(Scenes.Brute(boxes), Scenes.Sorted(first), "pairs");
        }

        static void CliPairsFile()
        {
            string cli = Environment.GetEnvironmentVariable("LOCD_CLI");
            if (string.IsNullOrEmpty(cli) || !File.Exists(cli))
                throw new SkipException("LOCD_CLI not set (the CI step sets it to the built `locd` tool)");
            string dir = Path.Combine(Path.GetTempPath(), "locd-cs-" + Process.GetCurrentProcess().Id);
            Directory.CreateDirectory(dir);
            try {
                var r = new Rng(2024);
                using (var e = new Engine())
                    foreach (string kind in new[] { "uniform", "snapped", "mixed" }) {
                        var boxes = MakeScene(kind, r, 2000);
                        string scene = Path.Combine(dir, kind + ".aabb"), pairs = Path.Combine(dir, kind + ".bin");
                        var bytes = new byte[boxes.Length * 4];
                        Buffer.BlockCopy(boxes, 0, bytes, 0, bytes.Length); // little-endian float32 rows
                        File.WriteAllBytes(scene, bytes);
                        var psi = new ProcessStartInfo(cli, "pairs \"" + scene + "\" --out \"" + pairs + "\"") {
                            UseShellExecute = false, RedirectStandardOutput = true, RedirectStandardError = true,
                        };
                        using (var p = Process.Start(psi)) {
                            string output = p.StandardOutput.ReadToEnd() + p.StandardError.ReadToEnd();
                            p.WaitForExit();
                            Assert.Equal(0, p.ExitCode, "locd pairs exit code (" + output.Trim() + ")");
                        }
                        var raw = File.ReadAllBytes(pairs);
                        var fromCli = new uint[raw.Length / 4];
                        Buffer.BlockCopy(raw, 0, fromCli, 0, raw.Length);
                        Assert.SamePairs(fromCli, e.FindPairs(boxes, FindFlags.Sorted), kind + ": C# vs `locd pairs`");
                        Assert.SamePairs(Scenes.Brute(boxes), fromCli, kind + ": `locd pairs` vs C# brute force");
                    }
            } finally {
                Directory.Delete(dir, true);
            }
        }

        static void ParallelCallers()
        {
            // One engine per thread, and one engine shared by all (calls serialize).
            var errors = new List<string>();
            using (var shared = new Engine()) {
                var threads = new Thread[4];
                for (int t = 0; t < threads.Length; t++) {
                    int seed = t;
                    threads[t] = new Thread(() => {
                        try {
                            var r = new Rng((ulong)(1000 + seed));
                            using (var own = new Engine(1))
                                for (int k = 0; k < 10; k++) {
                                    var boxes = Scenes.Uniform(r, 400, 50, 5);
                                    var reference = Scenes.Brute(boxes);
                                    Assert.SamePairs(reference, own.FindPairs(boxes, FindFlags.Sorted), "own engine");
                                    Assert.SamePairs(reference, shared.FindPairs(boxes, FindFlags.Sorted), "shared engine");
                                }
                        } catch (Exception ex) {
                            lock (errors) errors.Add(ex.Message);
                        }
                    });
                    threads[t].Start();
                }
                foreach (var th in threads)
                    th.Join();
            }
            Assert.True(errors.Count == 0, "parallel callers: " + string.Join("; ", errors.ToArray()));
        }

        // ------------------------------------------------------------------
        // Touching and degenerate boxes
        // ------------------------------------------------------------------

        static float[] Box(float x0, float y0, float z0, float x1, float y1, float z1)
        {
            return new[] { x0, y0, z0, x1, y1, z1 };
        }

        static float[] Concat(params float[][] boxes)
        {
            var all = new List<float>();
            foreach (var b in boxes)
                all.AddRange(b);
            return all.ToArray();
        }

        static bool HasPair(uint[] pairs, uint i, uint j)
        {
            for (int k = 0; k < pairs.Length; k += 2)
                if (pairs[k] == i && pairs[k + 1] == j)
                    return true;
            return false;
        }

        static void TouchingFacesEdgesCorners()
        {
            // Unit cube 0 and neighbours that touch it on a face, an edge, a corner;
            // closed intervals: all of them count (design.md section 2).
            var boxes = Concat(
                Box(0, 0, 0, 1, 1, 1),
                Box(1, 0, 0, 2, 1, 1),        // 1: face
                Box(1, 1, 0, 2, 2, 1),        // 2: edge
                Box(1, 1, 1, 2, 2, 2),        // 3: corner
                Box(-1, -1, -1, 0, 0, 0),     // 4: opposite corner
                Box(0.25f, 0.25f, 1, 0.75f, 0.75f, 1), // 5: flat square lying on the top face
                Box(3, 3, 3, 4, 4, 4));       // 6: apart
            using (var e = new Engine()) {
                var p = e.FindPairs(boxes, FindFlags.Sorted);
                Assert.SamePairs(Scenes.Brute(boxes), p, "touching vs C# reference");
                for (uint k = 1; k <= 5; k++)
                    Assert.True(HasPair(p, 0, k), "box 0 touches box " + k);
                for (uint k = 0; k < 6; k++)
                    Assert.True(!HasPair(p, k, 6), "box 6 is apart from box " + k);
                // A lattice of unit cubes: each touches its 26 neighbours.
                var lattice = new List<float>();
                for (int x = 0; x < 6; x++)
                    for (int y = 0; y < 6; y++)
                        for (int z = 0; z < 6; z++)
                            lattice.AddRange(Box(x, y, z, x + 1, y + 1, z + 1));
                var lb = lattice.ToArray();
                Assert.SamePairs(Scenes.Brute(lb), e.FindPairs(lb, FindFlags.Sorted), "touching lattice");
            }
        }

        static float NextUp(float x)
        {
            int bits = BitConverter.ToInt32(BitConverter.GetBytes(x), 0);
            bits += x >= 0 ? 1 : -1;
            return BitConverter.ToSingle(BitConverter.GetBytes(bits), 0);
        }

        static void OneUlpApart()
        {
            // Pairs of boxes separated by one float step on one axis, at several scales.
            var list = new List<float[]>();
            foreach (float x in new[] { 1f, 1000f, 1e-20f, 3e30f, -7.5f }) {
                float gap = NextUp(x);
                list.Add(Box(x - 1, 0, 0, x, 1, 1));
                list.Add(Box(gap, 0, 0, gap + 1, 1, 1));
            }
            var boxes = Concat(list.ToArray());
            using (var e = new Engine()) {
                var p = e.FindPairs(boxes, FindFlags.Sorted);
                Assert.SamePairs(Scenes.Brute(boxes), p, "one ulp apart vs C# reference");
                for (uint k = 0; k < list.Count; k += 2)
                    Assert.True(!HasPair(p, k, k + 1), "boxes " + k + " and " + (k + 1) + " are one ulp apart");
            }
        }

        static void DegeneratePointsPlanesIdentical()
        {
            using (var e = new Engine()) {
                // 40 identical boxes: every pair overlaps.
                var same = new List<float>();
                for (int k = 0; k < 40; k++)
                    same.AddRange(Box(2, 2, 2, 3, 3, 3));
                var sb = same.ToArray();
                var p = e.FindPairs(sb, FindFlags.Sorted);
                Assert.Equal(40 * 39 / 2, p.Length / 2, "identical boxes give n(n-1)/2 pairs");
                Assert.SamePairs(Scenes.Brute(sb), p, "identical boxes");
                // Points (zero-size boxes): equal points overlap, a point on a face overlaps.
                var pts = Concat(Box(1, 1, 1, 1, 1, 1), Box(1, 1, 1, 1, 1, 1), Box(1, 0.5f, 0.5f, 1, 0.5f, 0.5f),
                                 Box(0, 0, 0, 1, 1, 1), Box(-0f, -0f, -0f, 0, 0, 0), Box(0, 0, 0, -0f, -0f, -0f));
                p = e.FindPairs(pts, FindFlags.Sorted);
                Assert.SamePairs(Scenes.Brute(pts), p, "points");
                Assert.True(HasPair(p, 0, 1) && HasPair(p, 2, 3) && HasPair(p, 4, 5), "equal points, point on face, -0 == 0");
                // Random points and planes snapped to a grid (many exact contacts), and a huge
                // box containing everything.
                var r = new Rng(3);
                var mix = new List<float>();
                for (int k = 0; k < 600; k++) {
                    float x = r.Below(10), y = r.Below(10), z = r.Below(10);
                    int kind = r.Below(3);
                    if (kind == 0) mix.AddRange(Box(x, y, z, x, y, z));
                    else if (kind == 1) mix.AddRange(Box(x, y, z, x + 2, y + 2, z));
                    else mix.AddRange(Box(x, y, z, x, y + 1, z + 3));
                }
                mix.AddRange(Box(-1e30f, -1e30f, -1e30f, 1e30f, 1e30f, 1e30f));
                var mb = mix.ToArray();
                Assert.SamePairs(Scenes.Brute(mb), e.FindPairs(mb, FindFlags.Sorted), "points, planes and a huge box");
            }
        }

        static void EmptyAndSingle()
        {
            using (var e = new Engine()) {
                Assert.Equal(0, e.FindPairs(new float[0]).Length, "n = 0");
                Assert.Equal(0, e.FindPairs(new double[0]).Length, "n = 0 (f64)");
                Assert.Equal(0, e.FindPairs(Box(0, 0, 0, 1, 1, 1)).Length, "n = 1");
                var buf = new uint[0];
                Assert.Equal(0, e.FindPairs(new float[0], 0, buf), "n = 0 into an empty buffer");
                Assert.Equal(0, e.FindPairs(Box(0, 0, 0, 1, 1, 1), 1, ref buf), "n = 1 into a growing buffer");
                uint[] none = null;
                Assert.Equal(0, e.FindPairs(new float[0], 0, ref none), "n = 0 into a null buffer");
                Assert.True(none != null, "a null growing buffer is allocated even with no pairs");
            }
        }

        // ------------------------------------------------------------------
        // Errors
        // ------------------------------------------------------------------

        static void NanAndInfGiveIndex()
        {
            using (var e = new Engine()) {
                var boxes = Scenes.Uniform(new Rng(1), 20, 10, 1);
                var bad = (float[])boxes.Clone();
                bad[6 * 7 + 1] = float.NaN;
                var ex = Assert.Throws<LocdException>(() => e.FindPairs(bad), "NaN");
                Assert.Equal(Status.NonFinite, ex.Status, "NaN status");
                Assert.Equal(7L, ex.BoxIndex, "NaN box index");
                Assert.True(ex.Detail.Length > 0 && ex.Message.Contains("7"), "detail names the box: " + ex.Message);
                bad = (float[])boxes.Clone();
                bad[6 * 3 + 5] = float.PositiveInfinity;
                ex = Assert.Throws<LocdException>(() => e.FindPairs(bad), "+Inf");
                Assert.Equal(Status.NonFinite, ex.Status, "+Inf status");
                Assert.Equal(3L, ex.BoxIndex, "+Inf box index");
                var dbad = Scenes.ToDouble(boxes);
                dbad[6 * 19] = double.NegativeInfinity;
                ex = Assert.Throws<LocdException>(() => e.FindPairs(dbad), "-Inf f64");
                Assert.Equal(Status.NonFinite, ex.Status, "-Inf f64 status");
                Assert.Equal(19L, ex.BoxIndex, "-Inf f64 box index");
                // Nothing half-written: the caller's buffer is untouched on error.
                var buf = new uint[1000];
                for (int k = 0; k < buf.Length; k++)
                    buf[k] = 0xABCDu;
                bad = (float[])boxes.Clone();
                bad[6 * 12] = float.NaN;
                Assert.Throws<LocdException>(() => e.FindPairs(bad, 20, buf), "NaN into buffer");
                foreach (uint v in buf)
                    Assert.Equal(0xABCDu, v, "buffer untouched after an error");
                // The engine keeps working after an error.
                Assert.SamePairs(Scenes.Brute(boxes), e.FindPairs(boxes, FindFlags.Sorted), "after errors");
            }
        }

        static void InvertedBoxFirstBadIndex()
        {
            using (var e = new Engine()) {
                var boxes = Scenes.Uniform(new Rng(2), 30, 10, 1);
                boxes[6 * 9 + 2] = boxes[6 * 9 + 5] + 1; // min z > max z
                var ex = Assert.Throws<LocdException>(() => e.FindPairs(boxes), "inverted box");
                Assert.Equal(Status.InvertedBox, ex.Status, "inverted status");
                Assert.Equal(9L, ex.BoxIndex, "inverted box index");
                boxes[6 * 21] = float.NaN;                // a later bad box does not hide the first
                ex = Assert.Throws<LocdException>(() => e.FindPairs(boxes), "two bad boxes");
                Assert.Equal(9L, ex.BoxIndex, "first bad index wins");
                // locd_brute_force reports through the same path.
                ex = Assert.Throws<LocdException>(() => Engine.BruteForce(boxes), "brute force");
                Assert.Equal(9L, ex.BoxIndex, "brute force bad index");
            }
        }

        static void BadOptions()
        {
            var cases = new Dictionary<string, EngineOptions> {
                { "threads 65", new EngineOptions { Threads = 65 } },
                { "cell bias 9", new EngineOptions { CellBias = 9 } },
                { "cell bias -1", new EngineOptions { CellBias = -1 } },
                { "max depth 22", new EngineOptions { MaxDepth = 22 } },
                { "level 7", new EngineOptions { Level = (Level)7 } },
                { "service without address", new EngineOptions { Level = Level.Service } },
            };
            long live = EngineSafeHandle.Live;
            foreach (var kv in cases) {
                var ex = Assert.Throws<LocdException>(() => new Engine(kv.Value).Dispose(), kv.Key);
                Assert.Equal(Status.InvalidArgument, ex.Status, kv.Key + " status");
                Assert.True(ex.Detail.Length > 0, kv.Key + " has a detail message");
                Assert.Equal(-1L, ex.BoxIndex, kv.Key + " has no box index");
            }
            Assert.Throws<ArgumentOutOfRangeException>(() => new Engine(-1), "negative threads");
            Assert.Equal(live, EngineSafeHandle.Live, "failed constructors leave no engine");
        }

        static void ManagedArgumentChecks()
        {
            using (var e = new Engine()) {
                Assert.Throws<ArgumentException>(() => e.FindPairs(new float[7]), "length not a multiple of 6");
                Assert.Throws<ArgumentNullException>(() => e.FindPairs((float[])null), "null boxes");
                Assert.Throws<ArgumentOutOfRangeException>(() => e.FindPairs(new float[12], 3, new uint[4]), "boxCount too large");
                Assert.Throws<ArgumentOutOfRangeException>(() => e.FindPairs(new float[12], -1, new uint[4]), "negative boxCount");
                var two = Concat(Box(0, 0, 0, 1, 1, 1), Box(1, 1, 1, 2, 2, 2));
                Assert.Equal(1, e.FindPairs(two, 2, new uint[2]), "one pair");
                Assert.Throws<ArgumentException>(() => e.CopyLastPairs(new uint[1]), "CopyLastPairs into too small an array");
            }
        }

        static void BufferTooSmall()
        {
            var boxes = Scenes.Uniform(new Rng(8), 400, 30, 6);
            var reference = Scenes.Brute(boxes);
            int m = reference.Length / 2;
            Assert.True(m > 10, "scene has pairs");
            using (var e = new Engine()) {
                var small = new uint[2 * (m - 1)];
                for (int k = 0; k < small.Length; k++)
                    small[k] = 7;
                var ex = Assert.Throws<LocdException>(() => e.FindPairs(boxes, 400, small, FindFlags.Sorted), "one too small");
                Assert.Equal(Status.BufferTooSmall, ex.Status, "status");
                Assert.Equal((long)m, ex.RequiredPairs, "required pairs");
                foreach (uint v in small)
                    Assert.Equal(7u, v, "nothing copied into a too small buffer");
                var all = new uint[2 * m];
                Assert.Equal(m, e.CopyLastPairs(all), "CopyLastPairs count");
                Assert.SamePairs(reference, all, "CopyLastPairs gives the pairs");
                // Exactly enough fits.
                Assert.Equal(m, e.FindPairs(boxes, 400, all, FindFlags.Sorted), "exact capacity");
                Assert.SamePairs(reference, all, "exact capacity pairs");
            }
        }

        static void DetailIsPerThread()
        {
            // locd_last_error is thread-local: an error on another thread does not
            // overwrite this thread's detail, and each exception names its own box.
            using (var e1 = new Engine(1))
            using (var e2 = new Engine(1)) {
                var a = Scenes.Uniform(new Rng(4), 50, 10, 1);
                var b = (float[])a.Clone();
                a[6 * 11] = float.NaN;
                b[6 * 33 + 4] = float.NaN;
                LocdException exA = null, exB = null;
                var t = new Thread(() => {
                    for (int k = 0; k < 200; k++)
                        try { e2.FindPairs(b); } catch (LocdException x) { exB = x; }
                });
                t.Start();
                for (int k = 0; k < 200; k++)
                    try { e1.FindPairs(a); } catch (LocdException x) { exA = x; }
                t.Join();
                Assert.True(exA != null && exB != null, "both threads failed");
                Assert.Equal(11L, exA.BoxIndex, "this thread's index");
                Assert.Equal(33L, exB.BoxIndex, "other thread's index");
            }
        }

        static void StatsAfterFind()
        {
            var boxes = Scenes.Uniform(new Rng(6), 2000, 100, 5);
            using (var e = new Engine(2)) {
                var p = e.FindPairs(boxes);
                var s = e.Stats;
                Assert.Equal(2000L, s.Objects, "objects");
                Assert.Equal((long)p.Length / 2, s.Pairs, "pairs");
                Assert.True(s.Entries >= 2000 && s.Entries <= 8 * 2000, "entries " + s.Entries + " in n..8n");
                Assert.True(s.Candidates >= s.Pairs, "candidates >= pairs");
                Assert.True(s.Threads >= 1 && s.Threads <= 2, "threads " + s.Threads);
                Assert.True(s.MsTotal > 0 && s.MsTotal < 60000, "ms_total " + s.MsTotal);
                Assert.True(s.MsSweep >= 0 && s.MsSweep <= s.MsTotal, "ms_sweep within ms_total");
            }
        }

        // ------------------------------------------------------------------
        // Lifetime
        // ------------------------------------------------------------------

        static void DisposeTwiceAndUseAfter()
        {
            long live = EngineSafeHandle.Live;
            var e = new Engine();
            var boxes = Scenes.Uniform(new Rng(1), 10, 10, 3);
            e.FindPairs(boxes);
            Assert.Equal(live + 1, EngineSafeHandle.Live, "one live engine");
            e.Dispose();
            e.Dispose();
            Assert.True(e.IsDisposed, "IsDisposed");
            Assert.Equal(live, EngineSafeHandle.Live, "destroyed by Dispose");
            Assert.Throws<ObjectDisposedException>(() => e.FindPairs(boxes), "FindPairs after Dispose");
            Assert.Throws<ObjectDisposedException>(() => e.FindPairs(boxes, 10, new uint[100]), "buffer FindPairs after Dispose");
            Assert.Throws<ObjectDisposedException>(() => { var s = e.Stats; }, "Stats after Dispose");
            Assert.Throws<ObjectDisposedException>(() => e.Submit(boxes), "Submit after Dispose");
        }

        [MethodImpl(MethodImplOptions.NoInlining)]
        static void AbandonEngines(int count, float[] boxes)
        {
            for (int k = 0; k < count; k++) {
                var e = new Engine(2);
                e.FindPairs(boxes); // allocates the engine's pairs buffers too
            }
        }

        static void FinalizerReleasesNative()
        {
            var boxes = Scenes.Uniform(new Rng(1), 500, 30, 3);
            var before = ProcessProbe.Read();
            long live = EngineSafeHandle.Live;
            AbandonEngines(100, boxes);
            Assert.True(EngineSafeHandle.Live >= live + 1, "abandoned engines are still alive before a GC");
            var during = new Probe { Threads = Process.GetCurrentProcess().Threads.Count };
            for (int k = 0; k < 3 && EngineSafeHandle.Live != live; k++) {
                GC.Collect();
                GC.WaitForPendingFinalizers();
            }
            var after = ProcessProbe.Read();
            Console.WriteLine("         finalizers: before {0}; after {1}; threads while abandoned {2}", before, after, during.Threads);
            Assert.Equal(live, EngineSafeHandle.Live, "every abandoned engine was finalized");
            if (ProcessProbe.OnLinux) {
                // Each 2-thread engine owns a pool thread: they must all be joined again.
                Assert.True(after.Threads <= before.Threads, "threads back to " + before.Threads + " (now " + after.Threads + ")");
                if (before.MallocBytes >= 0)
                    // (mono mallocs a little itself; 100 leaked engines with their buffers are megabytes)
                    Assert.True(after.MallocBytes - before.MallocBytes < 512 * 1024,
                                "native heap back near its start (grew " + (after.MallocBytes - before.MallocBytes) + " B)");
            }
        }

        static void CreateDestroyNoGrowth()
        {
            if (!ProcessProbe.OnLinux)
                throw new SkipException("needs /proc (Linux)");
            var boxes = Scenes.Uniform(new Rng(1), 64, 10, 2);
            var buf = new uint[4096];
            Action cycle = () => {
                using (var e = new Engine()) // default: one thread per core, pool threads started and joined
                    e.FindPairs(boxes, 64, buf);
            };
            for (int k = 0; k < 500; k++) // warm-up: JIT, malloc arenas, thread stacks cached by glibc
                cycle();
            var before = ProcessProbe.Read();
            var sw = Stopwatch.StartNew();
            for (int k = 0; k < 10000; k++)
                cycle();
            double secs = sw.Elapsed.TotalSeconds;
            var after = ProcessProbe.Read();
            Console.WriteLine("         10,000 cycles in {0:F2}s: before {1}; after {2}", secs, before, after);
            Assert.Equal(before.Threads, after.Threads, "threads");
            Assert.Equal(before.Fds, after.Fds, "file descriptors");
            if (before.MallocBytes >= 0)
                // An engine is several hundred bytes: leaking one per cycle would be > 2 MB.
                Assert.True(after.MallocBytes - before.MallocBytes < 64 * 1024,
                            "malloc in-use grew " + (after.MallocBytes - before.MallocBytes) + " B over 10,000 cycles");
            Assert.True(after.RssKb - before.RssKb < 4096, "RSS grew " + (after.RssKb - before.RssKb) + " KiB over 10,000 cycles");
        }

        static void ReusedBufferNoAllocation()
        {
            // The per-frame pattern: one engine, one buffer, boxes updated in place.
            var r = new Rng(12);
            var boxes = Scenes.Uniform(r, 2000, 60, 3);
            uint[] buf = null;
            using (var e = new Engine()) {
                e.FindPairs(boxes, 2000, ref buf);
                var first = buf;
                long before = GC.GetTotalMemory(true);
                int gen0 = GC.CollectionCount(0);
                for (int frame = 0; frame < 200; frame++) {
                    for (int k = 0; k < boxes.Length; k += 6) { // jitter a little, keep the pair count similar
                        float dx = (float)(r.Uniform() - 0.5) * 0.01f;
                        boxes[k] += dx;
                        boxes[k + 3] += dx;
                    }
                    e.FindPairs(boxes, 2000, ref buf);
                }
                long after = GC.GetTotalMemory(false);
                Console.WriteLine("         200 frames: managed heap {0} -> {1} B, gen0 collections {2}", before, after,
                                  GC.CollectionCount(0) - gen0);
                Assert.True(after - before < 16 * 1024, "managed allocation over 200 frames: " + (after - before) + " B");
                int m = e.FindPairs(boxes, 2000, ref buf, FindFlags.Sorted);
                Assert.SamePairs(Scenes.Brute(boxes), Scenes.Prefix(buf, m), "pairs after 200 frames");
                Assert.True(first == buf || buf.Length > first.Length, "buffer replaced only to grow");
            }
        }

        // ------------------------------------------------------------------
        // Jobs
        // ------------------------------------------------------------------

        // Submits, or reports the test as skipped while the build has no jobs.
        static Job SubmitOrSkip(Engine e, float[] boxes, FindFlags flags)
        {
            try {
                return e.Submit(boxes, flags);
            } catch (LocdException ex) {
                if (ex.Status == Status.Unsupported)
                    throw new SkipException("jobs unsupported by this native build: " + ex.Message);
                throw;
            }
        }

        static void JobResultEqualsFind()
        {
            var r = new Rng(21);
            using (var e = new Engine()) {
                foreach (int n in new[] { 0, 1, 300, 5000 }) {
                    var boxes = Scenes.Mixed(r, n, 0);
                    uint[] direct = e.FindPairs(boxes);
                    using (var job = SubmitOrSkip(e, boxes, FindFlags.None)) {
                        Assert.True(job.Wait(60000), "job finished within 60 s (n=" + n + ")");
                        Assert.True(job.IsDone, "IsDone after Wait");
                        Assert.SamePairs(direct, job.Result, "job result, same deterministic order (n=" + n + ")");
                        Assert.True(ReferenceEquals(job.Result, job.Result), "Result is cached");
                        Assert.Equal((long)n, job.Stats.Objects, "job stats objects");
                    }
                    using (var job = e.Submit(Scenes.ToDouble(boxes), FindFlags.Sorted)) {
                        job.Wait();
                        Assert.SamePairs(Scenes.Brute(boxes), job.Result, "f64 sorted job (n=" + n + ")");
                    }
                }
                // The caller may overwrite its array right after Submit: the job copied it.
                var b2 = Scenes.Uniform(r, 3000, 80, 4);
                var expect = Scenes.Brute(b2);
                using (var job = e.Submit(b2, FindFlags.Sorted)) {
                    for (int k = 0; k < b2.Length; k++)
                        b2[k] = 0;
                    Assert.SamePairs(expect, job.Result, "job copied the boxes at submit");
                }
            }
        }

        static void JobPollingAndTimeout()
        {
            var boxes = Scenes.Uniform(new Rng(22), 200000, 1000, 5);
            using (var e = new Engine()) {
                using (var job = SubmitOrSkip(e, boxes, FindFlags.None)) {
                    bool early = job.Wait(0); // may or may not be finished; must not throw
                    var sw = Stopwatch.StartNew();
                    int polls = 0;
                    while (!job.IsDone) {
                        polls++;
                        Assert.True(sw.Elapsed.TotalSeconds < 60, "job done within 60 s");
                        Thread.Sleep(1);
                    }
                    Console.WriteLine("         Wait(0) -> {0}; {1} polls until IsDone", early, polls);
                    Assert.True(job.Wait(0), "Wait(0) true once done");
                    Assert.Equal(e.FindPairs(boxes).Length, job.Result.Length, "same pair count as FindPairs");
                }
                // Releasing a running job cancels it; the engine stays usable.
                var j2 = e.Submit(boxes);
                j2.Dispose();
                var small = Scenes.Uniform(new Rng(1), 100, 10, 2);
                uint[] got = null;
                var sw2 = Stopwatch.StartNew();
                while (true) {
                    try {
                        got = e.FindPairs(small, FindFlags.Sorted);
                        break;
                    } catch (LocdException ex) {
                        // A released job may take a moment to stop.
                        if (ex.Status != Status.Busy || sw2.Elapsed.TotalSeconds > 30)
                            throw;
                        Thread.Sleep(5);
                    }
                }
                Assert.SamePairs(Scenes.Brute(small), got, "engine usable after releasing a running job");
            }
        }

        static void JobErrorMapping()
        {
            var boxes = Scenes.Uniform(new Rng(23), 100, 10, 2);
            boxes[6 * 42 + 3] = float.NaN;
            using (var e = new Engine()) {
                LocdException ex = null;
                try {
                    using (var job = SubmitOrSkip(e, boxes, FindFlags.None)) {
                        // The error may come at submit (validated there) or from the job.
                        ex = Assert.Throws<LocdException>(() => job.Wait(60000), "job with a NaN box");
                        Assert.True(job.IsDone, "a failed job is done");
                        Assert.Throws<LocdException>(() => { var r = job.Result; }, "Result of a failed job");
                    }
                } catch (LocdException submitError) {
                    ex = submitError;
                }
                Assert.Equal(Status.NonFinite, ex.Status, "job error status");
                Assert.Equal(42L, ex.BoxIndex, "job error box index");
            }
        }

        [MethodImpl(MethodImplOptions.NoInlining)]
        static Job SubmitOnAbandonedEngine(float[] boxes, out long liveDuring)
        {
            var e = new Engine();
            var job = SubmitOrSkip(e, boxes, FindFlags.Sorted);
            e.Dispose(); // the job holds a reference: the native engine must outlive it
            liveDuring = EngineSafeHandle.Live;
            return job;
        }

        static void JobKeepsEngineAlive()
        {
            var boxes = Scenes.Uniform(new Rng(24), 20000, 200, 4);
            long engines = EngineSafeHandle.Live, jobs = JobSafeHandle.Live, during;
            var job = SubmitOnAbandonedEngine(boxes, out during);
            Assert.Equal(engines + 1, during, "engine kept alive by its job after Dispose");
            Assert.Equal(Scenes.Brute(boxes).Length, job.Result.Length, "job result after its engine's Dispose");
            job.Dispose();
            Assert.Equal(engines, EngineSafeHandle.Live, "engine destroyed with its last job");
            Assert.Equal(jobs, JobSafeHandle.Live, "job released");
            // Abandoned jobs (and their engines) are finalized too.
            AbandonJobs(boxes);
            for (int k = 0; k < 3 && (JobSafeHandle.Live != jobs || EngineSafeHandle.Live != engines); k++) {
                GC.Collect();
                GC.WaitForPendingFinalizers();
            }
            Assert.Equal(jobs, JobSafeHandle.Live, "abandoned jobs finalized");
            Assert.Equal(engines, EngineSafeHandle.Live, "their engines finalized after them");
        }

        [MethodImpl(MethodImplOptions.NoInlining)]
        static void AbandonJobs(float[] boxes)
        {
            for (int k = 0; k < 20; k++) {
                var e = new Engine(1);
                SubmitOrSkip(e, boxes, FindFlags.None);
            }
        }
    }
}
