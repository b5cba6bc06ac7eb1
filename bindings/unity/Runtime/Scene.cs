// Safe layer over the persistent scene (include/locd/scene.h): objects under
// stable ulong ids, added, moved, removed and re-filtered in batches; Update
// gives every pair and the pairs created and lost since the previous update;
// box, point and ray-segment queries. Pair lists are ulong[] holding rows
// (first, second) interleaved, first < second, rows sorted ascending.
using System;
using System.Threading;

namespace Locd
{
    /// <summary>Owns a locd_scene * and keeps its engine alive until the scene is destroyed.</summary>
    public sealed class SceneSafeHandle : System.Runtime.InteropServices.SafeHandle
    {
        static long live;
        EngineSafeHandle engine;
        Engine ownedEngine;

        /// <summary>Scenes created and not yet destroyed (all threads).</summary>
        public static long Live { get { return Interlocked.Read(ref live); } }

        public SceneSafeHandle() : base(IntPtr.Zero, true) { }

        public override bool IsInvalid { get { return handle == IntPtr.Zero; } }

        // The caller holds a reference on `owner` (DangerousAddRef) taken for
        // this scene; it is given back after locd_scene_destroy, so the engine
        // is destroyed last even when both are finalized together. `owned` is
        // the engine the scene created for itself (disposed with it).
        internal void Own(IntPtr scene, EngineSafeHandle owner, Engine owned)
        {
            engine = owner;
            ownedEngine = owned;
            SetHandle(scene);
            Interlocked.Increment(ref live);
        }

        protected override bool ReleaseHandle()
        {
            Native.locd_scene_destroy(handle);
            Interlocked.Decrement(ref live);
            if (engine != null)
                engine.DangerousRelease();
            if (ownedEngine != null)
                ownedEngine.Dispose();
            return true;
        }
    }

    /// <summary>Per-object attributes of an added batch. For each attribute the
    /// array (one value per box) is used when it is not null, the scalar otherwise.</summary>
    public sealed class SceneAddOptions
    {
        /// <summary>The whole batch is static: static objects never pair with each other.</summary>
        public bool Static { get; set; }
        public ulong Category { get; set; }
        public ulong Mask { get; set; }
        /// <summary>Objects with the same nonzero group never pair.</summary>
        public ulong Group { get; set; }
        /// <summary>A value of the caller's (e.g. an index into its own arrays).</summary>
        public ulong User { get; set; }
        public ulong[] Categories { get; set; }
        public ulong[] Masks { get; set; }
        public ulong[] Groups { get; set; }
        public ulong[] Users { get; set; }

        public SceneAddOptions()
        {
            Category = 1;
            Mask = Scene.AllCategories;
        }
    }

    /// <summary>What Scene.Update found: pair rows (first, second) interleaved, sorted.</summary>
    public sealed class SceneUpdate
    {
        /// <summary>Every pair now.</summary>
        public ulong[] Pairs { get; internal set; }
        /// <summary>Pairs now that were not at the previous update (all of them at the first).</summary>
        public ulong[] Created { get; internal set; }
        /// <summary>Pairs at the previous update that are not now (removed objects' pairs included).</summary>
        public ulong[] Lost { get; internal set; }
    }

    /// <summary>Which lists Scene.Update(SceneUpdateFlags) fills.</summary>
    [Flags]
    public enum SceneUpdateFlags : uint
    {
        None = 0,
        Pairs = Native.LOCD_SCENE_UPDATE_PAIRS,
        Events = Native.LOCD_SCENE_UPDATE_EVENTS,
        All = Pairs | Events,
    }

    /// <summary>Statistics of a scene's last update (locd_scene_stats).</summary>
    public struct SceneStats
    {
        public readonly Native.locd_scene_stats Raw;

        public SceneStats(Native.locd_scene_stats raw) { Raw = raw; }

