// Process-level resource readings for the leak tests (Linux): resident set
// size, bytes in use in glibc's malloc heap, thread and file-descriptor counts.
using System;
using System.IO;
using System.Runtime.InteropServices;

namespace Locd.Tests
{
    public struct Probe
    {
        public long RssKb;
        public long MallocBytes; // -1 when mallinfo2 is unavailable
        public int Threads;
        public int Fds;

        public override string ToString()
        {
            return string.Format("rss={0} KiB malloc={1} B threads={2} fds={3}", RssKb, MallocBytes, Threads, Fds);
        }
    }

    public static class ProcessProbe
    {
        [StructLayout(LayoutKind.Sequential)]
        struct mallinfo2_t
        {
            public UIntPtr arena, ordblks, smblks, hblks, hblkhd, usmblks, fsmblks, uordblks, fordblks, keepcost;
        }

        [DllImport("libc.so.6", EntryPoint = "mallinfo2")]
        static extern mallinfo2_t mallinfo2();

        public static Probe Read()
        {
            GC.Collect();
            GC.WaitForPendingFinalizers();
            GC.Collect();
            var p = new Probe { MallocBytes = -1 };
            foreach (string line in File.ReadAllLines("/proc/self/status")) {
                if (line.StartsWith("VmRSS:"))
                    p.RssKb = long.Parse(line.Substring(6).Trim().Split(' ')[0]);
                else if (line.StartsWith("Threads:"))
                    p.Threads = int.Parse(line.Substring(8).Trim());
            }
            p.Fds = Directory.GetFiles("/proc/self/fd").Length;
            try {
                var m = mallinfo2();
                // Bytes handed out by malloc: small/medium chunks plus mmapped ones.
                p.MallocBytes = (long)(ulong)m.uordblks + (long)(ulong)m.hblkhd;
            } catch (EntryPointNotFoundException) {
            } catch (DllNotFoundException) {
            }
            return p;
        }

        public static bool OnLinux { get { return File.Exists("/proc/self/status"); } }
    }
}
