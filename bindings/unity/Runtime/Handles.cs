// SafeHandles owning the C library's opaque handles. A handle is released
// exactly once, by Dispose or by the finalizer, and never while a call that
// took a reference (DangerousAddRef) is still running on another thread.
using System;
using System.Runtime.InteropServices;
using System.Threading;

namespace Locd
{
    /// <summary>
    /// One native call on a handle: takes the lock (when sync is not null)
    /// and a reference on the handle, so that a concurrent Dispose cannot
    /// free it under the call, and gives both back on Dispose:
    /// <c>using (var call = new HeldHandle(sync, handle)) st = Native.f(call.Handle, ...);</c>
    /// A struct, not a delegate: a call allocates nothing.
    /// </summary>
    internal struct HeldHandle : IDisposable
    {
        readonly object sync;
        readonly SafeHandle owner;
        readonly bool locked, added;
        /// <summary>The native pointer, valid until Dispose.</summary>
        public readonly IntPtr Handle;

        public HeldHandle(object sync, SafeHandle handle)
        {
            this.sync = sync;
            owner = handle;
            locked = added = false;
            Handle = IntPtr.Zero;
            try {
                if (sync != null)
                    Monitor.Enter(sync, ref locked);
                handle.DangerousAddRef(ref added);
                Handle = handle.DangerousGetHandle();
            } catch {
                Dispose(); // a disposed handle: give the lock back before throwing
                throw;
            }
        }

        public void Dispose()
        {
            if (added)
                owner.DangerousRelease();
            if (locked)
                Monitor.Exit(sync);
        }
    }

    /// <summary>Owns a locd_engine *.</summary>
    public sealed class EngineSafeHandle : SafeHandle
    {
        static long live;

        /// <summary>Engines created and not yet destroyed (all threads).</summary>
        public static long Live { get { return Interlocked.Read(ref live); } }

        public EngineSafeHandle() : base(IntPtr.Zero, true) { }

        public override bool IsInvalid { get { return handle == IntPtr.Zero; } }

        int hadJobs;

        internal void Own(IntPtr engine)
        {
            SetHandle(engine);
            Interlocked.Increment(ref live);
        }

        internal void NoteJob() { Interlocked.Exchange(ref hadJobs, 1); }

        protected override unsafe bool ReleaseHandle()
        {
            // A released job's thread may still be inside the engine (levels 1
            // and 2 cannot interrupt it). Destroying the engine under it would be
            // a use-after-free, so wait until the engine is no longer busy: an
            // empty find is refused with Busy exactly while that thread runs.
            if (Volatile.Read(ref hadJobs) != 0) {
                UIntPtr count;
                while (Native.locd_engine_find_pairs_f32_into(handle, null, UIntPtr.Zero, 0, null, UIntPtr.Zero, &count)
                       == (int)Status.Busy)
                    Thread.Sleep(1);
            }
            Native.locd_engine_destroy(handle);
            Interlocked.Decrement(ref live);
            return true;
        }
    }

    /// <summary>Owns a locd_pairs * (a growable native pairs buffer).</summary>
    public sealed class PairsSafeHandle : SafeHandle
    {
        public PairsSafeHandle() : base(IntPtr.Zero, true) { }

        public override bool IsInvalid { get { return handle == IntPtr.Zero; } }

        /// <summary>Creates an empty buffer (malloc/free).</summary>
        public static unsafe PairsSafeHandle Create()
        {
            var h = new PairsSafeHandle();
            IntPtr p;
            LocdException.Check(Native.locd_pairs_create(null, &p));
            h.SetHandle(p);
            return h;
        }

        protected override bool ReleaseHandle()
        {
            Native.locd_pairs_destroy(handle);
            return true;
        }
    }

    /// <summary>Owns a locd_job * and keeps its engine alive until the job is released.</summary>
    public sealed class JobSafeHandle : SafeHandle
    {
        static long live;
        EngineSafeHandle engine;

        /// <summary>Jobs submitted and not yet released (all threads).</summary>
        public static long Live { get { return Interlocked.Read(ref live); } }

        public JobSafeHandle() : base(IntPtr.Zero, true) { }

        public override bool IsInvalid { get { return handle == IntPtr.Zero; } }

        // The caller holds a reference on `owner` (DangerousAddRef) taken for
        // this job; it is given back in ReleaseHandle, after locd_job_release,
        // so the engine is destroyed last even when both are finalized together.
        internal void Own(IntPtr job, EngineSafeHandle owner)
        {
            engine = owner;
            SetHandle(job);
            Interlocked.Increment(ref live);
        }

        protected override bool ReleaseHandle()
        {
            Native.locd_job_release(handle);
            Interlocked.Decrement(ref live);
            if (engine != null)
                engine.DangerousRelease();
            return true;
        }
    }
}