        public int Threads { get { return (int)Raw.threads; } }
        public long Objects { get { return (long)Raw.objects; } }
        public long StaticObjects { get { return (long)Raw.static_objects; } }
        /// <summary>Objects added, moved or re-filtered since the previous update.</summary>
        public long Moved { get { return (long)Raw.moved; } }
        public long Reencoded { get { return (long)Raw.reencoded; } }
        public long Entries { get { return (long)Raw.entries; } }
        public long Candidates { get { return (long)Raw.candidates; } }
        public long Pairs { get { return (long)Raw.pairs; } }
        public long Created { get { return (long)Raw.created; } }
        public long Lost { get { return (long)Raw.lost; } }
        public bool Rebuilt { get { return Raw.rebuilt != 0; } }
        /// <summary>Moved objects that stayed in their fat boxes and took their pairs from their partner lists.</summary>
        public long Coasted { get { return (long)Raw.coasted; } }
        public double MsTotal { get { return Raw.ms_total; } }
        public double MsEncode { get { return Raw.ms_encode; } }
        public double MsMerge { get { return Raw.ms_merge; } }
        public double MsSweep { get { return Raw.ms_sweep; } }
        public double MsEvents { get { return Raw.ms_events; } }

        public override string ToString()
        {
            return string.Format("objects={0} moved={1} pairs={2} created={3} lost={4} total={5:F3}ms",
                                 Objects, Moved, Pairs, Created, Lost, MsTotal);
        }
    }

    /// <summary>
    /// A persistent scene of boxes with stable ulong ids (never 0, never reused).
    /// A pair (a, b) is reported iff the boxes overlap (closed intervals),
    /// (category_a &amp; mask_b) != 0 and (category_b &amp; mask_a) != 0, not
    /// group_a == group_b != 0, and not both objects are static.
    /// A call that fails throws LocdException (StaleId, DuplicateId, NonFinite,
    /// InvertedBox; Index names the position in the batch) and changes nothing.
    /// Calls from several threads are serialized. Dispose it (or let the
    /// finalizer do it) to free it.
    /// </summary>
    public sealed unsafe partial class Scene : IDisposable
    {
        /// <summary>A mask with every category bit set.</summary>
        public const ulong AllCategories = ulong.MaxValue;

        readonly SceneSafeHandle handle = new SceneSafeHandle();
        readonly object sync = new object();

        /// <summary>A scene on an engine of its own (level 1) with the given threads (0 = one per core).</summary>
        public Scene(int threads = 0, long capacityHint = 0)
        {
            var engine = new Engine(threads);
            try {
                Create(engine.SafeHandle, engine, capacityHint);
            } catch {
                engine.Dispose();
                throw;
            }
        }

        /// <summary>A scene on the caller's engine (level 1), which it keeps alive. While the
        /// scene updates, that engine is busy (a find on it from another thread fails with Busy).</summary>
        public Scene(Engine engine, long capacityHint = 0)
        {
            if (engine == null)
                throw new ArgumentNullException("engine");
            Create(engine.SafeHandle, null, capacityHint);
        }

        void Create(EngineSafeHandle engine, Engine owned, long capacityHint)
        {
            if (capacityHint < 0)
                throw new ArgumentOutOfRangeException("capacityHint");
            bool added = false;
            try {
                // This reference belongs to the scene from here on (SceneSafeHandle.ReleaseHandle).
                engine.DangerousAddRef(ref added);
                Native.locd_scene_config cfg;
                Native.locd_scene_config_init(&cfg);
                cfg.capacity_hint = (ulong)capacityHint;
                IntPtr s;
                int st = Native.locd_scene_create(engine.DangerousGetHandle(), &cfg, &s);
                if (st != Native.LOCD_OK)
                    throw LocdException.FromLastError(st);
                handle.Own(s, engine, owned);
                added = false;
            } finally {
                if (added) engine.DangerousRelease();
            }
        }

