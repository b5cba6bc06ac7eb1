// Tests of Locd.Scene: random sequences of add/move/remove/filter changes with
// static objects, compared at every update and query with a brute force
// written here in C#; stale and duplicate ids, bad boxes and the
// batch-rejection rule (a failed call changes nothing); the overloads agree.
using System;
using System.Collections.Generic;
using System.Linq;

namespace Locd.Tests
{
    public static unsafe class SceneTests
    {
        public static void Register(Harness h)
        {
            h.Add("scene.struct_sizes_match_init", StructSizes);
            h.Add("scene.readme_example", ReadmeExample);
            h.Add("scene.random_sequences_f32", () => RandomSequences(false));
            h.Add("scene.random_sequences_f64", () => RandomSequences(true));
            h.Add("scene.stale_ids_rejected_with_index", StaleIds);
            h.Add("scene.failed_batches_change_nothing", FailedBatchesChangeNothing);
            h.Add("scene.overloads_agree", OverloadsAgree);
            h.Add("scene.statics_and_filters", StaticsAndFilters);
            h.Add("scene.float_and_double_calls_mix", FloatAndDoubleMix);
            h.Add("scene.lifetime_and_engine_sharing", Lifetime);
            h.Add("scene.update_reused_buffers_no_allocation", NoAllocation);
        }

        // ------------------------------------------------------------------
        // The model: boxes (exact: grid values) and attributes per live id
        // ------------------------------------------------------------------

        sealed class Obj
        {
            public double[] Box;
            public bool Static;
            public ulong Category, Mask, Group, User;
        }

        sealed class Model
        {
            public readonly SortedDictionary<ulong, Obj> Objects = new SortedDictionary<ulong, Obj>();
            public readonly HashSet<ulong> Issued = new HashSet<ulong>();
            public List<ulong> Previous = new List<ulong>(); // interleaved rows, sorted

            public static bool Overlap(double[] a, double[] b)
            {
                for (int k = 0; k < 3; k++)
                    if (!(a[k] <= b[3 + k] && b[k] <= a[3 + k]))
                        return false;
                return true;
            }

            public List<ulong> Pairs()
            {
                var ids = Objects.Keys.ToArray();
                var rows = new List<ulong>();
                for (int i = 0; i < ids.Length; i++)
                    for (int j = i + 1; j < ids.Length; j++) {
                        Obj a = Objects[ids[i]], b = Objects[ids[j]];
                        if (a.Static && b.Static)
                            continue;
                        if ((a.Category & b.Mask) == 0 || (b.Category & a.Mask) == 0)
                            continue;
                        if (a.Group != 0 && a.Group == b.Group)
                            continue;
                        if (Overlap(a.Box, b.Box)) {
                            rows.Add(ids[i]);
                            rows.Add(ids[j]);
                        }
                    }
                return rows; // ids ascending, so rows come out sorted
            }

            public ulong[] QueryBox(double[] q, ulong mask)
            {
                return Objects.Where(kv => (kv.Value.Category & mask) != 0 && Overlap(kv.Value.Box, q))
                              .Select(kv => kv.Key).ToArray();
            }

            public ulong[] QueryPoint(double[] p, ulong mask)
            {
                var q = new[] { p[0], p[1], p[2], p[0], p[1], p[2] };
                return QueryBox(q, mask);
            }

            // Slab test; the test rays make every quotient exact, so any correct
            // implementation gives the same t to the bit.
            public ulong[] Raycast(double[] o, double[] d, double maxT, ulong mask, out double[] t)
            {
                var hits = new List<KeyValuePair<double, ulong>>();
                foreach (var kv in Objects) {
                    if ((kv.Value.Category & mask) == 0)
                        continue;
                    double[] b = kv.Value.Box;
                    double enter = 0, leave = maxT;
                    for (int a = 0; a < 3; a++) {
                        if (d[a] == 0) {
                            if (o[a] < b[a] || o[a] > b[3 + a]) {
                                enter = 1;
                                leave = 0;
                            }
                            continue;
                        }
                        double t1 = (b[a] - o[a]) / d[a], t2 = (b[3 + a] - o[a]) / d[a];
                        enter = Math.Max(enter, Math.Min(t1, t2));
                        leave = Math.Min(leave, Math.Max(t1, t2));
                    }
                    if (enter <= leave)
                        hits.Add(new KeyValuePair<double, ulong>(enter, kv.Key));
                }
                var sorted = hits.OrderBy(h => h.Key).ThenBy(h => h.Value).ToArray();
                t = sorted.Select(h => h.Key).ToArray();
                return sorted.Select(h => h.Value).ToArray();
            }
        }

