// The scene's queries of every kind and mode (include/locd/scene.h, docs/queries.md): spheres, ray and
// box casts with a hit mode, a reject callback, and batches on the scene's engine threads into a
// QueryHits buffer (arrays, spans, or pointers for Unity's NativeArray: NativeArrayUnsafeUtility's
// GetUnsafeReadOnlyPtr). Casts return every hit sorted by (t, id), or the closest, or any one.
//
// The span forms need System.Span in the core library: .NET Core and .NET 5+, Mono 6 (Debian 12's
// 6.8 runs the tests), Unity 2021.2+ (.NET Standard 2.1 APIs); Unity before 2021.2 leaves them out.
#if !UNITY_5_3_OR_NEWER || UNITY_2021_2_OR_NEWER
#define LOCD_SPAN
#endif
using System;
using System.Runtime.InteropServices;

namespace Locd
{
    /// <summary>Which hits of a cast: every one sorted by (t, id); the closest (smallest (t, id)); any one
    /// (the first found: a line of sight).</summary>
    public enum HitMode
    {
        All = 0,
        Closest = 1,
        Any = 2,
    }

    /// <summary>Owns a locd_hits * (the hits of a batch).</summary>
    public sealed class HitsSafeHandle : SafeHandle
    {
        public HitsSafeHandle() : base(IntPtr.Zero, true) { }

        public override bool IsInvalid { get { return handle == IntPtr.Zero; } }

        public static unsafe HitsSafeHandle Create()
        {
            var h = new HitsSafeHandle();
            IntPtr p;
            LocdException.Check(Native.locd_hits_create(null, &p));
            h.SetHandle(p);
            return h;
        }

        protected override bool ReleaseHandle()
        {
            Native.locd_hits_destroy(handle);
            return true;
        }
    }

    /// <summary>The hits of a batch: query k's ids are Ids[Offsets[k] .. Offsets[k + 1]) (and their entry
    /// times T, for casts). With HitMode.Closest or Any every query has one entry (Offsets[k] = k): 0 and
    /// +inf when it hit nothing. Reused by each batch given it; the pointers hold until the next one.
    /// A failed batch leaves it empty (Queries and Count 0). One batch at a time may fill it.</summary>
    public sealed unsafe class QueryHits : IDisposable
    {
        internal readonly HitsSafeHandle handle = HitsSafeHandle.Create();

        public void Dispose() { handle.Dispose(); }

        public bool IsDisposed { get { return handle.IsClosed; } }

        IntPtr Raw
        {
            get {
                if (handle.IsClosed) // the native buffer is freed: reading it would be a use after free
                    throw new ObjectDisposedException("QueryHits");
                return handle.DangerousGetHandle();
            }
        }

        public long Queries { get { return (long)(ulong)Native.locd_hits_queries(Raw); } }
        public long Count { get { return (long)(ulong)Native.locd_hits_count(Raw); } }
        /// <summary>Queries + 1 offsets (native memory, valid until the next batch).</summary>
        public ulong* Offsets { get { return Native.locd_hits_offsets(Raw); } }
        public ulong* Ids { get { return Native.locd_hits_ids(Raw); } }
        /// <summary>The entry times (casts); null after an overlap batch.</summary>
        public double* T { get { return Native.locd_hits_t(Raw); } }

        public long[] OffsetsArray()
        {
            var a = new long[Queries + 1];
            ulong* o = Offsets; // NULL before the first batch: then Queries is 0 and a is { 0 }
            for (long k = 0; o != null && k < a.Length; k++)
                a[k] = (long)o[k];
            return a;
        }

        public ulong[] IdsArray()
        {
            var a = new ulong[Count];
            ulong* ids = Ids;
            for (long k = 0; k < a.Length; k++)
                a[k] = ids[k];
            return a;
        }

        /// <summary>The entry times (casts); empty after an overlap batch.</summary>
        public double[] TArray()
        {
            double* t = T;
            var a = new double[t == null ? 0 : Count];
            for (long k = 0; k < a.Length; k++)
                a[k] = t[k];
            return a;
        }
    }

    public sealed unsafe partial class Scene
    {
        /// <summary>Brings the scene's query tree up to date now (the first query after a change does it
        /// otherwise), on the calling thread.</summary>
        public void PrepareQueries()
        {
            using (var call = Call())
                Throw(Native.locd_scene_prepare_queries(call.Handle));
        }

        // ---- one query ----

