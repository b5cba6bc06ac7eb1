// Tests of the scene's queries (SceneQueries.cs over scene.h): every kind (box, point, sphere, ray,
// swept box) and hit mode (all, closest, any) against a brute force written here in C# with the
// documented float64 tests, on random scenes in every state (before the first update, after updates,
// between a move and its update, after removals, after filter and user-value changes, after adds);
// batches (array and pointer forms) against the same queries one by one, on scenes of 1, 2 and 3
// threads; hand-checked hard cases and a lattice of touching boxes; bad input (the exception names the
// query, nothing changes); the reject callback; the hits buffer; no allocation per frame.
using System;
using System.Collections.Generic;
using System.Linq;
using System.Runtime.InteropServices;
using System.Threading;

namespace Locd.Tests
{
    public static unsafe class SceneQueryTests
    {
        public static void Register(Harness h)
        {
            h.Add("queries.filter_layout_and_defaults", FilterDefaults);
            h.Add("queries.random_scenes_every_state_f32", () => RandomScenes(false));
            h.Add("queries.random_scenes_every_state_f64", () => RandomScenes(true));
            h.Add("queries.batches_equal_one_by_one_threads_1_2_3", BatchesEqualOneByOne);
            h.Add("queries.hard_cases_hand_checked", HardCasesHandChecked);
            h.Add("queries.hard_cases_lattice_faces_edges_corners", HardCasesLattice);
            h.Add("queries.grazing_rays_through_edges", GrazingRays);
            h.Add("queries.extreme_magnitudes", ExtremeMagnitudes);
            h.Add("queries.entry_time_overflow_closest_and_any_report_it", EntryTimeOverflow);
            h.Add("queries.sphere_radius_square_overflows_meets_everything", () => Child.Expect("sphere_radius_square_overflows"));
            h.Add("queries.bad_single_queries_throw_and_change_nothing", BadSingleQueries);
            h.Add("queries.bad_batches_name_the_query_and_change_nothing", BadBatches);
            h.Add("queries.managed_argument_checks", ManagedArgumentChecks);
            h.Add("queries.reject_callback", RejectCallback);
            h.Add("queries.hits_buffer_lifecycle", HitsLifecycle);
            h.Add("queries.prepare_queries", PrepareQueries);
            h.Add("queries.batch_pointer_form_no_allocation", NoAllocation);
        }

        // ------------------------------------------------------------------
        // The model and its brute force: scene.h's float64 tests, written again
        // ------------------------------------------------------------------

        enum Kind { Box, Point, Sphere, Ray, Sweep }

        sealed class Query
        {
            public Kind Kind;
            public double[] V;                    // a box (6 values), or a point, center or origin (3)
            public double[] D = new double[3];    // casts: the direction
            public double Num;                    // the radius, or max_t

            public override string ToString()
            {
                return Kind + " v=(" + string.Join(", ", V.Select(x => x.ToString("R"))) + ") d=("
                       + string.Join(", ", D.Select(x => x.ToString("R"))) + ") num=" + Num.ToString("R");
            }
        }

        struct Hit
        {
            public double T;
            public ulong Id;

            public override string ToString() { return "(" + T.ToString("R") + ", " + Id + ")"; }
        }

        sealed class Obj
        {
            public double[] Box;
            public ulong Category = 1, User;
        }

        sealed class Model
        {
            public readonly SortedDictionary<ulong, Obj> Objects = new SortedDictionary<ulong, Obj>();

            /// <summary>Every hit of q: category passes mask, not rejected (odd user value when
            /// rejectOdd), sorted by (t, id); t 0 for the overlaps.</summary>
            public List<Hit> Brute(Query q, ulong mask, bool rejectOdd)
            {
                var hits = new List<Hit>();
                double[] hi = q.Kind == Kind.Box || q.Kind == Kind.Sweep ? q.V.Skip(3).ToArray() : q.V;
                foreach (var kv in Objects) {
                    Obj o = kv.Value;
                    if ((o.Category & mask) == 0 || (rejectOdd && (o.User & 1) != 0))
                        continue;
                    double t = 0;
                    bool met;
                    switch (q.Kind) {
                    case Kind.Box: met = BoxMeets(q.V, hi, o.Box); break;
                    case Kind.Point: met = BoxMeets(q.V, q.V, o.Box); break;
                    case Kind.Sphere: met = SphereMeets(q.V, q.Num, o.Box); break;
                    case Kind.Ray: met = CastMeets(q.V, q.V, q.D, q.Num, o.Box, out t); break;
                    default: met = CastMeets(q.V, hi, q.D, q.Num, o.Box, out t); break;
                    }
                    if (met)
                        hits.Add(new Hit { T = t, Id = kv.Key });
                }
                hits.Sort(ByTThenId);
                return hits;
            }
        }

        static int ByTThenId(Hit a, Hit b)
        {
            if (a.T != b.T)
                return a.T < b.T ? -1 : 1;
            return a.Id.CompareTo(b.Id);
        }

        // Closed intervals: the query box [lo, hi] and the object's box b.
        static bool BoxMeets(double[] lo, double[] hi, double[] b)
        {
            for (int a = 0; a < 3; a++)
                if (!(b[a] <= hi[a] && lo[a] <= b[3 + a]))
                    return false;
            return true;
        }

        static double Gap(double c, double lo, double hi)
        {
            return c < lo ? lo - c : c > hi ? c - hi : 0.0;
        }

        // (dx*dx + dy*dy) + dz*dz <= r*r, in float64 (scene.h).
        static bool SphereMeets(double[] c, double r, double[] b)
        {
            double dx = Gap(c[0], b[0], b[3]), dy = Gap(c[1], b[1], b[4]), dz = Gap(c[2], b[2], b[5]);
            return (dx * dx + dy * dy) + dz * dz <= r * r;
        }

        // The box [lo, hi] moved by t * d, 0 <= t <= maxT, meets b: per axis it overlaps b while
        // b.lo - hi <= t d <= b.hi - lo; the entry time is the largest entry over the axes (0 when
        // they touch at the start).
        static bool CastMeets(double[] lo, double[] hi, double[] d, double maxT, double[] b, out double t)
        {
            double t0 = 0.0, t1 = maxT;
            t = 0;
            for (int a = 0; a < 3; a++) {
                double enter = b[a] - hi[a], leave = b[3 + a] - lo[a];
                if (d[a] == 0.0) {
                    if (enter > 0.0 || leave < 0.0)
                        return false;
                    continue;
                }
                double u = (d[a] > 0.0 ? enter : leave) / d[a], v = (d[a] > 0.0 ? leave : enter) / d[a];
                t0 = u > t0 ? u : t0;
                t1 = v < t1 ? v : t1;
                if (t0 > t1)
                    return false;
            }
            t = t0;
            return true;
        }

        // The reject callback of the tests: objects whose user value is odd. A static field keeps the
        // delegate (and the function pointer the library holds during a call) alive.
        static readonly Native.locd_query_reject_fn RejectOdd = (user, id, value) => (int)(value & 1);

        // ------------------------------------------------------------------
        // The scene's answers
        // ------------------------------------------------------------------

        /// <summary>q on the scene through the single-query calls (box and point: the mask-only
        /// QueryBox/QueryPoint, so no reject).</summary>
        static Hit[] Ask(Scene s, Query q, HitMode mode, ulong mask, bool reject)
        {
            double[] t = null;
            ulong[] ids;
            Native.locd_query_reject_fn fn = reject ? RejectOdd : null;
            switch (q.Kind) {
            case Kind.Box:
                Assert.True(!reject, "no reject for a single box query");
                ids = s.QueryBox(q.V, mask);
                break;
            case Kind.Point:
                Assert.True(!reject, "no reject for a single point query");
                ids = s.QueryPoint(q.V, mask);
                break;
            case Kind.Sphere:
                ids = s.QuerySphere(q.V, q.Num, mask, fn);
                break;
            case Kind.Ray:
                ids = s.CastRay(q.V, q.D, q.Num, mode, out t, mask, fn);
                break;
            default:
                ids = s.SweepBox(q.V, q.D, q.Num, mode, out t, mask, fn);
                break;
            }
            if (t != null)
                Assert.Equal(ids.Length, t.Length, "one t per hit");
            var hits = new Hit[ids.Length];
            for (int k = 0; k < ids.Length; k++)
                hits[k] = new Hit { Id = ids[k], T = t != null && q.Kind >= Kind.Ray ? t[k] : 0 };
            return hits;
        }

        static void SameHits(IList<Hit> expected, IList<Hit> actual, string what)
        {
            if (expected.Count != actual.Count)
                throw new Exception(what + ": expected " + expected.Count + " hits, got " + actual.Count + " ["
                                    + string.Join(" ", expected.Take(8)) + "] vs [" + string.Join(" ", actual.Take(8)) + "]");
            for (int k = 0; k < expected.Count; k++)
                if (expected[k].Id != actual[k].Id || expected[k].T != actual[k].T)
                    throw new Exception(what + ": hit " + k + " is " + actual[k] + ", expected " + expected[k]);
        }

        /// <summary>q on the scene in every mode against the brute force: all (casts: by (t, id) and
        /// t to the bit; overlaps: ids ascending), closest = the first of all, any = one of all.</summary>
        static void CheckQuery(Scene s, Model m, Query q, ulong mask, bool reject, string at)
        {
            if (q.Kind == Kind.Box || q.Kind == Kind.Point)
                reject = false;
            at += " " + q + " mask=" + mask + (reject ? " reject" : "");
            List<Hit> want = m.Brute(q, mask, reject);
            Hit[] all = Ask(s, q, HitMode.All, mask, reject);
            SameHits(want, all, at + " all");
            if (q.Kind < Kind.Ray)
                return;
            Hit[] closest = Ask(s, q, HitMode.Closest, mask, reject);
            Assert.Equal(Math.Min(1, want.Count), closest.Length, at + " closest: hits");
            if (closest.Length == 1)
                SameHits(new[] { all[0] }, closest, at + " closest is the first of all");
            Hit[] any = Ask(s, q, HitMode.Any, mask, reject);
            Assert.Equal(Math.Min(1, want.Count), any.Length, at + " any: hits");
            if (any.Length == 1)
                Assert.True(want.Any(h => h.Id == any[0].Id && h.T == any[0].T), at + " any " + any[0] + " is one of all");
        }