        static List<ulong> Minus(List<ulong> a, List<ulong> b)
        {
            var set = new HashSet<KeyValuePair<ulong, ulong>>();
            for (int k = 0; k < b.Count; k += 2)
                set.Add(new KeyValuePair<ulong, ulong>(b[k], b[k + 1]));
            var rows = new List<ulong>();
            for (int k = 0; k < a.Count; k += 2)
                if (!set.Contains(new KeyValuePair<ulong, ulong>(a[k], a[k + 1]))) {
                    rows.Add(a[k]);
                    rows.Add(a[k + 1]);
                }
            return rows;
        }

        static void SameIds(IList<ulong> expected, IList<ulong> actual, string what)
        {
            if (expected.Count != actual.Count)
                throw new Exception(what + ": expected " + expected.Count + " values, got " + actual.Count
                                    + " [" + string.Join(" ", expected.Take(10)) + "] vs [" + string.Join(" ", actual.Take(10)) + "]");
            for (int k = 0; k < expected.Count; k++)
                if (expected[k] != actual[k])
                    throw new Exception(what + ": differ at " + k + ": expected " + expected[k] + ", got " + actual[k]);
        }

        static void CheckUpdate(Scene scene, Model model)
        {
            var r = scene.Update();
            var now = model.Pairs();
            SameIds(now, r.Pairs, "pairs");
            SameIds(Minus(now, model.Previous), r.Created, "created");
            SameIds(Minus(model.Previous, now), r.Lost, "lost");
            model.Previous = now;
            Assert.Equal((long)model.Objects.Count, scene.Count, "count");
        }

        static void CheckQueries(Scene scene, Model model, Rng r, double scale, bool f64)
        {
            double[] q = GridBoxes(r, 1, scale);
            double[] p = { (r.Below(13) - 6) * scale, (r.Below(13) - 6) * scale, (r.Below(13) - 6) * scale };
            double[] comps = { 0, 1, -1, 0.5, -0.5, 2 };
            double[] o = { (r.Below(13) - 6) * scale, (r.Below(13) - 6) * scale, (r.Below(13) - 6) * scale };
            double[] d = { comps[r.Below(6)], comps[r.Below(6)], comps[r.Below(6)] };
            double[] maxTs = { 0, scale, 4 * scale, 64 * scale, double.PositiveInfinity };
            double maxT = maxTs[r.Below(maxTs.Length)];
            ulong[] masks = { Scene.AllCategories, 1, 2, 3, 0 };
            ulong mask = masks[r.Below(masks.Length)];
            double[] t, wantT;
            ulong[] hits;
            if (f64) {
                SameIds(model.QueryBox(q, mask), scene.QueryBox(q, mask), "query box");
                SameIds(model.QueryPoint(p, mask), scene.QueryPoint(p, mask), "query point");
                hits = scene.Raycast(o, d, maxT, out t, mask);
            } else {
                SameIds(model.QueryBox(q, mask), scene.QueryBox(ToF(q), mask), "query box");
                SameIds(model.QueryPoint(p, mask), scene.QueryPoint(ToF(p), mask), "query point");
                hits = scene.Raycast(ToF(o), ToF(d), maxT, out t, mask);
            }
            SameIds(model.Raycast(o, d, maxT, mask, out wantT), hits, "raycast ids");
            Assert.Equal(wantT.Length, t.Length, "raycast t count");
            for (int k = 0; k < t.Length; k++)
                Assert.Equal(wantT[k], t[k], "raycast t[" + k + "]");
        }

