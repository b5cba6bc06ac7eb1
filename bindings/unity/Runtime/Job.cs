// An asynchronous find (locd_engine_submit_*): poll IsDone each frame or
// Wait(timeout), then read Result. The job keeps its engine alive.
using System;

namespace Locd
{
    public sealed unsafe class Job : IDisposable
    {
        readonly JobSafeHandle handle;
        readonly object sync = new object();
        LocdException failure; // the job's error, captured on the thread that saw it
        bool finished;
        uint[] result;

        internal Job(JobSafeHandle h) { handle = h; }

        public JobSafeHandle SafeHandle { get { return handle; } }

        // A reference on the handle for one call (HeldHandle); the callers
        // that need the lock take it themselves, around more than the call.
        HeldHandle Ref() { return new HeldHandle(null, handle); }

        /// <summary>True once the job has finished, successfully or not (Result then
        /// returns the pairs or throws the job's error). Never blocks.</summary>
        public bool IsDone
        {
            get {
                lock (sync) {
                    if (finished)
                        return true;
                    using (var call = Ref())
                        return Settle(Native.locd_job_poll(call.Handle));
                }
            }
        }

        /// <summary>Waits up to timeoutMs (negative = forever). Returns false if the job
        /// is still running; throws the job's error if it failed.</summary>
        public bool Wait(int timeoutMs)
        {
            lock (sync) {
                if (!finished) {
                    int st;
                    using (var call = Ref())
                        st = Native.locd_job_wait(call.Handle, timeoutMs);
                    if (st == (int)Status.Timeout)
                        return false;
                    Settle(st);
                }
                if (failure != null)
                    throw failure;
                return true;
            }
        }

        public bool Wait(TimeSpan timeout)
        {
            return Wait((int)Math.Min(int.MaxValue, Math.Max(-1, (long)timeout.TotalMilliseconds)));
        }

        /// <summary>Waits for the job without a time limit.</summary>
        public void Wait() { Wait(-1); }

        /// <summary>The pairs (i, j interleaved); waits for the job if needed.
        /// The same array is returned on every read.</summary>
        public uint[] Result
        {
            get {
                lock (sync) {
                    if (result == null) {
                        Wait(-1);
                        using (var p = PairsSafeHandle.Create()) {
                            IntPtr ph = p.DangerousGetHandle();
                            using (var call = Ref())
                                LocdException.Check(Native.locd_job_take(call.Handle, ph));
                            result = Engine.CopyPairs(Native.locd_pairs_data(ph), (long)(ulong)Native.locd_pairs_count(ph));
                        }
                    }
                    return result;
                }
            }
        }

        /// <summary>Statistics of the finished job.</summary>
        public EngineStats Stats
        {
            get {
                using (var call = Ref()) {
                    Native.locd_stats s;
                    Native.locd_stats_init(&s);
                    LocdException.Check(Native.locd_job_get_stats(call.Handle, &s));
                    return new EngineStats(s);
                }
            }
        }

        /// <summary>Asks the job to stop; a later Wait throws Cancelled unless it had finished.</summary>
        public void Cancel()
        {
            using (var call = Ref())
                LocdException.Check(Native.locd_job_cancel(call.Handle));
        }

        // Records the outcome of a poll/wait; true when the job is over.
        bool Settle(int st)
        {
            if (st == Native.LOCD_PENDING)
                return false;
            if (st < 0)
                failure = LocdException.FromLastError(st);
            finished = true;
            return true;
        }


        /// <summary>Releases the job (cancelling it if it still runs).</summary>
        public void Dispose()
        {
            handle.Dispose();
        }
    }
}