        // ------------------------------------------------------------------
        // Random scenes and queries
        // ------------------------------------------------------------------

        static readonly ulong[] Categories = { 1, 2, 4, 3, 1, 2, 0 };
        static readonly ulong[] Masks = { Scene.AllCategories, Scene.AllCategories, 1, 6, 2 | 8, 0 };

        static double Coord(Rng r, double scale, bool floats)
        {
            double v = r.Below(3) == 0 ? (r.Below(17) - 8) * 0.5 * scale : (r.Uniform() * 10 - 5) * scale;
            return floats ? (float)v : v;
        }

        // A box: on a half-unit grid (touching faces, edges and corners; zero-size on some axes), or
        // anywhere with edges up to 1.5, or now and then a large one.
        static double[] RandomBox(Rng r, double scale, bool floats)
        {
            var b = new double[6];
            int type = r.Below(50) == 0 ? 2 : r.Below(2);
            for (int a = 0; a < 3; a++) {
                if (type == 0) {
                    b[a] = (r.Below(17) - 8) * 0.5 * scale;
                    b[3 + a] = b[a] + r.Below(3) * 0.5 * scale;
                } else {
                    b[a] = (r.Uniform() * 10 - 5) * scale;
                    b[3 + a] = b[a] + (r.Below(10) == 0 ? 0 : r.Uniform() * (type == 2 ? 6 : 1.5)) * scale;
                }
                if (floats) {
                    b[a] = (float)b[a];
                    b[3 + a] = Math.Max(b[a], (float)b[3 + a]);
                }
            }
            return b;
        }

        static readonly double[] DirectionParts = { 0, 1, -1, 0.5, -0.5, 2, -3 };

        static Query RandomQuery(Rng r, Kind kind, double scale, bool floats)
        {
            var q = new Query { Kind = kind };
            if (kind == Kind.Box || kind == Kind.Sweep) {
                q.V = RandomBox(r, scale, floats);
            } else {
                q.V = new double[3];
                for (int a = 0; a < 3; a++)
                    q.V[a] = Coord(r, scale, floats);
            }
            for (int a = 0; a < 3; a++) {
                double c = r.Below(4) == 0 ? DirectionParts[r.Below(DirectionParts.Length)] : r.Uniform() * 4 - 2;
                q.D[a] = r.Below(6) == 0 ? 0 : floats ? (float)(c * scale) : c * scale;
            }
            if (kind == Kind.Sphere) {
                // (Radii whose square overflows to +inf crash the library: their own test, in a child.)
                double[] radii = { 0, 0.5 * scale, scale, r.Uniform() * 3 * scale, r.Uniform() * scale, 1e150 };
                q.Num = radii[r.Below(radii.Length)];
            } else {
                double[] maxT = { 0, 0.5, 1, 4, double.PositiveInfinity, r.Uniform() * 6, r.Uniform() };
                q.Num = maxT[r.Below(maxT.Length)];
            }
            return q;
        }

        static readonly Kind[] Kinds = { Kind.Box, Kind.Point, Kind.Sphere, Kind.Ray, Kind.Sweep };

        static void CheckRandomQueries(Scene s, Model m, Rng r, int rounds, double scale, string state)
        {
            for (int k = 0; k < rounds; k++)
                foreach (Kind kind in Kinds) {
                    Query q = RandomQuery(r, kind, scale, r.Below(2) == 0);
                    CheckQuery(s, m, q, Masks[r.Below(Masks.Length)], r.Below(3) == 0, state + " round " + k + ":");
                }
        }

        static ulong[] AddRandom(Scene s, Model m, Rng r, int n, double scale, bool f64)
        {
            var boxes = new double[6 * n];
            var cats = new ulong[n];
            var users = new ulong[n];
            for (int k = 0; k < n; k++) {
                Array.Copy(RandomBox(r, scale, !f64), 0, boxes, 6 * k, 6);
                cats[k] = Categories[r.Below(Categories.Length)];
                users[k] = r.Next() % 1000;
            }
            var o = new SceneAddOptions { Categories = cats, Users = users };
            ulong[] ids = f64 ? s.Add(boxes, o) : s.Add(boxes.Select(v => (float)v).ToArray(), o);
            for (int k = 0; k < n; k++)
                m.Objects.Add(ids[k], new Obj { Box = Row(boxes, k), Category = cats[k], User = users[k] });
            return ids;
        }

        static double[] Row(double[] a, int k)
        {
            var b = new double[6];
            Array.Copy(a, 6 * k, b, 0, 6);
            return b;
        }

        // A share of the objects moved: a small step, or anywhere.
        static void MoveRandom(Scene s, Model m, Rng r, double share, double scale, bool f64)
        {
            var ids = new List<ulong>();
            var boxes = new List<double>();
            foreach (var kv in m.Objects)
                if (r.Uniform() < share) {
                    double[] b;
                    if (r.Below(3) == 0) {
                        b = RandomBox(r, scale, !f64);
                    } else {
                        b = (double[])kv.Value.Box.Clone();
                        for (int a = 0; a < 3; a++) {
                            double step = (r.Uniform() - 0.5) * 0.4 * scale;
                            b[a] += step;
                            b[3 + a] += step;
                            if (!f64) {
                                b[a] = (float)b[a];
                                b[3 + a] = Math.Max(b[a], (float)b[3 + a]);
                            }
                        }
                    }
                    ids.Add(kv.Key);
                    boxes.AddRange(b);
                }
            if (f64) s.Move(ids.ToArray(), boxes.ToArray()); else s.Move(ids.ToArray(), boxes.Select(v => (float)v).ToArray());
            for (int k = 0; k < ids.Count; k++)
                m.Objects[ids[k]].Box = boxes.Skip(6 * k).Take(6).ToArray();
        }

        static ulong[] RemoveRandom(Scene s, Model m, Rng r, int n)
        {
            var live = m.Objects.Keys.ToList();
            var gone = new List<ulong>();
            for (int k = 0; k < n && live.Count > 0; k++) {
                int at = r.Below(live.Count);
                gone.Add(live[at]);
                live.RemoveAt(at);
            }
            s.Remove(gone.ToArray());
            foreach (ulong id in gone)
                m.Objects.Remove(id);
            return gone.ToArray();
        }

        // Categories (0 included: no mask passes it) and user values (the reject callback reads them)
        // of some objects changed.
        static void RefilterRandom(Scene s, Model m, Rng r, int n)
        {
            var ids = m.Objects.Keys.Where(_ => r.Below(m.Objects.Count) < n).ToArray();
            var cats = ids.Select(_ => Categories[r.Below(Categories.Length)]).ToArray();
            var users = ids.Select(_ => r.Next() % 1000).ToArray();
            s.SetFilter(ids, cats, null, null);
            s.SetUser(ids, users);
            for (int k = 0; k < ids.Length; k++) {
                m.Objects[ids[k]].Category = cats[k];
                m.Objects[ids[k]].User = users[k];
            }
        }

        // Queries in every state of a scene: empty, added and not updated, updated, moved and
        // updated, moved and not updated, after removals (updated or not), after filter and user
        // changes, after adds to an updated scene. Scales 1, 1/4 and 1024 keep the grid exact.
        static void RandomScenes(bool f64)
        {
            var r = new Rng(f64 ? 0x9E51064UL : 0x9E51032UL);
            long queries = 0;
            for (int run = 0; run < 3; run++) {
                double scale = new[] { 1.0, 0.25, 1024.0 }[run];
                var m = new Model();
                using (var s = new Scene(1 + run % 2)) {
                    Action<string> check = state => {
                        CheckRandomQueries(s, m, r, 12, scale, "run " + run + " " + state);
                        queries += 12 * 5;
                    };
                    check("empty");
                    AddRandom(s, m, r, 1200, scale, f64);
                    check("added, before the first update");
                    s.Update(SceneUpdateFlags.Pairs);
                    check("after the first update");
                    for (int step = 0; step < 4; step++) {
                        MoveRandom(s, m, r, step == 3 ? 1.0 : 0.1, scale, f64);
                        s.Update(SceneUpdateFlags.Pairs);
                        check("step " + step + ": moved and updated");
                        MoveRandom(s, m, r, step == 1 ? 0.9 : 0.05, scale, f64);
                        check("step " + step + ": between a move and its update");
                        RemoveRandom(s, m, r, 1 + r.Below(60));
                        check("step " + step + ": moved, removed, not updated");
                        s.Update(SceneUpdateFlags.Pairs);
                        check("step " + step + ": after removals and an update");
                        RefilterRandom(s, m, r, 100);
                        check("step " + step + ": categories and user values changed");
                        AddRandom(s, m, r, 1 + r.Below(80), scale, f64 ^ (step % 2 == 1));
                        check("step " + step + ": added to an updated scene");
                        s.Update(SceneUpdateFlags.Pairs);
                    }
                    RemoveRandom(s, m, r, m.Objects.Count);
                    check("every object removed");
                    Assert.Equal(0L, s.Count, "empty again");
                }
            }
            Console.WriteLine("         {0} random queries, each in every mode, against the brute force", queries);
        }

        // ------------------------------------------------------------------
        // Batches against one by one, threads 1, 2, 3, arrays, pointers and spans
        // ------------------------------------------------------------------

        /// <summary>n queries of one kind as the batch calls take them: floats (3 or 6 a query),
        /// directions (3), max_t or radii (1).</summary>
        sealed class BatchInput
        {
            public Kind Kind;
            public Query[] Queries;
            public float[] V, D;
            public double[] Num;

            public BatchInput(Kind kind, Query[] qs)
            {
                Kind = kind;
                Queries = qs;
                int w = kind == Kind.Box || kind == Kind.Sweep ? 6 : 3;
                V = new float[w * qs.Length];
                D = new float[3 * qs.Length];
                Num = new double[qs.Length];
                for (int k = 0; k < qs.Length; k++) {
                    for (int a = 0; a < w; a++) {
                        V[w * k + a] = (float)qs[k].V[a];
                        Assert.True(V[w * k + a] == qs[k].V[a], "query values are floats");
                    }
                    for (int a = 0; a < 3; a++)
                        D[3 * k + a] = (float)qs[k].D[a];
                    Num[k] = qs[k].Num;
                }
            }