        // Corners on a grid of powers of two: touching faces, edges and corners are
        // common, zero-size boxes occur, and every value is exact in float and double.
        static double[] GridBoxes(Rng r, int n, double scale)
        {
            var b = new double[6 * n];
            for (int i = 0; i < n; i++)
                for (int a = 0; a < 3; a++) {
                    int lo = r.Below(9) - 4;
                    b[6 * i + a] = lo * scale;
                    b[6 * i + 3 + a] = (lo + r.Below(3)) * scale;
                }
            return b;
        }

        static float[] ToF(double[] d)
        {
            return d.Select(v => (float)v).ToArray();
        }

        static double[] Row(double[] boxes, int k)
        {
            var b = new double[6];
            Array.Copy(boxes, 6 * k, b, 0, 6);
            return b;
        }

        static ulong[] SomeLive(Rng r, Model model, int max)
        {
            var live = model.Objects.Keys.ToList();
            var pick = new List<ulong>();
            int n = Math.Min(live.Count, r.Below(max + 1));
            for (int k = 0; k < n; k++) {
                int at = r.Below(live.Count);
                pick.Add(live[at]);
                live.RemoveAt(at);
            }
            return pick.ToArray();
        }

        static readonly ulong[] Categories = { 1, 2, 3, 0, 1UL << 63 };
        static readonly ulong[] Masks = { Scene.AllCategories, 1, 2, 3, 0, (1UL << 63) | 1 };
        static readonly ulong[] Groups = { 0, 0, 1, 2 };

        static ulong[] Pick(Rng r, ulong[] from, int n)
        {
            var v = new ulong[n];
            for (int k = 0; k < n; k++)
                v[k] = from[r.Below(from.Length)];
            return v;
        }

        // ------------------------------------------------------------------
        // Random sequences
        // ------------------------------------------------------------------

        static void RandomSequences(bool f64)
        {
            var r = new Rng(f64 ? 0x5CE4E64UL : 0x5CE4E32UL);
            long steps = 0, updates = 0, errors = 0;
            for (int run = 0; run < 24; run++) {
                double scale = new[] { 1.0, 0.25, 1024.0 }[run % 3];
                var model = new Model();
                using (var scene = new Scene(1 + run % 2)) {
                    for (int step = 0; step < 200; step++, steps++) {
                        int op = r.Below(12);
                        string at = "run " + run + " step " + step + " op " + op + ": ";
                        try {
                            errors += Step(scene, model, r, scale, f64, op, ref updates);
                        } catch (Exception e) {
                            throw new Exception(at + e.Message, e);
                        }
                        Assert.Equal((long)model.Objects.Count, scene.Count, at + "count");
                    }
                    CheckUpdate(scene, model);
                    CheckUpdate(scene, model);
                    Assert.Equal(0, model.Previous.Count == 0 ? 0 : Minus(model.Pairs(), model.Previous).Count,
                                 "no events when nothing changed");
                }
            }
            Console.WriteLine("         {0} steps, {1} updates compared, {2} rejected batches", steps, updates, errors);
        }

