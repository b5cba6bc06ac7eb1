// Safe layer: an engine owning its native handle, results as uint[] (i, j
// interleaved, i < j) or written into a caller's buffer, errors as
// LocdException. Boxes are n rows of 6 values: minx miny minz maxx maxy maxz.
using System;
using System.Runtime.InteropServices;

namespace Locd
{
    /// <summary>Options of an engine (see locd_engine_config).</summary>
    public sealed class EngineOptions
    {
        /// <summary>Integration level; default InProcess.</summary>
        public Level Level { get; set; }
        /// <summary>Threads (level 1) or worker processes (level 2); 0 = one per core.</summary>
        public int Threads { get; set; }
        /// <summary>Octree depth limit; 0 = automatic.</summary>
        public int MaxDepth { get; set; }
        /// <summary>Cell edge >= 2^CellBias times a box's largest extent (a flat or thin box finer); 0..8, default 2.</summary>
        public int CellBias { get; set; }
        /// <summary>Encode bounding cubes (the paper's choice) instead of the boxes.</summary>
        public bool Cubes { get; set; }
        /// <summary>Level 3: "unix:/path/to.sock" or "tcp:host:port".</summary>
        public string ServiceAddress { get; set; }
        /// <summary>Level 3 over TCP: shared secret.</summary>
        public string ServiceSecret { get; set; }
        /// <summary>Level 2: path of the locd-worker executable; null = installed default.</summary>
        public string WorkerPath { get; set; }

        public EngineOptions()
        {
            Level = Level.InProcess;
            CellBias = 2;
        }
    }

    /// <summary>Statistics of an engine's last call (locd_stats).</summary>
    public struct EngineStats
    {
        public readonly Native.locd_stats Raw;

        public EngineStats(Native.locd_stats raw) { Raw = raw; }

        public int Threads { get { return (int)Raw.threads; } }
        public long Objects { get { return (long)Raw.objects; } }
        public long Entries { get { return (long)Raw.entries; } }
        public long Candidates { get { return (long)Raw.candidates; } }
        public long ExactTests { get { return (long)Raw.exact_tests; } }
        public long Pairs { get { return (long)Raw.pairs; } }
        public int Depth { get { return (int)Raw.depth; } }
        /// <summary>Wall time inside the C call, in milliseconds.</summary>
        public double MsTotal { get { return Raw.ms_total; } }
        public double MsBounds { get { return Raw.ms_bounds; } }
        public double MsEncode { get { return Raw.ms_encode; } }
        public double MsSort { get { return Raw.ms_sort; } }
        public double MsMerge { get { return Raw.ms_merge; } }
        public double MsSweep { get { return Raw.ms_sweep; } }
        public double MsOrder { get { return Raw.ms_order; } }
        public double MsTransfer { get { return Raw.ms_transfer; } }

        public override string ToString()
        {
            return string.Format("objects={0} pairs={1} candidates={2} threads={3} total={4:F3}ms",
                                 Objects, Pairs, Candidates, Threads, MsTotal);
        }
    }

    /// <summary>
    /// A collision engine. One call at a time per engine (calls from several
    /// threads are serialized); use one engine per thread for parallel callers.
    /// Dispose it (or let the finalizer do it) to stop its threads and free it.
    /// </summary>
    public sealed unsafe class Engine : IDisposable
    {
        readonly EngineSafeHandle handle = new EngineSafeHandle();
        readonly object sync = new object();
        PairsSafeHandle pairs; // reused by the uint[]-returning overloads

        /// <summary>The defaults: level 1, one thread per core.</summary>
        public Engine() : this(null) { }

        /// <summary>Level 1 with the given thread count (0 = one per core).</summary>
        public Engine(int threads) : this(new EngineOptions { Threads = threads }) { }