            /// <summary>The batch call of this kind, from the arrays.</summary>
            public void Run(Scene s, HitMode mode, QueryHits hits, ulong mask, Native.locd_query_reject_fn reject)
            {
                switch (Kind) {
                case Kind.Box: s.QueryBoxBatch(V, hits, mask, reject); break;
                case Kind.Point: s.QueryPointBatch(V, hits, mask, reject); break;
                case Kind.Sphere: s.QuerySphereBatch(V, Num, hits, mask, reject); break;
                case Kind.Ray: s.RaycastBatch(V, D, Num, mode, hits, mask, reject); break;
                default: s.SweepBoxBatch(V, D, Num, mode, hits, mask, reject); break;
                }
            }

            /// <summary>The span form, from slices that start 5 values into longer arrays (a span's
            /// start, not its array's, is what the call must read).</summary>
            public void RunSpans(Scene s, HitMode mode, QueryHits hits, ulong mask, Native.locd_query_reject_fn reject)
            {
                ReadOnlySpan<float> v = Slice(V), d = Slice(D);
                ReadOnlySpan<double> num = Slice(Num);
                switch (Kind) {
                case Kind.Box: s.QueryBoxBatch(v, hits, mask, reject); break;
                case Kind.Point: s.QueryPointBatch(v, hits, mask, reject); break;
                case Kind.Sphere: s.QuerySphereBatch(v, num, hits, mask, reject); break;
                case Kind.Ray: s.RaycastBatch(v, d, num, mode, hits, mask, reject); break;
                default: s.SweepBoxBatch(v, d, num, mode, hits, mask, reject); break;
                }
            }

            /// <summary>a's values 5 into an array of NaN (a call that read from the array's start would
            /// fail on them), as a span of a.Length.</summary>
            static ReadOnlySpan<T> Slice<T>(T[] a)
            {
                var big = new T[a.Length + 10];
                T nan = (T)(object)(typeof(T) == typeof(float) ? (object)float.NaN : (object)double.NaN);
                for (int k = 0; k < big.Length; k++)
                    big[k] = nan;
                Array.Copy(a, 0, big, 5, a.Length);
                return new ReadOnlySpan<T>(big, 5, a.Length);
            }

            /// <summary>The pointer form, from copies in unmanaged memory (as a NativeArray's).</summary>
            public void RunPointers(Scene s, HitMode mode, QueryHits hits, ulong mask, Native.locd_query_reject_fn reject)
            {
                IntPtr v = Copy(V), d = Copy(D), num = Copy(Num);
                try {
                    float* pv = (float*)v, pd = (float*)d;
                    double* pn = (double*)num;
                    long n = Queries.Length;
                    switch (Kind) {
                    case Kind.Box: s.QueryBoxBatch(pv, n, hits, mask, reject); break;
                    case Kind.Point: s.QueryPointBatch(pv, n, hits, mask, reject); break;
                    case Kind.Sphere: s.QuerySphereBatch(pv, pn, n, hits, mask, reject); break;
                    case Kind.Ray: s.RaycastBatch(pv, pd, pn, n, mode, hits, mask, reject); break;
                    default: s.SweepBoxBatch(pv, pd, pn, n, mode, hits, mask, reject); break;
                    }
                } finally {
                    Marshal.FreeHGlobal(v);
                    Marshal.FreeHGlobal(d);
                    Marshal.FreeHGlobal(num);
                }
            }
        }

        static IntPtr Copy(float[] a)
        {
            IntPtr p = Marshal.AllocHGlobal(Math.Max(1, a.Length) * sizeof(float));
            Marshal.Copy(a, 0, p, a.Length);
            return p;
        }

        static IntPtr Copy(double[] a)
        {
            IntPtr p = Marshal.AllocHGlobal(Math.Max(1, a.Length) * sizeof(double));
            Marshal.Copy(a, 0, p, a.Length);
            return p;
        }

        /// <summary>The contents of a QueryHits, copied.</summary>
        sealed class Snapshot
        {
            public long Queries, Count;
            public long[] Offsets;
            public ulong[] Ids;
            public double[] T;
            public bool HasT;

            public Snapshot(QueryHits h)
            {
                Queries = h.Queries;
                Count = h.Count;
                Offsets = h.OffsetsArray();
                Ids = h.IdsArray();
                T = h.TArray();
                HasT = h.T != null;
            }

            public void AssertSame(Snapshot o, string what)
            {
                Assert.Equal(Queries, o.Queries, what + ": queries");
                Assert.Equal(Count, o.Count, what + ": count");
                Assert.Equal(HasT, o.HasT, what + ": t given");
                Assert.True(Offsets.SequenceEqual(o.Offsets), what + ": offsets");
                Assert.True(Ids.SequenceEqual(o.Ids), what + ": ids");
                Assert.True(T.SequenceEqual(o.T), what + ": t");
            }

            /// <summary>Query k's entries.</summary>
            public Hit[] Of(int k)
            {
                var h = new Hit[Offsets[k + 1] - Offsets[k]];
                for (long j = Offsets[k]; j < Offsets[k + 1]; j++)
                    h[j - Offsets[k]] = new Hit { Id = Ids[j], T = HasT ? T[j] : 0 };
                return h;
            }
        }

        /// <summary>A batch's hits: the layout of its mode, each query's hits equal to the brute
        /// force's (closest: the first; any: one of them) and, when given, to the single query's.</summary>
        static void CheckBatch(Snapshot b, BatchInput input, HitMode mode, Model m, ulong mask, bool reject,
                               Scene single, string at)
        {
            int n = input.Queries.Length;
            bool casts = input.Kind >= Kind.Ray, one = casts && mode != HitMode.All;
            Assert.Equal((long)n, b.Queries, at + ": queries");
            Assert.Equal(n + 1, b.Offsets.Length, at + ": offsets");
            Assert.Equal(0L, b.Offsets[0], at + ": offsets[0]");
            Assert.Equal(b.Count, b.Offsets[n], at + ": offsets[n] = count");
            Assert.Equal(casts, b.HasT, at + ": t given for casts only");
            for (int k = 0; k < n; k++) {
                Query q = input.Queries[k];
                string where = at + " query " + k + " " + q;
                List<Hit> want = m.Brute(q, mask, reject);
                Hit[] got = b.Of(k);
                Hit[] alone = single != null && (!reject || q.Kind >= Kind.Sphere) ? Ask(single, q, mode, mask, reject) : null;
                if (!one) {
                    SameHits(want, got, where + " against the brute force");
                    if (alone != null)
                        SameHits(alone, got, where + " against the query alone");
                    continue;
                }
                Assert.Equal((long)k, b.Offsets[k], where + ": one entry a query");
                Assert.Equal(1, got.Length, where + ": one entry");
                if (want.Count == 0) {
                    Assert.Equal(0UL, got[0].Id, where + ": no hit is id 0");
                    Assert.True(double.IsPositiveInfinity(got[0].T), where + ": no hit is t +inf, not " + got[0].T);
                } else if (mode == HitMode.Closest) {
                    SameHits(new[] { want[0] }, got, where + " closest against the brute force");
                } else {
                    Assert.True(want.Any(h => h.Id == got[0].Id && h.T == got[0].T), where + ": any " + got[0] + " is a hit");
                }
                if (alone != null)
                    SameHits(alone.Length == 0 ? new[] { new Hit { Id = 0, T = double.PositiveInfinity } } : alone, got,
                             where + " against the query alone");
            }
        }

        static Scene[] AlikeScenes(int n, Model m, out ulong[] ids)
        {
            var scenes = new Scene[3];
            ids = null;
            for (int i = 0; i < 3; i++) {
                var r = new Rng(0xBA7C4);
                var mi = i == 0 ? m : new Model();
                scenes[i] = new Scene(i + 1);
                ulong[] got = AddRandom(scenes[i], mi, r, n, 4, false);
                if (ids != null)
                    Assert.True(ids.SequenceEqual(got), "scenes made alike have the same ids");
                ids = got;
                scenes[i].Update(SceneUpdateFlags.Pairs);
                MoveRandom(scenes[i], mi, r, 0.03, 4, false); // a move not updated yet
            }
            return scenes;
        }

        static void BatchesEqualOneByOne()
        {
            const int N = 3000, Q = 600; // Q > 256: the batch runs on the engine's threads
            var m = new Model();
            ulong[] ids;
            Scene[] scenes = AlikeScenes(N, m, out ids);
            var hits = new QueryHits();
            var r = new Rng(0xBA7C5);
            int batches = 0;
            try {
                foreach (Kind kind in Kinds) {
                    var qs = new Query[Q];
                    for (int k = 0; k < Q; k++)
                        qs[k] = RandomQuery(r, kind, 4, true);
                    var input = new BatchInput(kind, qs);
                    HitMode[] modes = kind >= Kind.Ray ? new[] { HitMode.All, HitMode.Closest, HitMode.Any } : new[] { HitMode.All };
                    for (int pass = 0; pass < 2; pass++) {
                        ulong mask = pass == 0 ? Scene.AllCategories : 3;
                        bool reject = pass == 1;
                        foreach (HitMode mode in modes) {
                            string at = kind + " " + mode + (reject ? " mask 3 + reject" : "");
                            Snapshot first = null;
                            for (int i = 0; i < 3; i++)
                                for (int form = 0; form < 3; form++) {
                                    if (form == 0)
                                        input.Run(scenes[i], mode, hits, mask, reject ? RejectOdd : null);
                                    else if (form == 1)
                                        input.RunPointers(scenes[i], mode, hits, mask, reject ? RejectOdd : null);
                                    else
                                        input.RunSpans(scenes[i], mode, hits, mask, reject ? RejectOdd : null);
                                    batches++;
                                    var snap = new Snapshot(hits);
                                    string which = at + ", " + (i + 1) + " threads, " + new[] { "arrays", "pointers", "spans" }[form];
                                    if (first == null) {
                                        CheckBatch(snap, input, mode, m, mask, reject, scenes[0], which);
                                        first = snap;
                                    } else {
                                        first.AssertSame(snap, which + " against 1 thread, arrays");
                                    }
                                }
                        }
                    }
                }
            } finally {
                hits.Dispose();
                foreach (var s in scenes)
                    s.Dispose();
            }
            Console.WriteLine("         {0} batches of {1} queries on {2} objects", batches, Q, N);
        }

        // ------------------------------------------------------------------
        // Hard cases
        // ------------------------------------------------------------------