        // One random operation; returns 1 when it was a batch the library had to reject.
        static int Step(Scene scene, Model model, Rng r, double scale, bool f64, int op, ref long updates)
        {
            switch (op) {
            case 0:
            case 1: { // add
                int n = r.Below(7);
                double[] boxes = GridBoxes(r, n, scale);
                var o = new SceneAddOptions { Static = r.Below(3) == 0 };
                if (r.Below(2) == 0) o.Categories = Pick(r, Categories, n); else o.Category = Pick(r, Categories, 1)[0];
                if (r.Below(2) == 0) o.Masks = Pick(r, Masks, n); else o.Mask = Pick(r, Masks, 1)[0];
                if (r.Below(2) == 0) o.Groups = Pick(r, Groups, n); else o.Group = Pick(r, Groups, 1)[0];
                if (r.Below(2) == 0) o.Users = Enumerable.Range(0, n).Select(k => r.Next()).ToArray(); else o.User = r.Next();
                ulong[] ids = f64 ? scene.Add(boxes, o) : scene.Add(ToF(boxes), o);
                Assert.Equal(n, ids.Length, "ids returned");
                for (int k = 0; k < n; k++) {
                    Assert.True(ids[k] != 0 && !model.Issued.Contains(ids[k]), "new nonzero id " + ids[k]);
                    model.Issued.Add(ids[k]);
                    model.Objects[ids[k]] = new Obj {
                        Box = Row(boxes, k), Static = o.Static,
                        Category = o.Categories != null ? o.Categories[k] : o.Category,
                        Mask = o.Masks != null ? o.Masks[k] : o.Mask,
                        Group = o.Groups != null ? o.Groups[k] : o.Group,
                        User = o.Users != null ? o.Users[k] : o.User,
                    };
                }
                return 0;
            }
            case 2:
            case 3: { // move
                ulong[] ids = SomeLive(r, model, 6);
                double[] boxes = GridBoxes(r, ids.Length, scale);
                if (f64) scene.Move(ids, boxes); else scene.Move(ids, ToF(boxes));
                for (int k = 0; k < ids.Length; k++)
                    model.Objects[ids[k]].Box = Row(boxes, k);
                return 0;
            }
            case 4: { // remove
                ulong[] ids = SomeLive(r, model, 5);
                scene.Remove(ids);
                foreach (ulong id in ids)
                    model.Objects.Remove(id);
                return 0;
            }
            case 5: { // filter, some attributes kept
                ulong[] ids = SomeLive(r, model, 6);
                ulong[] c = r.Below(2) == 0 ? Pick(r, Categories, ids.Length) : null;
                ulong[] m = r.Below(2) == 0 ? Pick(r, Masks, ids.Length) : null;
                ulong[] g = r.Below(2) == 0 ? Pick(r, Groups, ids.Length) : null;
                scene.SetFilter(ids, c, m, g);
                for (int k = 0; k < ids.Length; k++) {
                    Obj ob = model.Objects[ids[k]];
                    if (c != null) ob.Category = c[k];
                    if (m != null) ob.Mask = m[k];
                    if (g != null) ob.Group = g[k];
                }
                return 0;
            }
            case 6: { // user values
                ulong[] ids = SomeLive(r, model, 6);
                ulong[] u = ids.Select(_ => r.Next()).ToArray();
                scene.SetUser(ids, u);
                for (int k = 0; k < ids.Length; k++)
                    model.Objects[ids[k]].User = u[k];
                ids = SomeLive(r, model, 6);
                SameIds(ids.Select(id => model.Objects[id].User).ToArray(), scene.GetUser(ids), "user values");
                return 0;
            }
            case 7:
                CheckUpdate(scene, model);
                updates++;
                return 0;
            case 8:
                CheckQueries(scene, model, r, scale, f64);
                return 0;
            case 9: { // a stale id somewhere in a good batch
                var gone = model.Issued.Where(id => !model.Objects.ContainsKey(id)).ToList();
                ulong bad = gone.Count > 0 && r.Below(2) == 0 ? gone[r.Below(gone.Count)] : 0xDEADBEEFUL << r.Below(20);
                if (model.Objects.ContainsKey(bad))
                    return 0;
                var ids = SomeLive(r, model, 5).ToList();
                int at = r.Below(ids.Count + 1);
                ids.Insert(at, bad);
                ulong[] batch = ids.ToArray();
                int which = r.Below(4);
                var e = Assert.Throws<LocdException>(() => {
                    if (which == 0) scene.Move(batch, GridBoxes(r, batch.Length, scale));
                    else if (which == 1) scene.Remove(batch);
                    else if (which == 2) scene.SetFilter(batch, new ulong[batch.Length], null, null);
                    else scene.GetUser(batch);
                }, "stale id");
                // GetUser only reads (an id may repeat there): no count check.
                ExpectBadId(e, Status.StaleId, which == 3 ? 0 : batch.Length, model.Objects.Count);
                if (e.Status == Status.StaleId)
                    Assert.Equal((long)at, e.Index, "index of the stale id");
                return 1;
            }
            case 10: { // NaN, infinite or inverted box
                int n = 1 + r.Below(5);
                double[] boxes = GridBoxes(r, n, scale);
                int at = r.Below(n), axis = r.Below(3);
                bool nonfinite = r.Below(2) == 0;
                if (nonfinite)
                    boxes[6 * at + r.Below(6)] = new[] { double.NaN, double.PositiveInfinity, double.NegativeInfinity }[r.Below(3)];
                else
                    boxes[6 * at + axis] = boxes[6 * at + 3 + axis] + scale;
                ulong[] ids = SomeLive(r, model, n);
                var e = Assert.Throws<LocdException>(() => {
                    if (ids.Length == n && r.Below(2) == 0) {
                        if (f64) scene.Move(ids, boxes); else scene.Move(ids, ToF(boxes));
                    } else {
                        if (f64) scene.Add(boxes); else scene.Add(ToF(boxes));
                    }
                }, "bad box");
                Assert.Equal(nonfinite ? Status.NonFinite : Status.InvertedBox, e.Status, "status");
                Assert.Equal((long)at, e.Index, "index of the bad box");
                return 1;
            }
            default: { // an id twice in one batch
                ulong[] ids = SomeLive(r, model, 4);
                if (ids.Length == 0)
                    return 0;
                ulong[] batch = ids.Concat(new[] { ids[r.Below(ids.Length)] }).ToArray();
                var e = Assert.Throws<LocdException>(() => {
                    if (r.Below(2) == 0) scene.Remove(batch);
                    else scene.Move(batch, GridBoxes(r, batch.Length, scale));
                }, "duplicate id");
                ExpectBadId(e, Status.DuplicateId, batch.Length, model.Objects.Count);
                Assert.True(e.Status == Status.TooManyObjects || e.Index >= 0 && e.Index < batch.Length && batch.Count(id => id == batch[e.Index]) == 2,
                            "index " + e.Index + " names the duplicated id");
                return 1;
            }
            }
        }