        /// <summary>The native handle (for the raw layer). Valid until Dispose.</summary>
        public IntPtr NativeHandle { get { return handle.DangerousGetHandle(); } }

        public SceneSafeHandle SafeHandle { get { return handle; } }

        public bool IsDisposed { get { return handle.IsClosed; } }

        public void Dispose()
        {
            lock (sync)
                handle.Dispose();
        }

        // Every call holds the lock and a reference on the handle (HeldHandle).
        HeldHandle Call() { return new HeldHandle(sync, handle); }

        static void Throw(int st)
        {
            if (st != Native.LOCD_OK)
                throw LocdException.FromLastError(st);
        }

        /// <summary>Objects in the scene now (static ones included).</summary>
        public long Count
        {
            get {
                using (var call = Call())
                    return (long)(ulong)Native.locd_scene_count(call.Handle);
            }
        }

        /// <summary>Statistics of the last update.</summary>
        public SceneStats Stats
        {
            get {
                Native.locd_scene_stats stats;
                Native.locd_scene_stats_init(&stats);
                int st;
                using (var call = Call())
                    st = Native.locd_scene_get_stats(call.Handle, &stats);
                Throw(st);
                return new SceneStats(stats);
            }
        }

        // ---------------------------------------------------------------
        // Changes, in batches
        // ---------------------------------------------------------------

        /// <summary>Adds boxes.Length / 6 boxes; returns their new ids.</summary>
        public ulong[] Add(float[] boxes, SceneAddOptions options = null)
        {
            long n = RowCount(boxes == null ? -1 : boxes.Length, "boxes");
            var ids = new ulong[n];
            fixed (float* b = boxes)
            fixed (ulong* i = ids)
                AddRaw(b, null, n, i, options);
            return ids;
        }

        public ulong[] Add(double[] boxes, SceneAddOptions options = null)
        {
            long n = RowCount(boxes == null ? -1 : boxes.Length, "boxes");
            var ids = new ulong[n];
            fixed (double* b = boxes)
            fixed (ulong* i = ids)
                AddRaw(null, b, n, i, options);
            return ids;
        }

        /// <summary>Adds boxCount boxes (boxCount * 6 values) and writes their ids to idsOut (no allocation).</summary>
        public void Add(float* boxes, long boxCount, ulong* idsOut, SceneAddOptions options = null)
        {
            AddRaw(boxes, null, CheckCount(boxCount), idsOut, options);
        }

        public void Add(double* boxes, long boxCount, ulong* idsOut, SceneAddOptions options = null)
        {
            AddRaw(null, boxes, CheckCount(boxCount), idsOut, options);
        }

        void AddRaw(float* f, double* d, long n, ulong* ids, SceneAddOptions o)
        {
            Native.locd_scene_add_options opt;
            Native.locd_scene_add_options_init(&opt);
            if (o != null) {
                CheckLength(o.Categories, n, "Categories");
                CheckLength(o.Masks, n, "Masks");
                CheckLength(o.Groups, n, "Groups");
                CheckLength(o.Users, n, "Users");
                opt.flags = o.Static ? Native.LOCD_OBJECT_STATIC : 0u;
                opt.category = o.Category;
                opt.mask = o.Mask;
                opt.group = o.Group;
                opt.user = o.User;
            }
            fixed (ulong* c = o == null ? null : o.Categories)
            fixed (ulong* m = o == null ? null : o.Masks)
            fixed (ulong* g = o == null ? null : o.Groups)
            fixed (ulong* u = o == null ? null : o.Users) {
                opt.categories = (IntPtr)c;
                opt.masks = (IntPtr)m;
                opt.groups = (IntPtr)g;
                opt.users = (IntPtr)u;
                int st;
                using (var call = Call())
                    st = f != null || d == null
                        ? Native.locd_scene_add_f32(call.Handle, f, (UIntPtr)(ulong)n, &opt, ids)
                        : Native.locd_scene_add_f64(call.Handle, d, (UIntPtr)(ulong)n, &opt, ids);
                Throw(st);
            }
        }