        static Query Ray(double ox, double oy, double oz, double dx, double dy, double dz, double maxT)
        {
            return new Query { Kind = Kind.Ray, V = new[] { ox, oy, oz }, D = new[] { dx, dy, dz }, Num = maxT };
        }

        static Query Sweep(double[] box, double dx, double dy, double dz, double maxT)
        {
            return new Query { Kind = Kind.Sweep, V = box, D = new[] { dx, dy, dz }, Num = maxT };
        }

        static Hit[] Hits(params object[] idAndT)
        {
            var h = new Hit[idAndT.Length / 2];
            for (int k = 0; k < h.Length; k++)
                h[k] = new Hit { Id = (ulong)idAndT[2 * k], T = Convert.ToDouble(idAndT[2 * k + 1]) };
            return h;
        }

        // Every mode of q against the hits worked out by hand (all, sorted by (t, id)) and against
        // the brute force.
        static void Expect(Scene s, Model m, Query q, Hit[] all, string what)
        {
            what += ": " + q;
            SameHits(all, Ask(s, q, HitMode.All, Scene.AllCategories, false), what + " all (by hand)");
            SameHits(m.Brute(q, Scene.AllCategories, false), all, what + " (the brute force agrees)");
            if (q.Kind < Kind.Ray)
                return;
            SameHits(all.Take(1).ToArray(), Ask(s, q, HitMode.Closest, Scene.AllCategories, false), what + " closest");
            Hit[] any = Ask(s, q, HitMode.Any, Scene.AllCategories, false);
            Assert.Equal(Math.Min(1, all.Length), any.Length, what + " any: count");
            Assert.True(any.Length == 0 || all.Any(h => h.Id == any[0].Id && h.T == any[0].T), what + " any is a hit");
        }

        static double Above(double x)
        {
            return BitConverter.Int64BitsToDouble(BitConverter.DoubleToInt64Bits(x) + 1); // x > 0
        }

        // A = [0,1]^3 and B = [1,2]x[0,1]^2 share the face x = 1; D = [0,1]x[2,3]x[0,1] lies one unit
        // above A; C is the point (3,3,3); E the square x = 10, [0,1]^2.
        static void HardCasesHandChecked()
        {
            using (var s = new Scene(1)) {
                var m = new Model();
                double[] boxes = {
                    0, 0, 0, 1, 1, 1,
                    1, 0, 0, 2, 1, 1,
                    3, 3, 3, 3, 3, 3,
                    0, 2, 0, 1, 3, 1,
                    10, 0, 0, 10, 1, 1,
                };
                ulong[] id = s.Add(boxes);
                for (int k = 0; k < id.Length; k++)
                    m.Objects.Add(id[k], new Obj { Box = Row(boxes, k) });
                ulong A = id[0], B = id[1], C = id[2], D = id[3], E = id[4];
                Assert.True(A < B && B < C && C < D && D < E, "ids ascend in the order added");
                double inf = double.PositiveInfinity;
                for (int round = 0; round < 2; round++) { // before and after the first update
                    string at = round == 0 ? "not updated" : "updated";
                    // Rays through faces, along a face and an edge (closed boxes: they hit), just off it.
                    Expect(s, m, Ray(-1, 0.5, 0.5, 1, 0, 0, inf), Hits(A, 1, B, 2, E, 11), at + " through the shared face");
                    Expect(s, m, Ray(-1, 1, 0.5, 1, 0, 0, inf), Hits(A, 1, B, 2, E, 11), at + " along the face y = 1");
                    Expect(s, m, Ray(-1, 1, 1, 1, 0, 0, inf), Hits(A, 1, B, 2, E, 11), at + " along the edge y = z = 1");
                    Expect(s, m, Ray(-1, Above(1), 0.5, 1, 0, 0, inf), Hits(), at + " one step above the face");
                    Expect(s, m, Ray(5, 0, 0.5, -1, 0, 0, inf), Hits(B, 3, A, 4), at + " backwards along y = 0");
                    Expect(s, m, Ray(-1, -1, -1, 1, 1, 1, inf), Hits(A, 1, B, 2, C, 4), at + " through the corners");
                    Expect(s, m, Ray(0.5, -10, 0.5, 0, 1, 0, inf), Hits(A, 10, D, 12), at + " up through A and D");
                    Expect(s, m, Ray(-1, 0.5, 0.5, 4, 0, 0, inf), Hits(A, 0.25, B, 0.5, E, 2.75), at + " a longer direction");
                    // Zero direction: a point; the hits at t 0 sorted by id.
                    Expect(s, m, Ray(1, 0.5, 0.5, 0, 0, 0, 10), Hits(A, 0, B, 0), at + " zero direction on the face");
                    Expect(s, m, Ray(1, 1, 1, 0, 0, 0, 0), Hits(A, 0, B, 0), at + " zero direction, max_t 0, on the corner");
                    Expect(s, m, Ray(5, 5, 5, 0, 0, 0, inf), Hits(), at + " zero direction outside");
                    // max_t 0, exactly at the face, -0, +inf.
                    Expect(s, m, Ray(-1, 0.5, 0.5, 1, 0, 0, 0), Hits(), at + " max_t 0 outside");
                    Expect(s, m, Ray(0.5, 0.5, 0.5, 1, 0, 0, 0), Hits(A, 0), at + " max_t 0 inside");
                    Expect(s, m, Ray(-1, 0.5, 0.5, 1, 0, 0, -0.0), Hits(), at + " max_t -0 (is 0)");
                    Expect(s, m, Ray(-1, 0.5, 0.5, 1, 0, 0, 1), Hits(A, 1), at + " max_t reaches the face");
                    Expect(s, m, Ray(-1, 0.5, 0.5, 1, 0, 0, 0.999), Hits(), at + " max_t short of the face");
                    Expect(s, m, Ray(-1, 0.5, 0.5, 1, 0, 0, 2), Hits(A, 1, B, 2), at + " max_t reaches B");
                    // Points on corners, faces, zero-size boxes; a point in the gap.
                    Expect(s, m, new Query { Kind = Kind.Point, V = new double[] { 1, 1, 1 } }, Hits(A, 0, B, 0), at + " point on a corner");
                    Expect(s, m, new Query { Kind = Kind.Point, V = new double[] { 0, 0, 0 } }, Hits(A, 0), at + " point on A's far corner");
                    Expect(s, m, new Query { Kind = Kind.Point, V = new double[] { 3, 3, 3 } }, Hits(C, 0), at + " point on a point");
                    Expect(s, m, new Query { Kind = Kind.Point, V = new double[] { 10, 0.5, 1 } }, Hits(E, 0), at + " point on a square's edge");
                    Expect(s, m, new Query { Kind = Kind.Point, V = new double[] { 0.5, 1.5, 0.5 } }, Hits(), at + " point in the gap");
                    // Boxes touching faces; a zero-size box.
                    Expect(s, m, new Query { Kind = Kind.Box, V = new double[] { 2, 0, 0, 3, 1, 1 } }, Hits(B, 0), at + " box touching B's face");
                    Expect(s, m, new Query { Kind = Kind.Box, V = new double[] { 1, 1, 1, 1, 1, 1 } }, Hits(A, 0, B, 0), at + " zero-size box on the corner");
                    Expect(s, m, new Query { Kind = Kind.Box, V = new double[] { 0, 1, 0, 1, 2, 1 } }, Hits(A, 0, B, 0, D, 0), at + " box filling the gap (B by its edge)");
                    // Spheres touching a face (distance exactly r), short of it, radius 0, a corner.
                    Expect(s, m, new Query { Kind = Kind.Sphere, V = new double[] { 2.5, 0.5, 0.5 }, Num = 0.5 }, Hits(B, 0), at + " sphere touching B");
                    Expect(s, m, new Query { Kind = Kind.Sphere, V = new double[] { 2.5, 0.5, 0.5 }, Num = 0.4999 }, Hits(), at + " sphere short of B");
                    Expect(s, m, new Query { Kind = Kind.Sphere, V = new double[] { 3, 3, 3 }, Num = 0 }, Hits(C, 0), at + " radius 0 on a point");
                    Expect(s, m, new Query { Kind = Kind.Sphere, V = new double[] { 0.5, 1.5, 0.5 }, Num = 0.5 }, Hits(A, 0, D, 0), at + " sphere in the gap");
                    Expect(s, m, new Query { Kind = Kind.Sphere, V = new double[] { 2, 2, 2 }, Num = 1.5 }, Hits(B, 0, D, 0), at + " sphere near corners");
                    Expect(s, m, new Query { Kind = Kind.Sphere, V = new double[] { 2, 2, 2 }, Num = 1e150 }, Hits(A, 0, B, 0, C, 0, D, 0, E, 0), at + " huge radius");
                    // Swept boxes: touching at the start, faces met at t, edges along the way.
                    Expect(s, m, Sweep(new double[] { -2, 0, 0, -1, 1, 1 }, 1, 0, 0, inf), Hits(A, 1, B, 2, E, 11), at + " box through A and B");
                    Expect(s, m, Sweep(new double[] { -1, 0, 0, 0, 1, 1 }, 0, 0, 0, 5), Hits(A, 0), at + " box touching A, not moving");
                    Expect(s, m, Sweep(new double[] { -2, 1, 0, -1, 2, 1 }, 1, 0, 0, inf), Hits(A, 1, D, 1, B, 2, E, 11), at + " box along the gap's faces");
                    Expect(s, m, Sweep(new double[] { -2, 0, 0, -1, 1, 1 }, 1, 0, 0, 0.99), Hits(), at + " box short of A");
                    Expect(s, m, Sweep(new double[] { 0.25, 0.25, 0.25, 0.75, 0.75, 0.75 }, 0, 1, 0, 1.25), Hits(A, 0, D, 1.25), at + " box from inside A up to D");
                    s.Update(SceneUpdateFlags.Pairs);
                }
            }
        }

