// The two-set query (Engine.FindPairsBetween) against a C# bipartite brute force.
using System;
using System.Collections.Generic;

namespace Locd.Tests
{
    public static class Between
    {
        // Every (i in a, j in b) whose closed boxes overlap, sorted by (i, j).
        static uint[] Brute(double[] a, double[] b)
        {
            var result = new List<uint>();
            for (int i = 0; i < a.Length / 6; i++)
                for (int j = 0; j < b.Length / 6; j++) {
                    bool hit = true;
                    for (int x = 0; x < 3 && hit; x++)
                        hit = a[6 * i + x] <= b[6 * j + 3 + x] && b[6 * j + x] <= a[6 * i + 3 + x];
                    if (hit) {
                        result.Add((uint)i);
                        result.Add((uint)j);
                    }
                }
            return result.ToArray();
        }

        public static void RandomSetsMatchBruteForce()
        {
            var r = new Rng(77);
            int[][] sizes = { new[] { 1, 1 }, new[] { 3, 500 }, new[] { 2500, 3000 } };
            foreach (var s in sizes)
                foreach (int threads in new[] { 1, 2 })
                    using (var e = new Engine(new EngineOptions { Threads = threads })) {
                        float[] a = Scenes.Snapped(r, s[0], 12), b = Scenes.Uniform(r, s[1], 10, 1);
                        double[] da = Scenes.ToDouble(a), db = Scenes.ToDouble(b);
                        uint[] expect = Brute(da, db);
                        string what = "na " + s[0] + " nb " + s[1] + " threads " + threads;
                        Assert.SamePairs(expect, e.FindPairsBetween(a, b, FindFlags.Sorted), what + " f32 sorted");
                        Assert.SamePairs(expect, Scenes.Sorted(e.FindPairsBetween(a, b)), what + " f32");
                        Assert.SamePairs(expect, e.FindPairsBetween(da, db, FindFlags.Sorted), what + " f64 sorted");
                    }
        }

        public static void EmptySetsAndBadBoxIndex()
        {
            using (var e = new Engine()) {
                float[] a = Scenes.Uniform(new Rng(3), 40, 2, 1), none = new float[0];
                Assert.Equal(0, e.FindPairsBetween(a, none).Length, "b empty");
                Assert.Equal(0, e.FindPairsBetween(none, a).Length, "a empty");
                var same = e.FindPairsBetween(a, a, FindFlags.Sorted);
                for (int i = 0; i < 40; i++)
                    Assert.True(Array.IndexOf(Scenes.Keys(same), ((ulong)i << 32) | (uint)i) >= 0,
                                "box " + i + " meets its twin");
                float[] bad = (float[])a.Clone();
                bad[6 * 5 + 1] = float.NaN;
                var ex = Assert.Throws<LocdException>(() => e.FindPairsBetween(a, bad), "NaN in b");
                Assert.Equal(Status.NonFinite, ex.Status, "status");
                Assert.Equal(40L + 5, ex.BoxIndex, "index of b's box 5 is na + 5");
                Assert.Throws<ArgumentException>(() => e.FindPairsBetween(new float[5], a), "not 6 values a box");
            }
        }
    }
}