        /// <summary>Gives object ids[k] the box boxes[6k .. 6k+5].</summary>
        public void Move(ulong[] ids, float[] boxes)
        {
            long n = IdCount(ids);
            CheckBoxes(boxes == null ? -1 : boxes.Length, n);
            fixed (ulong* i = ids)
            fixed (float* b = boxes)
                Move(i, b, n);
        }

        public void Move(ulong[] ids, double[] boxes)
        {
            long n = IdCount(ids);
            CheckBoxes(boxes == null ? -1 : boxes.Length, n);
            fixed (ulong* i = ids)
            fixed (double* b = boxes)
                Move(i, b, n);
        }

        public void Move(ulong* ids, float* boxes, long count)
        {
            CheckCount(count);
            int st;
            using (var call = Call())
                st = Native.locd_scene_move_f32(call.Handle, ids, boxes, (UIntPtr)(ulong)count);
            Throw(st);
        }

        public void Move(ulong* ids, double* boxes, long count)
        {
            CheckCount(count);
            int st;
            using (var call = Call())
                st = Native.locd_scene_move_f64(call.Handle, ids, boxes, (UIntPtr)(ulong)count);
            Throw(st);
        }

        /// <summary>Removes the objects; their pairs are lost pairs at the next update.</summary>
        public void Remove(ulong[] ids)
        {
            long n = IdCount(ids);
            fixed (ulong* i = ids)
                Remove(i, n);
        }

        public void Remove(ulong* ids, long count)
        {
            CheckCount(count);
            int st;
            using (var call = Call())
                st = Native.locd_scene_remove(call.Handle, ids, (UIntPtr)(ulong)count);
            Throw(st);
        }

        /// <summary>Sets category, mask and/or group of the objects: each array holds one value
        /// per id, or is null to keep that attribute.</summary>
        public void SetFilter(ulong[] ids, ulong[] categories, ulong[] masks, ulong[] groups)
        {
            long n = IdCount(ids);
            CheckLength(categories, n, "categories");
            CheckLength(masks, n, "masks");
            CheckLength(groups, n, "groups");
            fixed (ulong* i = ids)
            fixed (ulong* c = categories)
            fixed (ulong* m = masks)
            fixed (ulong* g = groups)
                SetFilter(i, n, c, m, g);
        }

        public void SetFilter(ulong* ids, long count, ulong* categories, ulong* masks, ulong* groups)
        {
            CheckCount(count);
            int st;
            using (var call = Call())
                st = Native.locd_scene_set_filter(call.Handle, ids, (UIntPtr)(ulong)count, categories, masks, groups);
            Throw(st);
        }

        /// <summary>Sets the user values of the objects (one per id).</summary>
        public void SetUser(ulong[] ids, ulong[] users)
        {
            long n = IdCount(ids);
            CheckLength(users, n, "users");
            if (users == null)
                throw new ArgumentNullException("users");
            fixed (ulong* i = ids)
            fixed (ulong* u = users)
                SetUser(i, u, n);
        }

        public void SetUser(ulong* ids, ulong* users, long count)
        {
            CheckCount(count);
            int st;
            using (var call = Call())
                st = Native.locd_scene_set_user(call.Handle, ids, (UIntPtr)(ulong)count, users);
            Throw(st);
        }

        /// <summary>The user values of the objects.</summary>
        public ulong[] GetUser(ulong[] ids)
        {
            long n = IdCount(ids);
            var users = new ulong[n];
            fixed (ulong* i = ids)
            fixed (ulong* u = users)
                GetUser(i, u, n);
            return users;
        }

        /// <summary>The user value of one object.</summary>
        public ulong GetUser(ulong id)
        {
            ulong u;
            GetUser(&id, &u, 1);
            return u;
        }