        // A change (move, remove, filter, user values) naming more ids than the scene has objects
        // must repeat or name a stale id: the library refuses it before reading the ids, with
        // TooManyObjects and no index. Any other bad batch gives the status of its first bad
        // position, and names that position.
        static void ExpectBadId(LocdException e, Status status, int batch, int live)
        {
            if (batch > live) {
                Assert.Equal(Status.TooManyObjects, e.Status, "status of " + batch + " ids for " + live + " objects");
                Assert.Equal(-1L, e.Index, "no index for a batch longer than the scene");
            } else {
                Assert.Equal(status, e.Status, "status");
            }
        }

        // ------------------------------------------------------------------
        // Focused tests
        // ------------------------------------------------------------------

        static void StructSizes()
        {
            // The library writes its sizeof into `size`; the defaults land in the right fields.
            Native.locd_scene_config c;
            Native.locd_scene_config_init(&c);
            Assert.Equal((uint)sizeof(Native.locd_scene_config), c.size, "sizeof(locd_scene_config)");
            Native.locd_scene_add_options o;
            Native.locd_scene_add_options_init(&o);
            Assert.Equal((uint)sizeof(Native.locd_scene_add_options), o.size, "sizeof(locd_scene_add_options)");
            Assert.Equal(1UL, o.category, "default category");
            Assert.Equal(ulong.MaxValue, o.mask, "default mask");
            Assert.True(o.group == 0 && o.user == 0 && o.categories == IntPtr.Zero && o.users == IntPtr.Zero, "zero defaults");
            Native.locd_scene_stats st;
            Native.locd_scene_stats_init(&st);
            Assert.Equal((uint)sizeof(Native.locd_scene_stats), st.size, "sizeof(locd_scene_stats)");
        }

        static void ReadmeExample()
        {
            using (var scene = new Scene()) {
                ulong[] ids = scene.Add(new float[] { 0, 0, 0, 1, 1, 1,   1, 0, 0, 2, 1, 1,   5, 5, 5, 6, 6, 6 },
                                        new SceneAddOptions { Users = new ulong[] { 10, 11, 12 } });
                SceneUpdate r = scene.Update();
                SameIds(new[] { ids[0], ids[1] }, r.Pairs, "pairs");
                SameIds(r.Pairs, r.Created, "created at the first update");
                Assert.Equal(0, r.Lost.Length, "lost");
                Assert.Equal(11UL, scene.GetUser(ids[1]), "user value");
                scene.Remove(new[] { ids[0] });
                r = scene.Update();
                SameIds(new[] { ids[0], ids[1] }, r.Lost, "lost after remove");
                Assert.Equal(0, r.Pairs.Length, "pairs after remove");
                SameIds(new[] { ids[2] }, scene.QueryPoint(new float[] { 5, 5, 5 }), "point on a corner");
                double[] t;
                SameIds(new[] { ids[1], ids[2] }, scene.Raycast(new float[] { 1.5f, 0.5f, 0.5f }, new float[] { 1, 1, 1 }, 10, out t), "ray");
                Assert.Equal(0.0, t[0], "t inside");
                Assert.Equal(4.5, t[1], "t entering (the last slab entered: y and z at 4.5)");
                Assert.Equal(2L, scene.Count, "count");
            }
        }

