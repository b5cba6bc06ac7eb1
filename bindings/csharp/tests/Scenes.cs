// Scene generators and an independent O(n^2) reference written in C#.
using System;
using System.Collections.Generic;

namespace Locd.Tests
{
    /// <summary>splitmix64: deterministic across runtimes.</summary>
    public sealed class Rng
    {
        ulong s;

        public Rng(ulong seed) { s = seed; }

        public ulong Next()
        {
            ulong z = (s += 0x9E3779B97F4A7C15UL);
            z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9UL;
            z = (z ^ (z >> 27)) * 0x94D049BB133111EBUL;
            return z ^ (z >> 31);
        }

        /// <summary>[0, 1)</summary>
        public double Uniform() { return (Next() >> 11) * (1.0 / 9007199254740992.0); }

        public int Below(int n) { return (int)(Next() % (ulong)n); }
    }

    public static class Scenes
    {
        /// <summary>n boxes in [0, side]^3 with edges in [0, maxEdge).</summary>
        public static float[] Uniform(Rng r, int n, double side, double maxEdge)
        {
            var b = new float[6 * n];
            for (int i = 0; i < n; i++)
                for (int a = 0; a < 3; a++) {
                    double lo = r.Uniform() * side;
                    b[6 * i + a] = (float)lo;
                    b[6 * i + 3 + a] = (float)(lo + r.Uniform() * maxEdge);
                }
            return b;
        }

        /// <summary>Boxes whose corners lie on a coarse grid, so many of them
        /// touch exactly on faces, edges and corners; some have zero size.</summary>
        public static float[] Snapped(Rng r, int n, int cells)
        {
            var b = new float[6 * n];
            for (int i = 0; i < n; i++)
                for (int a = 0; a < 3; a++) {
                    int lo = r.Below(cells);
                    int len = r.Below(3); // 0, 1 or 2 cells: zero-size boxes included
                    b[6 * i + a] = lo * 0.5f;
                    b[6 * i + 3 + a] = (lo + len) * 0.5f;
                }
            return b;
        }

        /// <summary>Clusters of boxes of very different sizes, far from the origin.</summary>
        public static float[] Mixed(Rng r, int n, double offset)
        {
            var b = new float[6 * n];
            for (int i = 0; i < n; i++) {
                double edge = Math.Pow(10, -3 + 5 * r.Uniform()); // 0.001 .. 100
                int cluster = r.Below(4);
                for (int a = 0; a < 3; a++) {
                    double c = offset + cluster * 50 + (r.Uniform() - 0.5) * 60;
                    b[6 * i + a] = (float)(c - edge / 2);
                    b[6 * i + 3 + a] = (float)(c + edge / 2);
                }
            }
            return b;
        }

        public static double[] ToDouble(float[] f)
        {
            var d = new double[f.Length];
            for (int k = 0; k < f.Length; k++)
                d[k] = f[k];
            return d;
        }

        /// <summary>Every pair i &lt; j with closed-interval overlap on all axes, sorted by (i, j).</summary>
        public static uint[] Brute(float[] b)
        {
            var d = ToDouble(b); // float -> double is exact: same comparisons
            return Brute(d);
        }

        public static uint[] Brute(double[] b)
        {
            int n = b.Length / 6;
            var result = new List<uint>();
            for (int i = 0; i < n; i++)
                for (int j = i + 1; j < n; j++) {
                    bool hit = true;
                    for (int a = 0; a < 3 && hit; a++)
                        hit = b[6 * i + a] <= b[6 * j + 3 + a] && b[6 * j + a] <= b[6 * i + 3 + a];
                    if (hit) {
                        result.Add((uint)i);
                        result.Add((uint)j);
                    }
                }
            return result.ToArray();
        }

        public static ulong[] Keys(uint[] pairs)
        {
            var k = new ulong[pairs.Length / 2];
            for (int p = 0; p < k.Length; p++)
                k[p] = ((ulong)pairs[2 * p] << 32) | pairs[2 * p + 1];
            return k;
        }

        /// <summary>The pairs sorted by (i, j) (a copy).</summary>
        public static uint[] Sorted(uint[] pairs)
        {
            var k = Keys(pairs);
            Array.Sort(k);
            var s = new uint[pairs.Length];
            for (int p = 0; p < k.Length; p++) {
                s[2 * p] = (uint)(k[p] >> 32);
                s[2 * p + 1] = (uint)k[p];
            }
            return s;
        }

        /// <summary>The first `count` pairs of a buffer.</summary>
        public static uint[] Prefix(uint[] buffer, int count)
        {
            var s = new uint[2 * count];
            Array.Copy(buffer, s, 2 * count);
            return s;
        }
    }
}