        public Engine(EngineOptions options)
        {
            Native.locd_engine_config cfg;
            Native.locd_engine_config_init(&cfg);
            IntPtr address = IntPtr.Zero, secret = IntPtr.Zero, worker = IntPtr.Zero;
            try {
                if (options != null) {
                    if (options.Threads < 0 || options.MaxDepth < 0)
                        throw new ArgumentOutOfRangeException("options", "Threads and MaxDepth must be >= 0");
                    cfg.level = (int)options.Level;
                    cfg.threads = (uint)options.Threads;
                    cfg.max_depth = (uint)options.MaxDepth;
                    cfg.cell_bias = options.CellBias;
                    cfg.flags = options.Cubes ? Native.LOCD_CONFIG_CUBES : 0u;
                    // The engine copies the strings; ours live only through the call.
                    address = StringToNative(options.ServiceAddress);
                    secret = StringToNative(options.ServiceSecret);
                    worker = StringToNative(options.WorkerPath);
                    cfg.service_address = address;
                    cfg.service_secret = secret;
                    cfg.worker_path = worker;
                }
                IntPtr e;
                int st = Native.locd_engine_create(&cfg, &e);
                if (st != Native.LOCD_OK)
                    throw LocdException.FromLastError(st);
                handle.Own(e);
            } finally {
                FreeNative(address);
                FreeNative(secret);
                FreeNative(worker);
            }
        }

        static IntPtr StringToNative(string s)
        {
            return s == null ? IntPtr.Zero : Marshal.StringToHGlobalAnsi(s);
        }

        static void FreeNative(IntPtr p)
        {
            if (p != IntPtr.Zero)
                Marshal.FreeHGlobal(p);
        }

        // A call on the handle (HeldHandle): Call() under the engine's lock,
        // Ref() with a reference on the handle only (callers that hold the
        // lock already, or need none).
        HeldHandle Call() { return new HeldHandle(sync, handle); }

        HeldHandle Ref() { return new HeldHandle(null, handle); }

        /// <summary>The native handle (for the raw layer, e.g. from Burst). Valid until Dispose.</summary>
        public IntPtr NativeHandle { get { return handle.DangerousGetHandle(); } }

        public EngineSafeHandle SafeHandle { get { return handle; } }

        public bool IsDisposed { get { return handle.IsClosed; } }

        /// <summary>Level actually in use.</summary>
        public Level Level
        {
            get {
                using (var call = Ref())
                    return (Level)Native.locd_engine_level(call.Handle);
            }
        }

        /// <summary>Threads (or worker processes) actually in use.</summary>
        public int Threads
        {
            get {
                using (var call = Ref())
                    return (int)Native.locd_engine_threads(call.Handle);
            }
        }

        /// <summary>Statistics of the last successful call.</summary>
        public EngineStats Stats
        {
            get {
                using (var call = Ref()) {
                    Native.locd_stats s;
                    Native.locd_stats_init(&s);
                    LocdException.Check(Native.locd_engine_get_stats(call.Handle, &s));
                    return new EngineStats(s);
                }
            }
        }

        // ---------------------------------------------------------------
        // Results as a new uint[] (2 * pairs values). Allocates per call:
        // in a game loop prefer the overloads that take a buffer.
        // ---------------------------------------------------------------

        /// <summary>All overlapping pairs of boxes.Length / 6 boxes, as i0 j0 i1 j1 ...</summary>
        public uint[] FindPairs(float[] boxes, FindFlags flags = FindFlags.None)
        {
            fixed (float* b = boxes)
                return FindPairsArray(b, null, RowCount(boxes, boxes == null ? 0 : boxes.Length), flags);
        }

        public uint[] FindPairs(double[] boxes, FindFlags flags = FindFlags.None)
        {
            fixed (double* b = boxes)
                return FindPairsArray(null, b, RowCount(boxes, boxes == null ? 0 : boxes.Length), flags);
        }

        /// <summary>Pairs of boxes given by a pointer to boxCount * 6 floats.</summary>
        public uint[] FindPairs(float* boxes, long boxCount, FindFlags flags = FindFlags.None)
        {
            return FindPairsArray(boxes, null, CheckCount(boxCount), flags);
        }

        public uint[] FindPairs(double* boxes, long boxCount, FindFlags flags = FindFlags.None)
        {
            return FindPairsArray(null, boxes, CheckCount(boxCount), flags);
        }

        uint[] FindPairsArray(float* f, double* d, long n, FindFlags flags)
        {
            using (var call = Call()) {
                if (pairs == null)
                    pairs = PairsSafeHandle.Create();
                IntPtr e = call.Handle, p = pairs.DangerousGetHandle();
                int st = f != null || d == null
                    ? Native.locd_engine_find_pairs_f32(e, f, (UIntPtr)(ulong)n, (uint)flags, p)
                    : Native.locd_engine_find_pairs_f64(e, d, (UIntPtr)(ulong)n, (uint)flags, p);
                if (st != Native.LOCD_OK)
                    throw LocdException.FromLastError(st);
                return CopyPairs(Native.locd_pairs_data(p), (long)(ulong)Native.locd_pairs_count(p));
            }
        }