        // The C suite's lattice: 6 x 6 x 3 unit cubes touching (every fifth one a point on its
        // corner), user values x + y, and a box far away; rays from lattice points along the axes
        // and diagonals (along faces and edges, through corners), zero directions, max_t 0 and +inf;
        // every mode, with and without the reject callback, against the brute force.
        static void HardCasesLattice()
        {
            using (var s = new Scene(2)) {
                var m = new Model();
                for (int x = 0; x < 6; x++)
                    for (int y = 0; y < 6; y++)
                        for (int z = 0; z < 3; z++) {
                            double[] b = { x, y, z, x + 1, y + 1, z + 1 };
                            if ((x + y + z) % 5 == 0) {
                                b[3] = x;
                                b[4] = y;
                                b[5] = z;
                            }
                            ulong u = (ulong)(x + y);
                            ulong id = s.Add(b, new SceneAddOptions { User = u })[0];
                            m.Objects.Add(id, new Obj { Box = b, User = u });
                        }
                double[] far = { 1e7, 1e7, 1e7, 1e7 + 0.5, 1e7 + 0.5, 1e7 + 0.5 };
                m.Objects.Add(s.Add(far)[0], new Obj { Box = far });
                s.Update(SceneUpdateFlags.Pairs);
                double[] at = { -1, 0, 1, 2.5, 3, 6 };
                double[][] dirs = {
                    new double[] { 1, 0, 0 }, new double[] { 0, 1, 0 }, new double[] { 0, 0, 1 }, new double[] { -1, 0, 0 },
                    new double[] { 0, -1, 0 }, new double[] { 1, 1, 0 }, new double[] { 1, 1, 1 }, new double[] { -1, -1, -1 },
                    new double[] { 0, 0, 0 }, new double[] { 1e30, 0, 0 }, new double[] { 0.5, 0, 0.25 },
                };
                double[] maxTs = { 0, 1, 2.5, double.PositiveInfinity };
                int n = 0;
                foreach (double x in at)
                    foreach (double y in at)
                        foreach (double z in at.Take(5)) {
                            double[] dir = dirs[n % dirs.Length];
                            double maxT = maxTs[(n / dirs.Length) % maxTs.Length];
                            var ray = Ray(x, y, z, dir[0], dir[1], dir[2], maxT);
                            CheckQuery(s, m, ray, Scene.AllCategories, n % 3 == 0, "lattice");
                            if (Math.Abs(dir[0]) < 1e20) // the unit box cast from the same corner
                                CheckQuery(s, m, Sweep(new[] { x, y, z, x + 1, y + 1, z + 1 }, dir[0], dir[1], dir[2], maxT),
                                           Scene.AllCategories, n % 3 == 1, "lattice");
                            CheckQuery(s, m, new Query { Kind = Kind.Point, V = new[] { x, y, z } }, Scene.AllCategories, false, "lattice");
                            CheckQuery(s, m, new Query { Kind = Kind.Sphere, V = new[] { x, y, z }, Num = maxT == 0 ? 0 : 1 },
                                       Scene.AllCategories, n % 2 == 0, "lattice");
                            n++;
                        }
                CheckQuery(s, m, Ray(1e7, 1e7, 1e7 - 1, 0, 0, 1, 1), Scene.AllCategories, false, "far box");
                Assert.True(n > 150, "lattice queries");
            }
        }

        // Rays that pass exactly through an edge of a box (they enter one slab at the t where they
        // leave the other: a hit by the float64 slab test), chosen so that multiplying by a rounded
        // reciprocal instead of dividing would put the entry after the exit: a node test that does
        // so without a margin misses them. Single queries in every mode, a batch, and swept points.
        static void GrazingRays()
        {
            var r = new Rng(0x6EA2E);
            var m = new Model();
            var rays = new List<Query>();
            using (var s = new Scene(2))
            using (var hits = new QueryHits()) {
                var boxes = new List<double>();
                while (rays.Count < 120) {
                    int ax = 1 + r.Below(50), by = 1 + r.Below(50);
                    double dx = (float)(0.1 + r.Uniform() * 10), dy = dx * by / ax;
                    if ((float)dy != dy)
                        continue;
                    double[] lo = { ax, by - 1 }, hi = { ax + 1, by }, d = { dx, dy };
                    double t0 = 0, t1 = double.PositiveInfinity, f0 = 0, f1 = double.PositiveInfinity;
                    for (int a = 0; a < 2; a++) {
                        t0 = Math.Max(t0, lo[a] / d[a]);
                        t1 = Math.Min(t1, hi[a] / d[a]);
                        f0 = Math.Max(f0, lo[a] * (1 / d[a]));
                        f1 = Math.Min(f1, hi[a] * (1 / d[a]));
                    }
                    if (!(t0 <= t1 && f0 > f1))
                        continue; // not a graze the reciprocal gets wrong
                    double z = 4 * rays.Count;
                    boxes.AddRange(new[] { lo[0], lo[1], z - 0.5, hi[0], hi[1], z + 0.5 });
                    rays.Add(Ray(0, 0, z, dx, dy, 0, double.PositiveInfinity));
                }
                double[] b = boxes.ToArray();
                ulong[] ids = s.Add(b);
                for (int k = 0; k < ids.Length; k++)
                    m.Objects.Add(ids[k], new Obj { Box = Row(b, k) });
                s.Update(SceneUpdateFlags.Pairs);
                for (int k = 0; k < rays.Count; k++) {
                    Assert.True(m.Brute(rays[k], Scene.AllCategories, false).Any(h => h.Id == ids[k]), "ray " + k + " grazes its box");
                    CheckQuery(s, m, rays[k], Scene.AllCategories, false, "graze " + k);
                    var point = Sweep(rays[k].V.Concat(rays[k].V).ToArray(), rays[k].D[0], rays[k].D[1], 0, double.PositiveInfinity);
                    CheckQuery(s, m, point, Scene.AllCategories, false, "swept point " + k);
                }
                var input = new BatchInput(Kind.Ray, rays.ToArray());
                foreach (HitMode mode in new[] { HitMode.All, HitMode.Closest, HitMode.Any }) {
                    input.Run(s, mode, hits, Scene.AllCategories, null);
                    CheckBatch(new Snapshot(hits), input, mode, m, Scene.AllCategories, false, s, "grazing batch " + mode);
                }
            }
        }

        // Coordinates and directions far outside float's range and near double's ends: boxes around
        // +-1e300, 1e-300 and a few units; directions of 1e-200, 1e-160, 1e160 and 1e300 (the
        // library's node test takes reciprocals only within 2^+-500); max_t up to 1e308 and +inf.
        // Every kind and mode against the brute force.
        static void ExtremeMagnitudes()
        {
            var r = new Rng(0xE87);
            var m = new Model();
            double[] centers = { 0, 1e-300, -1e-300, 3, 1e20, -1e200, 1e300, -1e300, 1e307 };
            double[] sizes = { 0, 1e-310, 1e-300, 1, 1e20, 1e150, 1e299 };
            using (var s = new Scene(2)) {
                var boxes = new List<double>();
                for (int k = 0; k < 400; k++)
                    for (int a = 0; a < 3; a++) {
                        double c = centers[r.Below(centers.Length)], e = sizes[r.Below(sizes.Length)];
                        boxes.Add(c);
                        boxes.Add(c + e); // (hi written after the three lo below)
                    }
                var b6 = new double[6 * 400];
                for (int k = 0; k < 400; k++)
                    for (int a = 0; a < 3; a++) {
                        b6[6 * k + a] = boxes[6 * k + 2 * a];
                        b6[6 * k + 3 + a] = boxes[6 * k + 2 * a + 1];
                    }
                ulong[] ids = s.Add(b6);
                for (int k = 0; k < ids.Length; k++)
                    m.Objects.Add(ids[k], new Obj { Box = Row(b6, k) });
                double[] dirs = { 0, 1, -1, 1e-200, -1e-160, 1e160, -1e300, 1e-310, 1e20 };
                double[] maxTs = { 0, 1, 1e20, 1e160, 1e308, double.PositiveInfinity };
                int overflowing = 0;
                for (int round = 0; round < 2; round++) {
                    for (int k = 0; k < 300; k++) {
                        var q = new Query { Kind = Kinds[k % 5] };
                        int w = q.Kind == Kind.Box || q.Kind == Kind.Sweep ? 6 : 3;
                        q.V = new double[w];
                        for (int a = 0; a < 3; a++) {
                            q.V[a] = centers[r.Below(centers.Length)] + (r.Uniform() - 0.5) * sizes[r.Below(sizes.Length)];
                            if (w == 6)
                                q.V[3 + a] = q.V[a] + sizes[r.Below(sizes.Length)];
                            q.D[a] = dirs[r.Below(dirs.Length)];
                        }
                        q.Num = q.Kind == Kind.Sphere ? new[] { 0, 1, 1e-300, 1e20, 1e150 }[r.Below(5)] : maxTs[r.Below(maxTs.Length)];
                        string at = "round " + round + " query " + k;
                        if (m.Brute(q, Scene.AllCategories, false).Any(h => double.IsInfinity(h.T))) {
                            // An entry time that overflows to +inf: all modes but All have their own
                            // test (queries.entry_time_overflow_closest_and_any_report_it).
                            overflowing++;
                            SameHits(m.Brute(q, Scene.AllCategories, false), Ask(s, q, HitMode.All, Scene.AllCategories, false), at);
                        } else {
                            CheckQuery(s, m, q, Scene.AllCategories, false, at);
                        }
                    }
                    s.Update(SceneUpdateFlags.Pairs);
                }
                Console.WriteLine("         600 queries, {0} of them with a hit whose entry time overflows to +inf", overflowing);
            }
        }