        public void GetUser(ulong* ids, ulong* usersOut, long count)
        {
            CheckCount(count);
            int st;
            using (var call = Call())
                st = Native.locd_scene_get_user(call.Handle, ids, (UIntPtr)(ulong)count, usersOut);
            Throw(st);
        }

        // ---------------------------------------------------------------
        // Update
        // ---------------------------------------------------------------

        /// <summary>Brings the pairs up to date and returns every pair and the created and lost
        /// ones as new arrays. In a game loop prefer Update(flags) and the Copy* calls.</summary>
        public SceneUpdate Update()
        {
            lock (sync) {
                Update(SceneUpdateFlags.All);
                var r = new SceneUpdate();
                ulong[] a = null;
                CopyList(0, ref a, true);
                r.Pairs = a;
                a = null;
                CopyList(1, ref a, true);
                r.Created = a;
                a = null;
                CopyList(2, ref a, true);
                r.Lost = a;
                return r;
            }
        }

        /// <summary>Brings the pairs up to date, filling the lists asked for (no allocation);
        /// read them with CopyPairs/CopyCreated/CopyLost or the pointer accessors.</summary>
        public void Update(SceneUpdateFlags flags)
        {
            int st;
            using (var call = Call())
                st = Native.locd_scene_update(call.Handle, (uint)flags);
            Throw(st);
        }

        /// <summary>Copies the pairs of the last update into dest (grown x1.5 when too small);
        /// returns the number of pairs (dest holds 2 * that many ids).</summary>
        public int CopyPairs(ref ulong[] dest) { return CopyList(0, ref dest, false); }

        public int CopyCreated(ref ulong[] dest) { return CopyList(1, ref dest, false); }

        public int CopyLost(ref ulong[] dest) { return CopyList(2, ref dest, false); }

        /// <summary>The scene's own list of the last update: 2 * count ids, valid until the
        /// scene's next change or update (and while the scene is not disposed).</summary>
        public ulong* PairsData(out long count) { return ListData(0, out count); }

        public ulong* CreatedData(out long count) { return ListData(1, out count); }

        public ulong* LostData(out long count) { return ListData(2, out count); }

        ulong* ListData(int which, out long count)
        {
            ulong* data = null;
            UIntPtr n = UIntPtr.Zero;
            int st;
            using (var call = Call())
                st = which == 0 ? Native.locd_scene_pairs(call.Handle, &data, &n)
                   : which == 1 ? Native.locd_scene_created(call.Handle, &data, &n)
                   : Native.locd_scene_lost(call.Handle, &data, &n);
            Throw(st);
            count = (long)(ulong)n;
            return data;
        }

        int CopyList(int which, ref ulong[] dest, bool exact)
        {
            lock (sync) {
                long m;
                ulong* src = ListData(which, out m);
                long values = checked(2 * m);
                if (exact)
                    dest = new ulong[values];
                else if (dest == null || dest.Length < values)
                    dest = new ulong[Math.Max(values + values / 2, 32)];
                if (m > 0)
                    fixed (ulong* d = dest)
                        Buffer.MemoryCopy(src, d, dest.Length * 8L, values * 8L);
                return checked((int)m);
            }
        }

        // ---------------------------------------------------------------
        // Queries: ids ascending (raycast: by t, then id), objects whose
        // category has a bit in mask.
        // ---------------------------------------------------------------

        /// <summary>Objects whose box overlaps box (6 values; closed intervals).</summary>
        public ulong[] QueryBox(float[] box, ulong mask = AllCategories)
        {
            CheckShape(box == null ? -1 : box.Length, 6, "box");
            fixed (float* q = box)
                return QueryArray(0, q, null, mask);
        }

        public ulong[] QueryBox(double[] box, ulong mask = AllCategories)
        {
            CheckShape(box == null ? -1 : box.Length, 6, "box");
            fixed (double* q = box)
                return QueryArray(0, null, q, mask);
        }