        /// <summary>Objects whose box lies within radius of center (ids ascending).</summary>
        public ulong[] QuerySphere(double[] center, double radius, ulong mask = AllCategories,
                                   Native.locd_query_reject_fn reject = null)
        {
            CheckShape(center == null ? -1 : center.Length, 3, "center");
            fixed (double* c = center)
                return Hits(2, c, null, radius, 0, HitMode.All, mask, reject, out double[] unused);
        }

        /// <summary>A ray's hits: every one sorted by (t, id), the closest, or any one (mode); t their
        /// entry times along origin + t * direction, 0 &lt;= t &lt;= maxT.</summary>
        public ulong[] CastRay(double[] origin, double[] direction, double maxT, HitMode mode, out double[] t,
                               ulong mask = AllCategories, Native.locd_query_reject_fn reject = null)
        {
            CheckShape(origin == null ? -1 : origin.Length, 3, "origin");
            CheckShape(direction == null ? -1 : direction.Length, 3, "direction");
            fixed (double* o = origin)
            fixed (double* d = direction)
                return Hits(3, o, d, 0, maxT, mode, mask, reject, out t);
        }

        /// <summary>The box moved to box + t * direction, 0 &lt;= t &lt;= maxT: the objects it meets and
        /// their first touch t.</summary>
        public ulong[] SweepBox(double[] box, double[] direction, double maxT, HitMode mode, out double[] t,
                                ulong mask = AllCategories, Native.locd_query_reject_fn reject = null)
        {
            CheckShape(box == null ? -1 : box.Length, 6, "box");
            CheckShape(direction == null ? -1 : direction.Length, 3, "direction");
            fixed (double* b = box)
            fixed (double* d = direction)
                return Hits(4, b, d, 0, maxT, mode, mask, reject, out t);
        }

        /// <summary>kind 2 sphere, 3 ray, 4 box cast: the hits, retried with the size the library reports
        /// until they fit (the scene cannot change meanwhile: the lock is held).</summary>
        ulong[] Hits(int kind, double* v, double* d, double radius, double maxT, HitMode mode, ulong mask,
                     Native.locd_query_reject_fn reject, out double[] t)
        {
            var f = Filter(mask, reject);
            lock (sync) {
                var ids = new ulong[64];
                var ts = new double[64];
                for (;;) {
                    UIntPtr n = UIntPtr.Zero;
                    int st;
                    using (var call = Call())
                    fixed (ulong* p = ids)
                    fixed (double* q = ts) {
                        var cap = (UIntPtr)(ulong)ids.Length;
                        if (kind == 2)
                            st = Native.locd_scene_overlap_sphere_f64(call.Handle, v, radius, &f, p, cap, &n);
                        else if (kind == 3)
                            st = Native.locd_scene_cast_ray_f64(call.Handle, v, d, maxT, (uint)mode, &f, p, q, cap, &n);
                        else
                            st = Native.locd_scene_cast_box_f64(call.Handle, v, d, maxT, (uint)mode, &f, p, q, cap, &n);
                    }
                    GC.KeepAlive(reject);
                    if (st != Native.LOCD_OK && st != (int)Status.BufferTooSmall)
                        throw LocdException.FromLastError(st, "query");
                    long m = (long)(ulong)n;
                    if (m <= ids.Length) {
                        Array.Resize(ref ids, (int)m);
                        Array.Resize(ref ts, kind == 2 ? 0 : (int)m);
                        t = ts;
                        return ids;
                    }
                    ids = new ulong[m];
                    ts = new double[m];
                }
            }
        }

        static Native.locd_query_filter Filter(ulong mask, Native.locd_query_reject_fn reject)
        {
            Native.locd_query_filter f;
            Native.locd_query_filter_init(&f);
            f.mask = mask;
            if (reject != null)
                f.reject = Marshal.GetFunctionPointerForDelegate(reject);
            return f;
        }

        // ---- batches ----

        /// <summary>n rays (origins, directions: 3 floats each; maxT: n values) on the engine's threads
        /// into hits.</summary>
        public void RaycastBatch(float[] origins, float[] directions, double[] maxT, HitMode mode, QueryHits hits,
                                 ulong mask = AllCategories, Native.locd_query_reject_fn reject = null)
        {
            long n = Rows(origins, 3, "origins");
            CheckRows(directions, 3, n, "directions");
            CheckRows(maxT, 1, n, "maxT");
            fixed (float* o = origins)
            fixed (float* d = directions)
            fixed (double* m = maxT)
                RaycastBatch(o, d, m, n, mode, hits, mask, reject);
        }