        // A cast whose entry time overflows to +inf (a direction of 1e-310 to a box 1 unit away, max_t
        // +inf) meets the box by scene.h's float64 slab test: t = +inf <= max_t. All reports it, so
        // Closest must report it too (it is the smallest (t, id)), and Any must report a hit.
        static void EntryTimeOverflow()
        {
            // Four boxes on a ray's line (entry times near 1e9) and one at x = 1e300 (its entry time
            // overflows): Any must find one of the five, Closest the first.
            using (var s = new Scene(1)) {
                var m = new Model();
                double[] boxes = {
                    1, 4, 4, 2, 6, 6,   3, 4, 4, 4, 6, 6,   5, 4, 4, 6, 6, 6,   7, 4, 4, 8, 6, 6,
                    1e300, 4, 4, 1e300, 6, 6,
                };
                ulong[] ids = s.Add(boxes);
                for (int k = 0; k < ids.Length; k++)
                    m.Objects.Add(ids[k], new Obj { Box = Row(boxes, k) });
                double inf = double.PositiveInfinity;
                var q = Ray(-1, 5, 5, 1e-9, 0, 0, inf);
                List<Hit> all = m.Brute(q, Scene.AllCategories, false);
                Assert.True(all.Count == 5 && double.IsInfinity(all[4].T) && !double.IsInfinity(all[3].T), "four finite hits and one at +inf");
                Expect(s, m, q, all.ToArray(), "four boxes and one whose entry time overflows");
            }
            using (var s = new Scene(1)) {
                var m = new Model();
                double[] boxes = { 1, -1, -1, 2, 1, 1,   -5, -1, -1, -4, 1, 1 };
                ulong[] ids = s.Add(boxes);
                for (int k = 0; k < 2; k++)
                    m.Objects.Add(ids[k], new Obj { Box = Row(boxes, k) });
                double inf = double.PositiveInfinity;
                var q = Ray(0, 0, 0, 1e-310, 0, 0, inf);
                Expect(s, m, q, Hits(ids[0], inf), "a ray");
                Expect(s, m, Sweep(new double[] { 0, 0, 0, 0.5, 0.5, 0.5 }, -1e-310, 0, 0, inf), Hits(ids[1], inf), "a box");
                // One hit at a finite t, one at +inf: Any must not come back empty.
                var q2 = Ray(-4.5, 0, 0, 1e-310, 0, 0, inf);
                Expect(s, m, q2, Hits(ids[1], 0, ids[0], inf), "from inside the second box");
            }
        }

        // A radius of +inf is valid (scene.h: radius >= 0, not NaN) and meets every object, as does one
        // whose square overflows to +inf (1e155, 1e200): (dx*dx + dy*dy) + dz*dz <= +inf. Run in a child
        // process (Child.cs): the library crashes on it (see the report of this test).
        public static void SphereRadiusSquareOverflowsBody()
        {
            var r = new Rng(0x1AF);
            var m = new Model();
            using (var s = new Scene(2))
            using (var hits = new QueryHits()) {
                AddRandom(s, m, r, 50, 1, false);
                foreach (double radius in new[] { 1e150, 1e155, 1e200, double.PositiveInfinity }) {
                    var q = new Query { Kind = Kind.Sphere, V = new double[] { 0.5, 0.5, 0.5 }, Num = radius };
                    List<Hit> want = m.Brute(q, Scene.AllCategories, false);
                    Assert.Equal(m.Objects.Values.Count(o => o.Category != 0), want.Count, "the brute force: every object");
                    Console.WriteLine("radius " + radius + ": one query");
                    SameHits(want, Ask(s, q, HitMode.All, Scene.AllCategories, false), "radius " + radius);
                    Console.WriteLine("radius " + radius + ": a batch");
                    s.QuerySphereBatch(new float[] { 0.5f, 0.5f, 0.5f }, new[] { radius }, hits);
                    SameHits(want, new Snapshot(hits).Of(0), "radius " + radius + ", a batch");
                }
            }
        }

        // ------------------------------------------------------------------
        // Bad input
        // ------------------------------------------------------------------

        static LocdException ExpectQueryError(Action body, Status status, long index, string what)
        {
            var e = Assert.Throws<LocdException>(body, what);
            Assert.Equal(status, e.Status, what + ": status");
            Assert.Equal(index, e.Index, what + ": index");
            if (index >= 0)
                Assert.True(e.Message.Contains("(query " + index + ")"), what + ": the message names the query: " + e.Message);
            Assert.True(!e.Message.Contains("(box "), what + ": a query is not called a box: " + e.Message);
            return e;
        }

        // The scene is as before: its count, an update finds the same pairs and no events, random
        // queries answer as the brute force.
        static void Unchanged(Scene s, Model m, ulong[] pairs, Rng r, string what)
        {
            Assert.Equal((long)m.Objects.Count, s.Count, what + ": count");
            SceneUpdate u = s.Update();
            Assert.True(pairs.SequenceEqual(u.Pairs), what + ": pairs");
            Assert.Equal(0, u.Created.Length + u.Lost.Length, what + ": no events");
            CheckRandomQueries(s, m, r, 3, 1, what);
        }

        static void BadSingleQueries()
        {
            var r = new Rng(0xBAD1);
            var m = new Model();
            using (var s = new Scene(2)) {
                AddRandom(s, m, r, 300, 1, false);
                s.Update(SceneUpdateFlags.Pairs);
                ulong[] pairs = s.Update().Pairs;
                double nan = double.NaN, inf = double.PositiveInfinity;
                double[] o = { 1, 1, 1 }, d = { 1, 0, 0 }, box = { 1, 1, 1, 2, 2, 2 };
                double[] t;
                // A single query's errors name query 0.
                ExpectQueryError(() => s.CastRay(new[] { 1, nan, 1 }, d, 1, HitMode.All, out t), Status.NonFinite, 0, "ray: NaN origin");
                ExpectQueryError(() => s.CastRay(new[] { 1, 1, inf }, d, 1, HitMode.Closest, out t), Status.NonFinite, 0, "ray: infinite origin");
                ExpectQueryError(() => s.CastRay(o, new[] { nan, 0, 0 }, 1, HitMode.Any, out t), Status.NonFinite, 0, "ray: NaN direction");
                ExpectQueryError(() => s.CastRay(o, new[] { 0, -inf, 0 }, 1, HitMode.All, out t), Status.NonFinite, 0, "ray: infinite direction");
                ExpectQueryError(() => s.CastRay(o, d, -1, HitMode.All, out t), Status.InvalidArgument, 0, "ray: negative max_t");
                ExpectQueryError(() => s.CastRay(o, d, -inf, HitMode.Closest, out t), Status.InvalidArgument, 0, "ray: max_t -inf");
                ExpectQueryError(() => s.CastRay(o, d, nan, HitMode.Any, out t), Status.InvalidArgument, 0, "ray: NaN max_t");
                ExpectQueryError(() => s.CastRay(o, d, 1, (HitMode)3, out t), Status.InvalidArgument, -1, "ray: unknown mode");
                ExpectQueryError(() => s.SweepBox(new double[] { 3, 1, 1, 2, 2, 2 }, d, 1, HitMode.All, out t), Status.InvertedBox, 0, "sweep: min > max");
                ExpectQueryError(() => s.SweepBox(new double[] { 1, 1, 1, 2, nan, 2 }, d, 1, HitMode.All, out t), Status.NonFinite, 0, "sweep: NaN box");
                ExpectQueryError(() => s.SweepBox(box, new[] { 0, nan, 0 }, 1, HitMode.Closest, out t), Status.NonFinite, 0, "sweep: NaN direction");
                ExpectQueryError(() => s.SweepBox(box, d, -0.5, HitMode.Any, out t), Status.InvalidArgument, 0, "sweep: negative max_t");
                ExpectQueryError(() => s.SweepBox(box, d, 1, (HitMode)(-1), out t), Status.InvalidArgument, -1, "sweep: unknown mode");
                ExpectQueryError(() => s.QuerySphere(o, -1), Status.InvalidArgument, 0, "sphere: negative radius");
                ExpectQueryError(() => s.QuerySphere(o, -double.Epsilon), Status.InvalidArgument, 0, "sphere: the smallest negative radius");
                ExpectQueryError(() => s.QuerySphere(o, nan), Status.InvalidArgument, 0, "sphere: NaN radius");
                ExpectQueryError(() => s.QuerySphere(new[] { nan, 0, 0 }, 1), Status.NonFinite, 0, "sphere: NaN center");
                ExpectQueryError(() => s.QueryBox(new double[] { 1, 3, 1, 2, 2, 2 }), Status.InvertedBox, 0, "box: min > max");
                ExpectQueryError(() => s.QueryPoint(new double[] { 1, nan, 1 }), Status.NonFinite, 0, "point: NaN");
                // Still answers: max_t -0 is 0, radius -0 is 0.
                s.CastRay(o, d, -0.0, HitMode.All, out t);
                s.QuerySphere(o, -0.0);
                Unchanged(s, m, pairs, r, "after bad single queries");
            }
        }