        /// <summary>Objects whose box contains the point (3 values; faces, edges and corners count).</summary>
        public ulong[] QueryPoint(float[] point, ulong mask = AllCategories)
        {
            CheckShape(point == null ? -1 : point.Length, 3, "point");
            fixed (float* q = point)
                return QueryArray(1, q, null, mask);
        }

        public ulong[] QueryPoint(double[] point, ulong mask = AllCategories)
        {
            CheckShape(point == null ? -1 : point.Length, 3, "point");
            fixed (double* q = point)
                return QueryArray(1, null, q, mask);
        }

        /// <summary>Pointer form: at most capacity ids into idsOut. Returns the number of hits;
        /// when it exceeds capacity nothing was written (call again with a larger buffer).</summary>
        public long QueryBox(float* box, ulong mask, ulong* idsOut, long capacity)
        {
            return QueryRaw(0, box, null, mask, idsOut, capacity);
        }

        public long QueryBox(double* box, ulong mask, ulong* idsOut, long capacity)
        {
            return QueryRaw(0, null, box, mask, idsOut, capacity);
        }

        public long QueryPoint(float* point, ulong mask, ulong* idsOut, long capacity)
        {
            return QueryRaw(1, point, null, mask, idsOut, capacity);
        }

        public long QueryPoint(double* point, ulong mask, ulong* idsOut, long capacity)
        {
            return QueryRaw(1, null, point, mask, idsOut, capacity);
        }

        /// <summary>Objects whose box meets the segment origin + t * direction, 0 &lt;= t &lt;= maxT
        /// (direction need not be unit length). t receives each hit's entry parameter
        /// (0 when the origin is inside the box); hits are sorted by t, then id.</summary>
        public ulong[] Raycast(float[] origin, float[] direction, double maxT, out double[] t,
                               ulong mask = AllCategories)
        {
            CheckShape(origin == null ? -1 : origin.Length, 3, "origin");
            CheckShape(direction == null ? -1 : direction.Length, 3, "direction");
            fixed (float* o = origin)
            fixed (float* d = direction)
                return RaycastArray(o, d, null, null, maxT, mask, out t);
        }

        public ulong[] Raycast(double[] origin, double[] direction, double maxT, out double[] t,
                               ulong mask = AllCategories)
        {
            CheckShape(origin == null ? -1 : origin.Length, 3, "origin");
            CheckShape(direction == null ? -1 : direction.Length, 3, "direction");
            fixed (double* o = origin)
            fixed (double* d = direction)
                return RaycastArray(null, null, o, d, maxT, mask, out t);
        }

        /// <summary>Pointer form; returns the number of hits (nothing written when it exceeds capacity).</summary>
        public long Raycast(float* origin, float* direction, double maxT, ulong mask, ulong* idsOut, double* tOut,
                            long capacity)
        {
            return RaycastRaw(origin, direction, null, null, maxT, mask, idsOut, tOut, capacity);
        }

        public long Raycast(double* origin, double* direction, double maxT, ulong mask, ulong* idsOut, double* tOut,
                            long capacity)
        {
            return RaycastRaw(null, null, origin, direction, maxT, mask, idsOut, tOut, capacity);
        }

        long QueryRaw(int kind, float* f, double* d, ulong mask, ulong* ids, long capacity)
        {
            if (capacity < 0)
                throw new ArgumentOutOfRangeException("capacity");
            UIntPtr n = UIntPtr.Zero;
            int st;
            using (var call = Call()) {
                var cap = (UIntPtr)(ulong)capacity;
                if (kind == 0)
                    st = f != null || d == null ? Native.locd_scene_query_box_f32(call.Handle, f, mask, ids, cap, &n)
                                                : Native.locd_scene_query_box_f64(call.Handle, d, mask, ids, cap, &n);
                else
                    st = f != null || d == null ? Native.locd_scene_query_point_f32(call.Handle, f, mask, ids, cap, &n)
                                                : Native.locd_scene_query_point_f64(call.Handle, d, mask, ids, cap, &n);
            }
            if (st != Native.LOCD_OK && st != (int)Status.BufferTooSmall)
                throw LocdException.FromLastError(st, "query");
            return (long)(ulong)n;
        }

