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

        /// <summary>True once the job has finished, successfully or not (Result then
        /// returns the pairs or throws the job's error). Never blocks.</summary>
        public bool IsDone
        {
            get {
                lock (sync) {
                    if (finished)
                        return true;
                    bool added = false;
                    try {
                        handle.DangerousAddRef(ref added);
                        return Settle(Native.locd_job_poll(handle.DangerousGetHandle()));
                    } finally {
                        if (added) handle.DangerousRelease();
                    }
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
                    bool added = false;
                    try {
                        handle.DangerousAddRef(ref added);
                        st = Native.locd_job_wait(handle.DangerousGetHandle(), timeoutMs);
                    } finally {
                        if (added) handle.DangerousRelease();
                    }
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
                            bool added = false;
                            try {
                                handle.DangerousAddRef(ref added);
                                LocdException.Check(Native.locd_job_take(handle.DangerousGetHandle(), ph));
                            } finally {
                                if (added) handle.DangerousRelease();
                            }
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
                bool added = false;
                try {
                    handle.DangerousAddRef(ref added);
                    Native.locd_stats s;
                    Native.locd_stats_init(&s);
                    LocdException.Check(Native.locd_job_stats(handle.DangerousGetHandle(), &s));
                    return new EngineStats(s);
                } finally {
                    if (added) handle.DangerousRelease();
                }
            }
        }

        /// <summary>Asks the job to stop; a later Wait throws Cancelled unless it had finished.</summary>
        public void Cancel()
        {
            bool added = false;
            try {
                handle.DangerousAddRef(ref added);
                LocdException.Check(Native.locd_job_cancel(handle.DangerousGetHandle()));
            } finally {
                if (added) handle.DangerousRelease();
            }
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