        static void StaleIds()
        {
            using (var scene = new Scene(1)) {
                var seen = new HashSet<ulong>();
                ulong[] ids = null;
                for (int k = 0; k < 50; k++) {
                    ids = scene.Add(new float[18]);
                    foreach (ulong id in ids)
                        Assert.True(id != 0 && seen.Add(id), "id " + id + " never reused");
                    scene.Remove(ids);
                }
                ulong[] live = scene.Add(new float[18]);
                var e = Assert.Throws<LocdException>(() => scene.Move(new[] { live[0], live[1], ids[2] }, new float[18]), "removed id");
                Assert.Equal(Status.StaleId, e.Status, "status");
                Assert.Equal(2L, e.Index, "index");
                Assert.True(e.Message.Contains("(index 2)"), "message names the index: " + e.Message);
                e = Assert.Throws<LocdException>(() => scene.GetUser(0UL), "id 0");
                Assert.Equal(Status.StaleId, e.Status, "id 0 is never issued");
                e = Assert.Throws<LocdException>(() => scene.Remove(new[] { live[1], live[0], live[1] }), "duplicate");
                Assert.Equal(Status.DuplicateId, e.Status, "duplicate status");
                Assert.Equal(2L, e.Index, "index of the repeated id");
                // More ids than objects: refused before the ids are read, with no index.
                e = Assert.Throws<LocdException>(() => scene.Remove(new[] { live[0], live[1], live[2], ids[0] }), "4 ids, 3 objects");
                Assert.Equal(Status.TooManyObjects, e.Status, "a batch longer than the scene");
                Assert.Equal(-1L, e.Index, "no index");
                Assert.Equal(3L, scene.Count, "nothing removed");
            }
        }

        static void FailedBatchesChangeNothing()
        {
            using (var scene = new Scene()) {
                var box = new double[] { 0, 0, 0, 1, 1, 1 };
                var four = box.Concat(box).Concat(box).Concat(box).ToArray();
                ulong[] ids = scene.Add(four, new SceneAddOptions { User = 7 });
                ulong[] before = scene.Update().Pairs;
                var moved = four.Select(v => v + 5).ToArray();
                moved[6 * 2 + 4] = double.NaN;
                var e = Assert.Throws<LocdException>(() => scene.Move(ids, moved), "NaN in a move");
                Assert.Equal(2L, e.Index, "index of the NaN box");
                Assert.Throws<LocdException>(() => scene.SetFilter(new[] { ids[0], 999UL }, new ulong[2], null, null), "stale in a filter");
                Assert.Throws<LocdException>(() => scene.SetUser(new[] { ids[0], 999UL }, new ulong[] { 1, 2 }), "stale in set user");
                var bad = four.Concat(new double[] { 2, 0, 0, 1, 1, 1 }).ToArray();
                e = Assert.Throws<LocdException>(() => scene.Add(bad), "inverted box in an add");
                Assert.Equal(Status.InvertedBox, e.Status, "inverted status");
                Assert.Equal(4L, e.Index, "index of the inverted box");
                Assert.Equal(4L, scene.Count, "nothing added");
                SameIds(new ulong[] { 7, 7, 7, 7 }, scene.GetUser(ids), "users unchanged");
                SceneUpdate r = scene.Update();
                SameIds(before, r.Pairs, "pairs unchanged");
                Assert.Equal(0, r.Created.Length + r.Lost.Length, "no events");
                SameIds(ids.OrderBy(i => i).ToArray(), scene.QueryBox(new double[] { 0, 0, 0, 0, 0, 0 }), "boxes unchanged");
            }
        }