        ulong[] QueryArray(int kind, float* f, double* d, ulong mask)
        {
            lock (sync) { // the scene cannot change between the two calls
                var ids = new ulong[64];
                for (;;) {
                    long m;
                    fixed (ulong* p = ids)
                        m = QueryRaw(kind, f, d, mask, p, ids.Length);
                    if (m <= ids.Length) {
                        Array.Resize(ref ids, (int)m);
                        return ids;
                    }
                    ids = new ulong[m];
                }
            }
        }

        long RaycastRaw(float* of, float* df, double* od, double* dd, double maxT, ulong mask, ulong* ids, double* t,
                        long capacity)
        {
            if (capacity < 0)
                throw new ArgumentOutOfRangeException("capacity");
            UIntPtr n = UIntPtr.Zero;
            int st;
            using (var call = Call()) {
                var cap = (UIntPtr)(ulong)capacity;
                st = of != null || od == null
                    ? Native.locd_scene_raycast_f32(call.Handle, of, df, maxT, mask, ids, t, cap, &n)
                    : Native.locd_scene_raycast_f64(call.Handle, od, dd, maxT, mask, ids, t, cap, &n);
            }
            if (st != Native.LOCD_OK && st != (int)Status.BufferTooSmall)
                throw LocdException.FromLastError(st, "query");
            return (long)(ulong)n;
        }

        ulong[] RaycastArray(float* of, float* df, double* od, double* dd, double maxT, ulong mask, out double[] t)
        {
            lock (sync) {
                var ids = new ulong[64];
                var ts = new double[64];
                for (;;) {
                    long m;
                    fixed (ulong* p = ids)
                    fixed (double* q = ts)
                        m = RaycastRaw(of, df, od, dd, maxT, mask, p, q, ids.Length);
                    if (m <= ids.Length) {
                        Array.Resize(ref ids, (int)m);
                        Array.Resize(ref ts, (int)m);
                        t = ts;
                        return ids;
                    }
                    ids = new ulong[m];
                    ts = new double[m];
                }
            }
        }

        // ---------------------------------------------------------------
        // Argument checks (managed mistakes are ArgumentExceptions; the
        // library's own checks are LocdExceptions naming the index)
        // ---------------------------------------------------------------

        static long RowCount(int length, string name)
        {
            if (length < 0)
                throw new ArgumentNullException(name);
            if (length % 6 != 0)
                throw new ArgumentException(name + " must hold 6 values per box (minx miny minz maxx maxy maxz); got "
                                            + length + " values", name);
            return length / 6;
        }

        static long IdCount(ulong[] ids)
        {
            if (ids == null)
                throw new ArgumentNullException("ids");
            return ids.Length;
        }

        static void CheckBoxes(int length, long ids)
        {
            if (RowCount(length, "boxes") != ids)
                throw new ArgumentException("boxes holds " + (length / 6) + " boxes for " + ids + " ids", "boxes");
        }

        static void CheckLength(ulong[] values, long n, string name)
        {
            if (values != null && values.Length != n)
                throw new ArgumentException(name + " holds " + values.Length + " values for " + n + " objects", name);
        }

        static void CheckShape(int length, int want, string name)
        {
            if (length < 0)
                throw new ArgumentNullException(name);
            if (length != want)
                throw new ArgumentException(name + " must hold " + want + " values, got " + length, name);
        }

        static long CheckCount(long count)
        {
            if (count < 0)
                throw new ArgumentOutOfRangeException("count");
            return count;
        }
    }
}