        /// <summary>Pointer form (a NativeArray's memory): n rays.</summary>
        public void RaycastBatch(float* origins, float* directions, double* maxT, long n, HitMode mode,
                                 QueryHits hits, ulong mask = AllCategories, Native.locd_query_reject_fn reject = null)
        {
            Batch(0, origins, directions, maxT, n, mode, hits, mask, reject);
        }

#if LOCD_SPAN
        /// <summary>Span form (a slice of an array, stackalloc memory; nothing is copied): n rays.</summary>
        public void RaycastBatch(ReadOnlySpan<float> origins, ReadOnlySpan<float> directions, ReadOnlySpan<double> maxT,
                                 HitMode mode, QueryHits hits, ulong mask = AllCategories,
                                 Native.locd_query_reject_fn reject = null)
        {
            SpanBatch(0, origins, 3, "origins", directions, maxT, "maxT", mode, hits, mask, reject);
        }
#endif

        /// <summary>n boxes (6 floats each) moved by directions (3 each) to maxT (n values).</summary>
        public void SweepBoxBatch(float[] boxes, float[] directions, double[] maxT, HitMode mode, QueryHits hits,
                                  ulong mask = AllCategories, Native.locd_query_reject_fn reject = null)
        {
            long n = Rows(boxes, 6, "boxes");
            CheckRows(directions, 3, n, "directions");
            CheckRows(maxT, 1, n, "maxT");
            fixed (float* b = boxes)
            fixed (float* d = directions)
            fixed (double* m = maxT)
                SweepBoxBatch(b, d, m, n, mode, hits, mask, reject);
        }

        public void SweepBoxBatch(float* boxes, float* directions, double* maxT, long n, HitMode mode,
                                  QueryHits hits, ulong mask = AllCategories, Native.locd_query_reject_fn reject = null)
        {
            Batch(1, boxes, directions, maxT, n, mode, hits, mask, reject);
        }

#if LOCD_SPAN
        public void SweepBoxBatch(ReadOnlySpan<float> boxes, ReadOnlySpan<float> directions, ReadOnlySpan<double> maxT,
                                  HitMode mode, QueryHits hits, ulong mask = AllCategories,
                                  Native.locd_query_reject_fn reject = null)
        {
            SpanBatch(1, boxes, 6, "boxes", directions, maxT, "maxT", mode, hits, mask, reject);
        }
#endif

        /// <summary>n box queries (6 floats each): each query's ids ascending.</summary>
        public void QueryBoxBatch(float[] boxes, QueryHits hits, ulong mask = AllCategories,
                                  Native.locd_query_reject_fn reject = null)
        {
            long n = Rows(boxes, 6, "boxes");
            fixed (float* b = boxes)
                QueryBoxBatch(b, n, hits, mask, reject);
        }

        public void QueryBoxBatch(float* boxes, long n, QueryHits hits, ulong mask = AllCategories,
                                  Native.locd_query_reject_fn reject = null)
        {
            Batch(2, boxes, null, null, n, HitMode.All, hits, mask, reject);
        }

#if LOCD_SPAN
        public void QueryBoxBatch(ReadOnlySpan<float> boxes, QueryHits hits, ulong mask = AllCategories,
                                  Native.locd_query_reject_fn reject = null)
        {
            SpanBatch(2, boxes, 6, "boxes", default(ReadOnlySpan<float>), default(ReadOnlySpan<double>), null,
                      HitMode.All, hits, mask, reject);
        }
#endif

        /// <summary>n point queries (3 floats each): the objects whose box contains each point (a point on
        /// a face, edge or corner is inside), ids ascending.</summary>
        public void QueryPointBatch(float[] points, QueryHits hits, ulong mask = AllCategories,
                                    Native.locd_query_reject_fn reject = null)
        {
            long n = Rows(points, 3, "points");
            fixed (float* p = points)
                QueryPointBatch(p, n, hits, mask, reject);
        }

        public void QueryPointBatch(float* points, long n, QueryHits hits, ulong mask = AllCategories,
                                    Native.locd_query_reject_fn reject = null)
        {
            Batch(4, points, null, null, n, HitMode.All, hits, mask, reject);
        }

#if LOCD_SPAN
        public void QueryPointBatch(ReadOnlySpan<float> points, QueryHits hits, ulong mask = AllCategories,
                                    Native.locd_query_reject_fn reject = null)
        {
            SpanBatch(4, points, 3, "points", default(ReadOnlySpan<float>), default(ReadOnlySpan<double>), null,
                      HitMode.All, hits, mask, reject);
        }
#endif