        static void OverloadsAgree()
        {
            var r = new Rng(99);
            var boxes = Scenes.Uniform(r, 400, 30, 3);
            using (var a = new Scene(2))
            using (var b = new Scene(2)) {
                ulong[] ia = a.Add(boxes);
                var ib = new ulong[400];
                fixed (float* p = boxes)
                fixed (ulong* q = ib)
                    b.Add(p, 400, q);
                SameIds(ia, ib, "ids of two fresh scenes");
                var moved = Scenes.Uniform(r, 100, 30, 3);
                var some = ia.Take(100).ToArray();
                a.Move(some, moved);
                fixed (ulong* q = some)
                fixed (float* p = moved)
                    b.Move(q, p, 100);
                a.Update();
                ulong[] pa = null, pb = null;
                int m = a.CopyPairs(ref pa);
                b.Update(SceneUpdateFlags.Pairs);
                long count;
                ulong* data = b.PairsData(out count);
                Assert.Equal((long)m, count, "pair counts");
                pb = new ulong[2 * count];
                for (long k = 0; k < 2 * count; k++)
                    pb[k] = data[k];
                SameIds(pa.Take(2 * m).ToArray(), pb, "pairs");
                long created;
                b.CreatedData(out created);
                Assert.Equal(0L, created, "no created list when only pairs were asked for");
                // The C# brute force over the boxes as they are now.
                var now = (float[])boxes.Clone();
                Array.Copy(moved, 0, now, 0, moved.Length);
                uint[] brute = Scenes.Brute(now);
                Assert.Equal(brute.Length / 2, m, "pairs equal the brute force count");
                // Queries: array and pointer forms.
                var q6 = new float[] { 10, 10, 10, 15, 15, 15 };
                ulong[] hits = a.QueryBox(q6);
                var buf = new ulong[hits.Length + 1];
                long got;
                fixed (float* qp = q6)
                fixed (ulong* bp = buf) {
                    got = b.QueryBox(qp, Scene.AllCategories, bp, buf.Length);
                    Assert.Equal((long)hits.Length, got, "hits in the pointer form");
                    if (hits.Length > 1)
                        Assert.Equal((long)hits.Length, b.QueryBox(qp, Scene.AllCategories, bp, 1), "count reported when too small");
                }
                SameIds(hits, buf.Take((int)got).ToArray(), "query box hits");
                SameIds(hits, a.QueryBox(q6.Select(v => (double)v).ToArray()), "float and double query");
                double[] t1, t2;
                ulong[] ray1 = a.Raycast(new float[] { -1, 15, 15 }, new float[] { 1, 0, 0 }, 40, out t1);
                ulong[] ray2 = b.Raycast(new double[] { -1, 15, 15 }, new double[] { 1, 0, 0 }, 40, out t2);
                SameIds(ray1, ray2, "ray hits");
                Assert.True(ray1.Length > 0 && t1.SequenceEqual(t2), "ray t");
            }
        }

        static void StaticsAndFilters()
        {
            using (var scene = new Scene()) {
                var zero = new float[24];
                ulong[] s = scene.Add(zero, new SceneAddOptions { Static = true });
                Assert.Equal(0, scene.Update().Pairs.Length, "statics never pair with each other");
                ulong[] d = scene.Add(new float[6]);
                Assert.Equal(8, scene.Update().Pairs.Length, "the dynamic object pairs with the 4 statics");
                Assert.Equal(4L, scene.Stats.StaticObjects, "stats: static objects");
                scene.SetFilter(d, null, new ulong[] { 0 }, null);
                SceneUpdate r = scene.Update();
                Assert.Equal(0, r.Pairs.Length, "mask 0: no pairs");
                Assert.Equal(8, r.Lost.Length, "their pairs are lost");
                scene.SetFilter(d, null, new[] { Scene.AllCategories }, new ulong[] { 3 });
                scene.SetFilter(s.Take(2).ToArray(), null, null, new ulong[] { 3, 3 });
                Assert.Equal(4, scene.Update().Pairs.Length, "same nonzero group: no pair");
                Assert.Equal(0, scene.QueryPoint(new float[] { 0, 0, 0 }, 2).Length, "mask 2 matches no category 1");
                Assert.Equal(5, scene.QueryPoint(new float[] { 0, 0, 0 }, 1).Length, "mask 1 matches all five");
            }
        }