        /// <summary>The two-set query: every pair (i, j) with box i of a and box j of b
        /// overlapping, as i0 j0 i1 j1 ... (i indexes a, j indexes b; pairs within one set are
        /// not reported). A bad box of b is reported with BoxIndex a.Length / 6 + j. Levels 1
        /// and 2; level 3 throws with Status.Unsupported.</summary>
        public uint[] FindPairsBetween(float[] a, float[] b, FindFlags flags = FindFlags.None)
        {
            long na = RowCount(a, a == null ? 0 : a.Length), nb = RowCount(b, b == null ? 0 : b.Length);
            fixed (float* pa = a)
            fixed (float* pb = b)
                return FindPairsBetweenArray(pa, pb, null, null, na, nb, flags);
        }

        public uint[] FindPairsBetween(double[] a, double[] b, FindFlags flags = FindFlags.None)
        {
            long na = RowCount(a, a == null ? 0 : a.Length), nb = RowCount(b, b == null ? 0 : b.Length);
            fixed (double* pa = a)
            fixed (double* pb = b)
                return FindPairsBetweenArray(null, null, pa, pb, na, nb, flags);
        }

        uint[] FindPairsBetweenArray(float* fa, float* fb, double* da, double* db, long na, long nb, FindFlags flags)
        {
            using (var call = Call()) {
                if (pairs == null)
                    pairs = PairsSafeHandle.Create();
                IntPtr e = call.Handle, p = pairs.DangerousGetHandle();
                int st = da == null && db == null
                    ? Native.locd_engine_find_pairs_between_f32(e, fa, (UIntPtr)(ulong)na, fb, (UIntPtr)(ulong)nb,
                                                                (uint)flags, p)
                    : Native.locd_engine_find_pairs_between_f64(e, da, (UIntPtr)(ulong)na, db, (UIntPtr)(ulong)nb,
                                                                (uint)flags, p);
                if (st != Native.LOCD_OK)
                    throw LocdException.FromLastError(st);
                return CopyPairs(Native.locd_pairs_data(p), (long)(ulong)Native.locd_pairs_count(p));
            }
        }

        internal static uint[] CopyPairs(uint* src, long count)
        {
            var result = new uint[checked(2 * count)];
            if (count > 0)
                fixed (uint* dst = result)
                    Buffer.MemoryCopy(src, dst, result.Length * 4L, count * 8L);
            return result;
        }

        // ---------------------------------------------------------------
        // Results into a caller's buffer (no allocation). The return value
        // is the number of pairs; the buffer holds 2 * that many values.
        // ---------------------------------------------------------------

        /// <summary>Pairs of the first boxCount boxes into pairs (capacity pairs.Length / 2).
        /// Throws LocdException(BufferTooSmall, RequiredPairs = count) if they do not fit;
        /// CopyLastPairs then still gives them.</summary>
        public int FindPairs(float[] boxes, int boxCount, uint[] pairs, FindFlags flags = FindFlags.None)
        {
            CheckRows(boxes == null ? 0 : boxes.Length, boxCount);
            fixed (float* b = boxes)
            fixed (uint* p = pairs)
                return checked((int)FindInto(b, null, boxCount, p, pairs == null ? 0 : pairs.Length / 2, flags));
        }

        public int FindPairs(double[] boxes, int boxCount, uint[] pairs, FindFlags flags = FindFlags.None)
        {
            CheckRows(boxes == null ? 0 : boxes.Length, boxCount);
            fixed (double* b = boxes)
            fixed (uint* p = pairs)
                return checked((int)FindInto(null, b, boxCount, p, pairs == null ? 0 : pairs.Length / 2, flags));
        }

        /// <summary>Like FindPairs(boxes, boxCount, pairs) but grows the buffer (x1.5 of the
        /// need) when the pairs do not fit, so a buffer reused every frame stops
        /// allocating once it is large enough. pairs may be null; it never is afterwards.</summary>
        public int FindPairs(float[] boxes, int boxCount, ref uint[] pairs, FindFlags flags = FindFlags.None)
        {
            CheckRows(boxes == null ? 0 : boxes.Length, boxCount);
            lock (sync) {
                long m;
                fixed (float* b = boxes)
                fixed (uint* p = pairs)
                    m = FindIntoOrNeed(b, null, boxCount, p, pairs == null ? 0 : pairs.Length / 2, flags);
                return GrowAndCopy(m, ref pairs);
            }
        }