        static void BadBatches()
        {
            var r = new Rng(0xBAD2);
            var m = new Model();
            using (var s = new Scene(2))
            using (var hits = new QueryHits()) {
                AddRandom(s, m, r, 300, 1, false);
                ulong[] pairs = s.Update().Pairs;
                float nan = float.NaN, inf = float.PositiveInfinity;
                const int n = 5;
                Func<float[]> points = () => Enumerable.Range(0, 3 * n).Select(k => (float)(k % 4)).ToArray();
                Func<float[]> boxes = () => Enumerable.Range(0, 6 * n).Select(k => (float)(k % 6 < 3 ? 0 : 2)).ToArray();
                Func<float[]> dirs = () => Enumerable.Range(0, 3 * n).Select(k => (float)(k % 3 == 0 ? 1 : 0)).ToArray();
                Func<double[]> ones = () => Enumerable.Repeat(1.0, n).ToArray();
                // A good batch first: the failed one must empty the hits.
                Action good = () => {
                    s.RaycastBatch(points(), dirs(), ones(), HitMode.All, hits);
                    Assert.Equal((long)n, hits.Queries, "a good batch's queries");
                    Assert.True(hits.Count > 0, "a good batch's hits");
                };
                Action<Action, Status, long, string> bad = (body, status, index, what) => {
                    good();
                    ExpectQueryError(body, status, index, what);
                    Assert.Equal(0L, hits.Queries, what + ": the hits are empty");
                    Assert.Equal(0L, hits.Count, what + ": no hits");
                    Assert.True(hits.OffsetsArray().SequenceEqual(new long[] { 0 }), what + ": offsets { 0 }");
                };
                float[] p, b, dd;
                double[] num;
                p = points(); p[3 * 3 + 1] = nan;
                bad(() => s.RaycastBatch(p, dirs(), ones(), HitMode.All, hits), Status.NonFinite, 3, "rays: NaN origin 3");
                p = points(); p[3 * 1 + 2] = -inf;
                bad(() => s.RaycastBatch(p, dirs(), ones(), HitMode.Closest, hits), Status.NonFinite, 1, "rays: infinite origin 1");
                dd = dirs(); dd[3 * 4] = nan;
                bad(() => s.RaycastBatch(points(), dd, ones(), HitMode.Any, hits), Status.NonFinite, 4, "rays: NaN direction 4");
                num = ones(); num[2] = -0.5;
                bad(() => s.RaycastBatch(points(), dirs(), num, HitMode.All, hits), Status.InvalidArgument, 2, "rays: negative max_t 2");
                num = ones(); num[0] = double.NaN;
                bad(() => s.RaycastBatch(points(), dirs(), num, HitMode.All, hits), Status.InvalidArgument, 0, "rays: NaN max_t 0");
                p = points(); p[3 * 4] = nan; num = ones(); num[2] = -1;
                bad(() => s.RaycastBatch(p, dirs(), num, HitMode.All, hits), Status.InvalidArgument, 2, "rays: the first of two bad queries");
                bad(() => s.RaycastBatch(points(), dirs(), ones(), (HitMode)5, hits), Status.InvalidArgument, -1, "rays: unknown mode");
                b = boxes(); b[6 * 2 + 0] = 3;
                bad(() => s.SweepBoxBatch(b, dirs(), ones(), HitMode.Closest, hits), Status.InvertedBox, 2, "sweeps: min > max 2");
                b = boxes(); b[6 * 4 + 5] = nan;
                bad(() => s.SweepBoxBatch(b, dirs(), ones(), HitMode.All, hits), Status.NonFinite, 4, "sweeps: NaN box 4");
                num = ones(); num[1] = double.NegativeInfinity;
                bad(() => s.SweepBoxBatch(boxes(), dirs(), num, HitMode.Any, hits), Status.InvalidArgument, 1, "sweeps: max_t -inf 1");
                b = boxes(); b[6 * 3 + 4] = -1;
                bad(() => s.QueryBoxBatch(b, hits), Status.InvertedBox, 3, "boxes: min > max 3");
                b = boxes(); b[6 * 0 + 0] = inf;
                bad(() => s.QueryBoxBatch(b, hits), Status.NonFinite, 0, "boxes: infinite 0");
                p = points(); p[3 * 2 + 2] = nan;
                bad(() => s.QueryPointBatch(p, hits), Status.NonFinite, 2, "points: NaN 2");
                num = ones(); num[4] = -1;
                bad(() => s.QuerySphereBatch(points(), num, hits), Status.InvalidArgument, 4, "spheres: negative radius 4");
                num = ones(); num[3] = double.NaN;
                bad(() => s.QuerySphereBatch(points(), num, hits), Status.InvalidArgument, 3, "spheres: NaN radius 3");
                p = points(); p[3 * 1] = nan;
                bad(() => s.QuerySphereBatch(p, ones(), hits), Status.NonFinite, 1, "spheres: NaN center 1");
                // The pointer forms report the same.
                p = points(); p[3 * 3 + 1] = nan;
                fixed (float* pp = p)
                fixed (float* pd = dirs())
                fixed (double* pn = ones()) {
                    float* pp1 = pp, pd1 = pd;
                    double* pn1 = pn;
                    bad(() => s.RaycastBatch(pp1, pd1, pn1, n, HitMode.Closest, hits), Status.NonFinite, 3, "ray pointers: NaN origin 3");
                    bad(() => s.QuerySphereBatch(pp1, pn1, n, hits), Status.NonFinite, 3, "sphere pointers: NaN center 3");
                    bad(() => s.QueryPointBatch(pp1, n, hits), Status.NonFinite, 3, "point pointers: NaN 3");
                    s.RaycastBatch(pp1, pd1, pn1, 3, HitMode.All, hits); // the first 3 queries are good
                    Assert.Equal(3L, hits.Queries, "ray pointers: the first 3 queries");
                }
                Unchanged(s, m, pairs, r, "after bad batches");
            }
        }

        static void ManagedArgumentChecks()
        {
            using (var s = new Scene(1))
            using (var hits = new QueryHits()) {
                s.Add(new float[] { 0, 0, 0, 1, 1, 1 });
                double[] t;
                float[] three = { 0, 0, 0 }, six = { 0, 0, 0, 1, 1, 1 };
                double[] one = { 1 };
                Assert.Throws<ArgumentNullException>(() => s.CastRay(null, new double[3], 1, HitMode.All, out t), "null origin");
                Assert.Throws<ArgumentException>(() => s.CastRay(new double[2], new double[3], 1, HitMode.All, out t), "origin of 2");
                Assert.Throws<ArgumentException>(() => s.CastRay(new double[3], new double[4], 1, HitMode.All, out t), "direction of 4");
                Assert.Throws<ArgumentException>(() => s.SweepBox(new double[3], new double[3], 1, HitMode.All, out t), "box of 3");
                Assert.Throws<ArgumentException>(() => s.QuerySphere(new double[6], 1), "center of 6");
                Assert.Throws<ArgumentNullException>(() => s.RaycastBatch(three, three, one, HitMode.All, null), "null hits");
                Assert.Throws<ArgumentNullException>(() => s.RaycastBatch(null, three, one, HitMode.All, hits), "null origins");
                Assert.Throws<ArgumentException>(() => s.RaycastBatch(new float[4], three, one, HitMode.All, hits), "origins of 4");
                Assert.Throws<ArgumentException>(() => s.RaycastBatch(three, six, one, HitMode.All, hits), "2 directions for 1 ray");
                Assert.Throws<ArgumentException>(() => s.RaycastBatch(three, three, new double[2], HitMode.All, hits), "2 max_t for 1 ray");
                Assert.Throws<ArgumentException>(() => s.SweepBoxBatch(three, three, one, HitMode.All, hits), "boxes of 3");
                Assert.Throws<ArgumentException>(() => s.QueryBoxBatch(new float[7], hits), "boxes of 7");
                Assert.Throws<ArgumentException>(() => s.QueryPointBatch(new float[5], hits), "points of 5");
                Assert.Throws<ArgumentException>(() => s.QuerySphereBatch(six, one, hits), "1 radius for 2 spheres");
                Assert.Throws<ArgumentException>(() => s.RaycastBatch(new ReadOnlySpan<float>(three), new ReadOnlySpan<float>(six),
                                                                      new ReadOnlySpan<double>(one), HitMode.All, hits), "span: 2 directions for 1 ray");
                Assert.Throws<ArgumentException>(() => s.QuerySphereBatch(new ReadOnlySpan<float>(six), new ReadOnlySpan<double>(one), hits),
                                                 "span: 1 radius for 2 spheres");
                Assert.Throws<ArgumentException>(() => s.QueryBoxBatch(new ReadOnlySpan<float>(new float[7]), hits), "span: boxes of 7");
                fixed (float* p = three)
                fixed (double* q = one) {
                    float* p1 = p;
                    double* q1 = q;
                    Assert.Throws<ArgumentOutOfRangeException>(() => s.RaycastBatch(p1, p1, q1, -1, HitMode.All, hits), "n -1");
                    Assert.Throws<ArgumentOutOfRangeException>(() => s.QueryPointBatch(p1, -1, hits), "n -1 points");
                    var e = Assert.Throws<LocdException>(() => s.RaycastBatch(null, p1, q1, 1, HitMode.All, hits), "null origins pointer");
                    Assert.Equal(Status.NullPointer, e.Status, "a NULL array");
                    s.RaycastBatch((float*)null, null, null, 0, HitMode.Closest, hits); // no queries: no arrays needed
                    Assert.Equal(0L, hits.Queries, "0 queries");
                }
                hits.Dispose();
                Assert.Throws<ObjectDisposedException>(() => s.QueryBoxBatch(six, hits), "disposed hits");
                s.Dispose();
                Assert.Throws<ObjectDisposedException>(() => s.CastRay(new double[3], new double[3], 1, HitMode.All, out t), "disposed scene: ray");
                Assert.Throws<ObjectDisposedException>(() => s.PrepareQueries(), "disposed scene: prepare");
                using (var h2 = new QueryHits())
                    Assert.Throws<ObjectDisposedException>(() => s.QueryBoxBatch(six, h2), "disposed scene: batch");
            }
        }

        // ------------------------------------------------------------------
        // The reject callback
        // ------------------------------------------------------------------

        static void RejectCallback()
        {
            var r = new Rng(0x4E1EC7);
            var m = new Model();
            using (var s = new Scene(3))
            using (var hits = new QueryHits()) {
                AddRandom(s, m, r, 2000, 1, false);
                s.Update(SceneUpdateFlags.Pairs);
                MoveRandom(s, m, r, 0.05, 1, false);
                long calls = 0, wrong = 0;
                var threads = new HashSet<int>();
                // Counts its calls, checks each id and user value against the model, rejects odd users.
                Native.locd_query_reject_fn counting = (user, id, value) => {
                    Interlocked.Increment(ref calls);
                    Obj o;
                    if (user != (IntPtr)0 || !m.Objects.TryGetValue(id, out o) || o.User != value)
                        Interlocked.Increment(ref wrong);
                    lock (threads)
                        threads.Add(Thread.CurrentThread.ManagedThreadId);
                    return (int)(value & 1);
                };
                Native.locd_query_reject_fn all = (user, id, value) => 1;
                long candidates = 0;
                for (int k = 0; k < 60; k++) {
                    Query q = RandomQuery(r, k % 2 == 0 ? Kind.Ray : Kind.Sphere, 1, false);
                    q.Num = q.Kind == Kind.Ray ? double.PositiveInfinity : 2;
                    ulong mask = k % 3 == 0 ? 3UL : Scene.AllCategories;
                    long met = m.Brute(q, mask, false).Count; // the objects the shape meets, category passing
                    calls = 0;
                    double[] t;
                    ulong[] got = q.Kind == Kind.Ray ? s.CastRay(q.V, q.D, q.Num, HitMode.All, out t, mask, counting)
                                                     : s.QuerySphere(q.V, q.Num, mask, counting);
                    Assert.Equal(met, calls, "query " + k + ": one call per object met (and no other)");
                    Assert.True(got.SequenceEqual(m.Brute(q, mask, true).Select(h => h.Id)), "query " + k + ": the odd users rejected");
                    if (q.Kind == Kind.Ray) {
                        calls = 0;
                        s.CastRay(q.V, q.D, q.Num, HitMode.Closest, out t, mask, counting);
                        Assert.True(calls <= met, "closest: at most one call per object met");
                    }
                    Assert.Equal(0, (q.Kind == Kind.Ray ? s.CastRay(q.V, q.D, q.Num, HitMode.Any, out t, mask, all)
                                                        : s.QuerySphere(q.V, q.Num, mask, all)).Length, "all rejected: no hit");
                    candidates += met;
                }
                Assert.True(candidates > 100, "the queries met objects: " + candidates);
                Assert.Equal(0L, wrong, "every call named a live object with its user value");
                // A batch on 3 threads: the callback runs on the engine's threads, concurrently.
                var qs = Enumerable.Range(0, 900).Select(_ => RandomQuery(r, Kind.Ray, 1, true)).ToArray();
                var input = new BatchInput(Kind.Ray, qs);
                long expectCalls = qs.Sum(q => (long)m.Brute(q, Scene.AllCategories, false).Count);
                calls = 0;
                threads.Clear();
                input.Run(s, HitMode.All, hits, Scene.AllCategories, counting);
                Assert.Equal(expectCalls, calls, "batch: one call per object met");
                Assert.Equal(0L, wrong, "batch: every call named a live object with its user value");
                CheckBatch(new Snapshot(hits), input, HitMode.All, m, Scene.AllCategories, true, null, "batch with reject");
                Console.WriteLine("         {0} reject calls in a batch of 900 rays, from {1} threads", calls, threads.Count);
                // A filter's mask 0 passes nothing, and the callback is not called.
                calls = 0;
                input.Run(s, HitMode.Closest, hits, 0, counting);
                Assert.Equal(0L, calls, "mask 0: no calls");
                Assert.True(new Snapshot(hits).Ids.All(id => id == 0), "mask 0: no hits");
                GC.KeepAlive(counting);
                GC.KeepAlive(all);
            }
        }