        static void FloatAndDoubleMix()
        {
            using (var scene = new Scene()) {
                double tiny = Math.Pow(2, -40); // lost in float: the scene must keep doubles
                ulong[] a = scene.Add(new float[] { 0, 0, 0, 1, 1, 1 });
                ulong[] b = scene.Add(new double[] { 1 + tiny, 0, 0, 2, 1, 1 });
                Assert.Equal(0, scene.Update().Pairs.Length, "1 + 2^-40 does not touch 1");
                Assert.Equal(0, scene.QueryPoint(new double[] { 1 + tiny / 2, 0.5, 0.5 }).Length, "point between them");
                scene.Move(b, new float[] { 1, 0, 0, 2, 1, 1 });
                SameIds(new[] { a[0], b[0] }, scene.Update().Pairs, "touching after a float move");
                scene.Move(a, new double[] { 0, 0, 0, 1 - tiny, 1, 1 });
                Assert.Equal(2, scene.Update().Lost.Length, "apart again after a double move");
            }
        }

        static void Lifetime()
        {
            long live = SceneSafeHandle.Live;
            var engine = new Engine(1);
            var scene = new Scene(engine);
            ulong[] ids = scene.Add(new float[12]);
            engine.Dispose(); // the scene keeps the native engine alive
            Assert.Equal(2, scene.Update().Pairs.Length, "works after its Engine object is disposed");
            Assert.Equal(live + 1, SceneSafeHandle.Live, "one live scene");
            scene.Dispose();
            scene.Dispose();
            Assert.True(scene.IsDisposed, "disposed");
            Assert.Equal(live, SceneSafeHandle.Live, "released");
            Assert.Throws<ObjectDisposedException>(() => scene.Remove(ids), "use after dispose");
            // Finalizers release scenes nobody disposed.
            for (int k = 0; k < 200; k++)
                new Scene(1).Add(new float[6]);
            GC.Collect();
            GC.WaitForPendingFinalizers();
            GC.Collect();
            GC.WaitForPendingFinalizers();
            Assert.True(SceneSafeHandle.Live <= live + 1, "finalizers released the scenes (" + (SceneSafeHandle.Live - live) + " left)");
        }

        static void NoAllocation()
        {
            var r = new Rng(5);
            var boxes = Scenes.Uniform(r, 2000, 60, 3);
            using (var scene = new Scene()) {
                ulong[] ids = scene.Add(boxes);
                var moving = ids.Where((_, k) => k % 10 == 0).ToArray();
                var moved = new float[6 * moving.Length];
                ulong[] pairs = null, created = null, lost = null;
                var hits = new ulong[4096];
                scene.Update(SceneUpdateFlags.All);
                scene.CopyPairs(ref pairs);
                long before = GC.GetTotalMemory(true);
                int gen0 = GC.CollectionCount(0);
                long events = 0;
                fixed (ulong* mp = moving)
                fixed (float* bp = moved)
                fixed (ulong* hp = hits) {
                    var q = stackalloc float[6];
                    for (int frame = 0; frame < 200; frame++) {
                        for (int k = 0; k < moved.Length; k += 6)
                            for (int a = 0; a < 3; a++) {
                                float lo = (float)(r.Uniform() * 60);
                                moved[k + a] = lo;
                                moved[k + 3 + a] = lo + 2;
                            }
                        scene.Move(mp, bp, moving.Length);
                        scene.Update(SceneUpdateFlags.All);
                        scene.CopyPairs(ref pairs);
                        events += scene.CopyCreated(ref created) + scene.CopyLost(ref lost);
                        q[0] = q[1] = q[2] = 20;
                        q[3] = q[4] = q[5] = 25;
                        scene.QueryBox(q, Scene.AllCategories, hp, hits.Length);
                    }
                }
                long after = GC.GetTotalMemory(false);
                Console.WriteLine("         200 frames of 200 moves: managed heap {0} -> {1} B, gen0 collections {2}, {3} events",
                                  before, after, GC.CollectionCount(0) - gen0, events);
                Assert.True(after - before < 64 * 1024, "managed allocation over 200 frames: " + (after - before) + " B");
                Assert.True(events > 0, "events happened");
            }
        }
    }
}