        public int FindPairs(double[] boxes, int boxCount, ref uint[] pairs, FindFlags flags = FindFlags.None)
        {
            CheckRows(boxes == null ? 0 : boxes.Length, boxCount);
            lock (sync) {
                long m;
                fixed (double* b = boxes)
                fixed (uint* p = pairs)
                    m = FindIntoOrNeed(null, b, boxCount, p, pairs == null ? 0 : pairs.Length / 2, flags);
                return GrowAndCopy(m, ref pairs);
            }
        }

        /// <summary>Pointers in and out (e.g. NativeArray's unsafe pointers): boxCount * 6 floats
        /// in, at most capacity pairs (2 * capacity uints) out. Returns the pair count.
        /// Throws LocdException(BufferTooSmall, RequiredPairs) if they do not fit.</summary>
        public long FindPairs(float* boxes, long boxCount, uint* pairs, long capacity, FindFlags flags = FindFlags.None)
        {
            return FindInto(boxes, null, CheckCount(boxCount), pairs, capacity, flags);
        }

        public long FindPairs(double* boxes, long boxCount, uint* pairs, long capacity, FindFlags flags = FindFlags.None)
        {
            return FindInto(null, boxes, CheckCount(boxCount), pairs, capacity, flags);
        }

        /// <summary>Copies the pairs of the last buffer call (including one that failed with
        /// BufferTooSmall) into dest; returns the pair count. Throws if dest is too small.</summary>
        public int CopyLastPairs(uint[] dest)
        {
            lock (sync) {
                uint* src;
                long m = LastPairs(out src);
                if (dest == null || dest.Length < 2 * m)
                    throw new ArgumentException("dest holds fewer than " + (2 * m) + " values", "dest");
                if (m > 0)
                    fixed (uint* d = dest)
                        Buffer.MemoryCopy(src, d, dest.Length * 4L, m * 8L);
                return checked((int)m);
            }
        }

        long FindInto(float* f, double* d, long n, uint* p, long capacity, FindFlags flags)
        {
            lock (sync) {
                long m = FindIntoOrNeed(f, d, n, p, capacity, flags);
                if (m > capacity) {
                    var ex = new LocdException(Status.BufferTooSmall,
                        m + " pairs found, capacity " + capacity + " (see CopyLastPairs)", -1);
                    ex.RequiredPairs = m;
                    throw ex;
                }
                return m;
            }
        }

        // Returns the pair count; when it exceeds capacity nothing was copied
        // and the pairs wait in the engine (locd_engine_last_pairs).
        long FindIntoOrNeed(float* f, double* d, long n, uint* p, long capacity, FindFlags flags)
        {
            if (capacity < 0)
                throw new ArgumentOutOfRangeException("capacity");
            using (var call = Ref()) {
                IntPtr e = call.Handle;
                UIntPtr count;
                if (capacity == 0)
                    p = null;
                int st = f != null || d == null
                    ? Native.locd_engine_find_pairs_f32_into(e, f, (UIntPtr)(ulong)n, (uint)flags, p, (UIntPtr)(ulong)capacity, &count)
                    : Native.locd_engine_find_pairs_f64_into(e, d, (UIntPtr)(ulong)n, (uint)flags, p, (UIntPtr)(ulong)capacity, &count);
                if (st == (int)Status.BufferTooSmall)
                    return (long)(ulong)count;
                if (st != Native.LOCD_OK)
                    throw LocdException.FromLastError(st);
                return (long)(ulong)count;
            }
        }

        int GrowAndCopy(long m, ref uint[] pairs)
        {
            int have = pairs == null ? 0 : pairs.Length / 2;
            if (m <= have && pairs != null)
                return checked((int)m);
            long grown = Math.Max(m + m / 2, 16);
            pairs = new uint[checked(2 * grown)];
            if (m == 0)
                return 0; // a null buffer became an empty-but-usable one
            uint* src;
            long again = LastPairs(out src);
            fixed (uint* dst = pairs)
                Buffer.MemoryCopy(src, dst, pairs.Length * 4L, again * 8L);
            return checked((int)again);
        }

