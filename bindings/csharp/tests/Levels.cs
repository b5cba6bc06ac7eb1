// Integration levels 2 (worker processes) and 3 (service) through the C#
// binding: the option strings (WorkerPath, ServiceAddress, ServiceSecret)
// reach the library, results equal level 1's, errors map. The executables
// come from the build of LOCD_CLI: locd beside it in tools/, locd-worker in
// the build's lib/ beside the library; without them, or while a level is
// not implemented (Unsupported), the tests report skipped.
using System;
using System.Diagnostics;
using System.IO;
using System.Runtime.InteropServices;
using System.Threading;

namespace Locd.Tests
{
    public static class Levels
    {
        [DllImport("libc.so.6", SetLastError = true)]
        static extern int chmod(string path, uint mode);

        static string ToolDir()
        {
            string cli = Environment.GetEnvironmentVariable("LOCD_CLI");
            if (string.IsNullOrEmpty(cli) || !File.Exists(cli))
                throw new SkipException("LOCD_CLI not set (the CI step sets it to the built `locd` tool)");
            return Path.GetDirectoryName(Path.GetFullPath(cli));
        }

        // The build's locd-worker: built beside the library (lib/), the
        // tools' sibling folder.
        static string WorkerPath()
        {
            return Path.GetFullPath(Path.Combine(ToolDir(), "..", "lib", "locd-worker"));
        }

        static Engine CreateOrSkip(EngineOptions opt, string what)
        {
            try {
                return new Engine(opt);
            } catch (LocdException ex) {
                if (ex.Status == Status.Unsupported)
                    throw new SkipException(what + " unsupported by this native build: " + ex.Message);
                throw;
            }
        }

        static void SameAsLevelOne(Engine e, string what)
        {
            var r = new Rng(77);
            using (var one = new Engine(2))
                foreach (int n in new[] { 0, 1, 50, 2000, 20000 }) {
                    var boxes = n < 1000 ? Scenes.Mixed(r, n, 1e4) : Scenes.Uniform(r, n, 2 * Math.Pow(n, 1.0 / 3), 2);
                    var expect = one.FindPairs(boxes);
                    Assert.SamePairs(expect, e.FindPairs(boxes), what + ": same pairs and order as level 1 (n=" + n + ")");
                    Assert.SamePairs(Scenes.Sorted(expect), e.FindPairs(Scenes.ToDouble(boxes), FindFlags.Sorted),
                                     what + ": f64 sorted (n=" + n + ")");
                    uint[] buf = null;
                    int m = e.FindPairs(boxes, n, ref buf);
                    Assert.SamePairs(expect, Scenes.Prefix(buf, m), what + ": into a buffer (n=" + n + ")");
                }
            var bad = Scenes.Uniform(new Rng(1), 100, 10, 1);
            bad[6 * 57 + 4] = float.NaN;
            var ex = Assert.Throws<LocdException>(() => e.FindPairs(bad), what + ": NaN");
            Assert.Equal(Status.NonFinite, ex.Status, what + ": NaN status");
            Assert.Equal(57L, ex.BoxIndex, what + ": NaN index");
        }

        public static void Workers()
        {
            string worker = WorkerPath();
            if (!File.Exists(worker))
                throw new SkipException("no locd-worker in the lib/ folder of LOCD_CLI's build");
            using (var e = CreateOrSkip(new EngineOptions { Level = Level.Workers, Threads = 2, WorkerPath = worker },
                                        "level 2")) {
                Assert.Equal(Level.Workers, e.Level, "level");
                SameAsLevelOne(e, "level 2");
            }
            // The path string reaches the library: a wrong one is named in the error.
            string wrong = "/nonexistent/locd-worker-" + Process.GetCurrentProcess().Id;
            var err = Assert.Throws<LocdException>(() => {
                using (var e = new Engine(new EngineOptions { Level = Level.Workers, Threads = 2, WorkerPath = wrong }))
                    e.FindPairs(Scenes.Uniform(new Rng(1), 10, 10, 1));
            }, "bad worker path");
            Assert.True(err.Detail.Contains(wrong), "detail names the worker path: " + err.Detail);
        }

        public static void Service()
        {
            string cli = Path.Combine(ToolDir(), "locd");
            string dir = Path.Combine(Path.GetTempPath(), "locd-cs-svc-" + Process.GetCurrentProcess().Id);
            Directory.CreateDirectory(dir);
            chmod(dir, Convert.ToUInt32("700", 8)); // the service insists on a private directory
            string sock = Path.Combine(dir, "s.sock");
            var psi = new ProcessStartInfo(cli, "serve --listen unix:" + sock + " --threads 2") {
                UseShellExecute = false, RedirectStandardError = true, RedirectStandardOutput = true,
            };
            Process server = Process.Start(psi);
            server.ErrorDataReceived += (s, a) => { };
            server.OutputDataReceived += (s, a) => { };
            server.BeginErrorReadLine();
            server.BeginOutputReadLine();
            try {
                var sw = Stopwatch.StartNew();
                while (!File.Exists(sock) && !server.HasExited && sw.Elapsed.TotalSeconds < 20)
                    Thread.Sleep(20);
                if (server.HasExited)
                    throw new SkipException("`locd serve` exited with " + server.ExitCode + " (no level 3 in this build?)");
                Assert.True(File.Exists(sock), "service socket appeared");
                using (var e = CreateOrSkip(new EngineOptions { Level = Level.Service, ServiceAddress = "unix:" + sock },
                                            "level 3")) {
                    Assert.Equal(Level.Service, e.Level, "level");
                    SameAsLevelOne(e, "level 3");
                    // Several jobs in flight on one level-3 engine.
                    var r = new Rng(5);
                    var scenes = new float[4][];
                    var jobs = new Job[4];
                    for (int k = 0; k < jobs.Length; k++) {
                        scenes[k] = Scenes.Uniform(r, 3000, 60, 3);
                        jobs[k] = e.Submit(scenes[k], FindFlags.Sorted);
                    }
                    for (int k = 0; k < jobs.Length; k++)
                        using (jobs[k]) {
                            Assert.True(jobs[k].Wait(60000), "level 3 job " + k + " finished");
                            Assert.SamePairs(Scenes.Brute(scenes[k]), jobs[k].Result, "level 3 job " + k);
                        }
                }
                // An address nobody listens on: a connection error, at create or at the first call.
                var err = Assert.Throws<LocdException>(() => {
                    using (var e = new Engine(new EngineOptions { Level = Level.Service, ServiceAddress = "unix:" + sock + ".none" }))
                        e.FindPairs(Scenes.Uniform(new Rng(1), 10, 10, 1));
                }, "unreachable service");
                Assert.True(err.Status == Status.Connection || err.Status == Status.IO,
                            "unreachable service status: " + err.Status + " (" + err.Detail + ")");
            } finally {
                if (!server.HasExited) {
                    server.Kill();
                    server.WaitForExit(10000);
                }
                try { Directory.Delete(dir, true); } catch (IOException) { }
            }
        }
    }
}