        /// <summary>n sphere queries (centers: 3 floats each; radii: n values).</summary>
        public void QuerySphereBatch(float[] centers, double[] radii, QueryHits hits, ulong mask = AllCategories,
                                     Native.locd_query_reject_fn reject = null)
        {
            long n = Rows(centers, 3, "centers");
            CheckRows(radii, 1, n, "radii");
            fixed (float* c = centers)
            fixed (double* r = radii)
                QuerySphereBatch(c, r, n, hits, mask, reject);
        }

        public void QuerySphereBatch(float* centers, double* radii, long n, QueryHits hits,
                                     ulong mask = AllCategories, Native.locd_query_reject_fn reject = null)
        {
            Batch(3, centers, null, radii, n, HitMode.All, hits, mask, reject);
        }

#if LOCD_SPAN
        public void QuerySphereBatch(ReadOnlySpan<float> centers, ReadOnlySpan<double> radii, QueryHits hits,
                                     ulong mask = AllCategories, Native.locd_query_reject_fn reject = null)
        {
            SpanBatch(3, centers, 3, "centers", default(ReadOnlySpan<float>), radii, "radii", HitMode.All, hits, mask,
                      reject);
        }

        /// <summary>The span forms' one body: v holds `width` floats a query; directions 3 a query (casts,
        /// kinds 0 and 1); num one value a query when numName is given (maxT, radii).</summary>
        void SpanBatch(int kind, ReadOnlySpan<float> v, int width, string vName, ReadOnlySpan<float> directions,
                       ReadOnlySpan<double> num, string numName, HitMode mode, QueryHits hits, ulong mask,
                       Native.locd_query_reject_fn reject)
        {
            long n = Rows(v.Length, width, vName);
            bool cast = kind <= 1;
            if (cast)
                CheckRows(directions.Length, 3, n, "directions");
            if (numName != null)
                CheckRows(num.Length, 1, n, numName);
            fixed (float* pv = &MemoryMarshal.GetReference(v))
            fixed (float* pd = &MemoryMarshal.GetReference(directions))
            fixed (double* pn = &MemoryMarshal.GetReference(num))
                Batch(kind, pv, cast ? pd : null, numName != null ? pn : null, n, mode, hits, mask, reject);
        }
#endif

        /// <summary>kind 0 rays, 1 box casts, 2 boxes, 3 spheres, 4 points.</summary>
        void Batch(int kind, float* v, float* d, double* num, long n, HitMode mode, QueryHits hits, ulong mask,
                   Native.locd_query_reject_fn reject)
        {
            if (hits == null)
                throw new ArgumentNullException("hits");
            if (n < 0)
                throw new ArgumentOutOfRangeException("n");
            var f = Filter(mask, reject);
            var count = (UIntPtr)(ulong)n;
            int st;
            using (var call = Call())
            using (var into = new HeldHandle(null, hits.handle)) {
                if (kind == 0)
                    st = Native.locd_scene_cast_ray_batch_f32(call.Handle, v, d, num, count, (uint)mode, &f, into.Handle);
                else if (kind == 1)
                    st = Native.locd_scene_cast_box_batch_f32(call.Handle, v, d, num, count, (uint)mode, &f, into.Handle);
                else if (kind == 2)
                    st = Native.locd_scene_overlap_box_batch_f32(call.Handle, v, count, &f, into.Handle);
                else if (kind == 3)
                    st = Native.locd_scene_overlap_sphere_batch_f32(call.Handle, v, num, count, &f, into.Handle);
                else
                    st = Native.locd_scene_overlap_point_batch_f32(call.Handle, v, count, &f, into.Handle);
            }
            GC.KeepAlive(reject);
            if (st != Native.LOCD_OK) // Index: the first bad query
                throw LocdException.FromLastError(st, "query");
        }

        static long Rows(Array a, int width, string name)
        {
            if (a == null)
                throw new ArgumentNullException(name);
            return Rows(a.Length, width, name);
        }

        static long Rows(int length, int width, string name)
        {
            if (length % width != 0)
                throw new ArgumentException(name + " must hold " + width + " values per query; got " + length, name);
            return length / width;
        }

        static void CheckRows(Array a, int width, long n, string name)
        {
            if (a == null)
                throw new ArgumentNullException(name);
            CheckRows(a.Length, width, n, name);
        }

        static void CheckRows(int length, int width, long n, string name)
        {
            if (Rows(length, width, name) != n)
                throw new ArgumentException(name + " holds " + (length / width) + " queries for " + n, name);
        }
    }
}