        // ------------------------------------------------------------------
        // The hits buffer, PrepareQueries, allocation
        // ------------------------------------------------------------------

        static void HitsLifecycle()
        {
            using (var s = new Scene(2)) {
                ulong[] ids = s.Add(new float[] { 0, 0, 0, 1, 1, 1,   2, 0, 0, 3, 1, 1 });
                var hits = new QueryHits();
                Assert.Equal(0L, hits.Queries, "fresh: no queries");
                Assert.Equal(0L, hits.Count, "fresh: no hits");
                Assert.True(hits.OffsetsArray().SequenceEqual(new long[] { 0 }), "fresh: offsets { 0 }");
                Assert.Equal(0, hits.IdsArray().Length + hits.TArray().Length, "fresh: no ids, no t");
                // Rays, all: query 0 hits both, query 1 nothing, query 2 the second box from inside.
                float[] o = { -1, 0.5f, 0.5f,   -1, 5, 5,   2.5f, 0.5f, 0.5f };
                float[] d = { 1, 0, 0,   1, 0, 0,   -1, 0, 0 };
                double[] maxT = { 10, 10, 0.25 };
                s.RaycastBatch(o, d, maxT, HitMode.All, hits);
                Assert.True(hits.OffsetsArray().SequenceEqual(new long[] { 0, 2, 2, 3 }), "all: offsets");
                Assert.True(hits.IdsArray().SequenceEqual(new[] { ids[0], ids[1], ids[1] }), "all: ids");
                Assert.True(hits.TArray().SequenceEqual(new[] { 1.0, 3.0, 0.0 }), "all: t");
                Assert.True(hits.Ids[1] == ids[1] && hits.T[1] == 3.0 && hits.Offsets[3] == 3, "the pointers");
                s.RaycastBatch(o, d, maxT, HitMode.Closest, hits);
                Assert.True(hits.OffsetsArray().SequenceEqual(new long[] { 0, 1, 2, 3 }), "closest: one entry a query");
                Assert.True(hits.IdsArray().SequenceEqual(new[] { ids[0], 0UL, ids[1] }), "closest: ids, 0 for none");
                Assert.True(hits.TArray().SequenceEqual(new[] { 1.0, double.PositiveInfinity, 0.0 }), "closest: t, +inf for none");
                // An overlap batch in the same buffer: no t.
                s.QueryPointBatch(new float[] { 1, 1, 1 }, hits);
                Assert.True(hits.T == null && hits.TArray().Length == 0, "overlaps: no t");
                Assert.True(hits.IdsArray().SequenceEqual(new[] { ids[0] }), "a point on the corner");
                // Larger, then smaller again: the buffer follows.
                var many = Enumerable.Range(0, 3000).SelectMany(k => new float[] { k % 4, 0.5f, 0.5f }).ToArray();
                s.QueryPointBatch(many, hits);
                Assert.Equal(3000L, hits.Queries, "3000 queries");
                Assert.Equal(3000L, hits.Count, "x 0 and 1 in the first box, 2 and 3 in the second");
                s.QuerySphereBatch(new float[0], new double[0], hits);
                Assert.Equal(0L, hits.Queries, "0 queries");
                Assert.True(hits.OffsetsArray().SequenceEqual(new long[] { 0 }), "0 queries: offsets { 0 }");
                hits.Dispose();
                hits.Dispose();
                Assert.True(hits.IsDisposed, "disposed");
                Assert.Throws<ObjectDisposedException>(() => { long q = hits.Queries; }, "Queries after Dispose");
                Assert.Throws<ObjectDisposedException>(() => hits.IdsArray(), "IdsArray after Dispose");
                Assert.Throws<ObjectDisposedException>(() => s.RaycastBatch(o, d, maxT, HitMode.All, hits), "a batch into it");
            }
        }

        static void PrepareQueries()
        {
            var r = new Rng(0x97E9);
            var m = new Model();
            using (var s = new Scene(2)) {
                s.PrepareQueries(); // empty
                AddRandom(s, m, r, 1500, 1, true);
                s.PrepareQueries();
                CheckRandomQueries(s, m, r, 6, 1, "prepared, not updated");
                MoveRandom(s, m, r, 0.2, 1, true);
                RemoveRandom(s, m, r, 100);
                s.PrepareQueries();
                s.PrepareQueries(); // nothing changed since: still right
                CheckRandomQueries(s, m, r, 6, 1, "moved, removed, prepared");
                s.Update(SceneUpdateFlags.Pairs);
                CheckRandomQueries(s, m, r, 6, 1, "then updated");
                // A prepared scene changed again: the single queries bring the structure up to
                // date themselves (no PrepareQueries, no batch).
                for (int step = 0; step < 3; step++) {
                    MoveRandom(s, m, r, step == 0 ? 0.02 : 0.5, 1, step != 1);
                    CheckRandomQueries(s, m, r, 4, 1, "step " + step + ": moved after a prepare");
                    RemoveRandom(s, m, r, 50);
                    AddRandom(s, m, r, 30, 1, false);
                    RefilterRandom(s, m, r, 100);
                    CheckRandomQueries(s, m, r, 4, 1, "step " + step + ": removed, added, refiltered after a prepare");
                    s.Update(SceneUpdateFlags.Pairs);
                    s.PrepareQueries();
                }
            }
        }

        // The per-frame pattern: move, update, a batch of rays from native memory into one QueryHits,
        // read through the pointers. 200 frames allocate no managed memory.
        static void NoAllocation()
        {
            var r = new Rng(0xA110C);
            const int Rays = 512;
            using (var s = new Scene(2))
            using (var hits = new QueryHits()) {
                ulong[] ids = s.Add(Scenes.Uniform(r, 2000, 60, 3));
                var moving = ids.Where((_, k) => k % 10 == 0).ToArray();
                var moved = new float[6 * moving.Length];
                IntPtr o = Marshal.AllocHGlobal(3 * Rays * sizeof(float)), d = Marshal.AllocHGlobal(3 * Rays * sizeof(float));
                IntPtr mt = Marshal.AllocHGlobal(Rays * sizeof(double));
                try {
                    float* po = (float*)o, pd = (float*)d;
                    double* pm = (double*)mt;
                    for (int k = 0; k < Rays; k++) {
                        for (int a = 0; a < 3; a++) {
                            po[3 * k + a] = (float)(r.Uniform() * 60);
                            pd[3 * k + a] = (float)(r.Uniform() - 0.5);
                        }
                        pm[k] = 40;
                    }
                    s.Update(SceneUpdateFlags.None);
                    s.RaycastBatch(po, pd, pm, Rays, HitMode.Closest, hits); // the buffer's room, once
                    long before = GC.GetTotalMemory(true);
                    long hit = 0;
                    fixed (ulong* mp = moving)
                    fixed (float* bp = moved)
                        for (int frame = 0; frame < 200; frame++) {
                            for (int k = 0; k < moved.Length; k += 6)
                                for (int a = 0; a < 3; a++) {
                                    float lo = (float)(r.Uniform() * 60);
                                    moved[k + a] = lo;
                                    moved[k + 3 + a] = lo + 2;
                                }
                            s.Move(mp, bp, moving.Length);
                            s.Update(SceneUpdateFlags.Events);
                            s.RaycastBatch(po, pd, pm, Rays, HitMode.Closest, hits);
                            ulong* hid = hits.Ids;
                            for (int k = 0; k < Rays; k++)
                                hit += hid[k] != 0 ? 1 : 0;
                        }
                    long after = GC.GetTotalMemory(false);
                    Console.WriteLine("         200 frames of {0} rays: managed heap {1} -> {2} B, {3} rays hit", Rays, before, after, hit);
                    Assert.True(after - before < 64 * 1024, "managed allocation over 200 frames: " + (after - before) + " B");
                    Assert.True(hit > 0, "rays hit");
                } finally {
                    Marshal.FreeHGlobal(o);
                    Marshal.FreeHGlobal(d);
                    Marshal.FreeHGlobal(mt);
                }
            }
        }

        static void FilterDefaults()
        {
            Native.locd_query_filter f;
            Native.locd_query_filter_init(&f);
            Assert.Equal((uint)sizeof(Native.locd_query_filter), f.size, "sizeof(locd_query_filter)");
            Assert.Equal((uint)Marshal.SizeOf(typeof(Native.locd_query_filter)), f.size, "marshalled size");
            Assert.Equal(ulong.MaxValue, f.mask, "default mask: every category");
            Assert.True(f.reserved == 0 && f.reject == IntPtr.Zero && f.user == IntPtr.Zero, "zero defaults");
            Assert.Equal(0u, Native.LOCD_HIT_ALL, "LOCD_HIT_ALL");
            Assert.Equal((uint)HitMode.Closest, Native.LOCD_HIT_CLOSEST, "HitMode.Closest");
            Assert.Equal((uint)HitMode.Any, Native.LOCD_HIT_ANY, "HitMode.Any");
        }
    }
}