        long LastPairs(out uint* src)
        {
            using (var call = Ref()) {
                uint* data;
                UIntPtr count;
                LocdException.Check(Native.locd_engine_last_pairs(call.Handle, &data, &count));
                src = data;
                return (long)(ulong)count;
            }
        }

        // ---------------------------------------------------------------
        // Asynchronous jobs: the boxes are copied, the call returns at once.
        // ---------------------------------------------------------------

        public Job Submit(float[] boxes, FindFlags flags = FindFlags.None)
        {
            fixed (float* b = boxes)
                return SubmitRaw(b, null, RowCount(boxes, boxes == null ? 0 : boxes.Length), flags);
        }

        public Job Submit(double[] boxes, FindFlags flags = FindFlags.None)
        {
            fixed (double* b = boxes)
                return SubmitRaw(null, b, RowCount(boxes, boxes == null ? 0 : boxes.Length), flags);
        }

        public Job Submit(float* boxes, long boxCount, FindFlags flags = FindFlags.None)
        {
            return SubmitRaw(boxes, null, CheckCount(boxCount), flags);
        }

        Job SubmitRaw(float* f, double* d, long n, FindFlags flags)
        {
            var jh = new JobSafeHandle();
            bool added = false;
            try {
                // This reference belongs to the job from here on (JobSafeHandle.ReleaseHandle).
                handle.DangerousAddRef(ref added);
                IntPtr e = handle.DangerousGetHandle(), j;
                int st = f != null || d == null
                    ? Native.locd_engine_submit_f32(e, f, (UIntPtr)(ulong)n, (uint)flags, &j)
                    : Native.locd_engine_submit_f64(e, d, (UIntPtr)(ulong)n, (uint)flags, &j);
                if (st != Native.LOCD_OK)
                    throw LocdException.FromLastError(st);
                handle.NoteJob();
                jh.Own(j, handle);
                added = false;
                return new Job(jh);
            } finally {
                if (added) handle.DangerousRelease();
            }
        }

        // ---------------------------------------------------------------
        // Reference and helpers
        // ---------------------------------------------------------------

        /// <summary>The C library's O(n^2) reference (locd_brute_force_f32), sorted by (i, j).</summary>
        public static uint[] BruteForce(float[] boxes)
        {
            using (var p = PairsSafeHandle.Create())
            fixed (float* b = boxes) {
                IntPtr h = p.DangerousGetHandle();
                LocdException.Check(Native.locd_brute_force_f32(b, (UIntPtr)(ulong)RowCount(boxes, boxes == null ? 0 : boxes.Length), h));
                return CopyPairs(Native.locd_pairs_data(h), (long)(ulong)Native.locd_pairs_count(h));
            }
        }

        public static uint[] BruteForce(double[] boxes)
        {
            using (var p = PairsSafeHandle.Create())
            fixed (double* b = boxes) {
                IntPtr h = p.DangerousGetHandle();
                LocdException.Check(Native.locd_brute_force_f64(b, (UIntPtr)(ulong)RowCount(boxes, boxes == null ? 0 : boxes.Length), h));
                return CopyPairs(Native.locd_pairs_data(h), (long)(ulong)Native.locd_pairs_count(h));
            }
        }

        /// <summary>Version string of the native library actually loaded.</summary>
        public static string NativeVersion
        {
            get { return Marshal.PtrToStringAnsi(Native.locd_version_string()); }
        }

        static long RowCount(Array boxes, int length)
        {
            if (boxes == null)
                throw new ArgumentNullException("boxes");
            if (length % 6 != 0)
                throw new ArgumentException("boxes must hold 6 values per box (minx miny minz maxx maxy maxz); got "
                                            + length + " values", "boxes");
            return length / 6;
        }

        static void CheckRows(int length, int boxCount)
        {
            if (boxCount < 0 || boxCount > length / 6)
                throw new ArgumentOutOfRangeException("boxCount", "boxCount " + boxCount + " exceeds the "
                                                      + (length / 6) + " boxes of the array");
        }

        static long CheckCount(long boxCount)
        {
            if (boxCount < 0)
                throw new ArgumentOutOfRangeException("boxCount");
            return boxCount;
        }

        public void Dispose()
        {
            lock (sync) {
                handle.Dispose();
                if (pairs != null)
                    pairs.Dispose();
            }
        }
    }
}
