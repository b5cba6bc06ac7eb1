// Test bodies that may crash the process (a native fault kills mono, and with it the whole suite)
// run in a child process: the test starts this runner again with --child NAME and fails when the
// child does not exit with 0. The child's output is summarized, not copied: CI reads mono's crash
// report in the log as a crash of the suite itself.
using System;
using System.Collections.Generic;
using System.Diagnostics;
using System.IO;
using System.Linq;
using System.Reflection;
using System.Text.RegularExpressions;

namespace Locd.Tests
{
    public static class Child
    {
        static readonly Dictionary<string, Action> Bodies = new Dictionary<string, Action> {
            { "sphere_radius_square_overflows", SceneQueryTests.SphereRadiusSquareOverflowsBody },
        };

        /// <summary>In the child: runs the body; 0 when it returns, 1 when it throws.</summary>
        public static int Run(string name)
        {
            Action body;
            if (!Bodies.TryGetValue(name, out body)) {
                Console.WriteLine("no child body named " + name);
                return 2;
            }
            try {
                body();
                Console.WriteLine("child " + name + ": passed");
                return 0;
            } catch (Exception e) {
                Console.WriteLine("child " + name + ": " + e.Message);
                return 1;
            }
        }

        /// <summary>In the test: runs body NAME in a child process; throws unless it passed.
        /// The child runs in a scratch directory (mono writes its crash dumps, mono_crash.*.json,
        /// into the working directory), removed afterwards.</summary>
        public static void Expect(string name, int timeoutMs = 120000)
        {
            string dir = Path.Combine(Path.GetTempPath(), "locd-child-" + Guid.NewGuid().ToString("N"));
            Directory.CreateDirectory(dir);
            try {
                Run(name, dir, timeoutMs);
            } finally {
                Directory.Delete(dir, true);
            }
        }

        static void Run(string name, string dir, int timeoutMs)
        {
            var psi = new ProcessStartInfo {
                FileName = Process.GetCurrentProcess().MainModule.FileName, // mono
                Arguments = "--debug \"" + Assembly.GetEntryAssembly().Location + "\" --child " + name,
                WorkingDirectory = dir,
                UseShellExecute = false,
                RedirectStandardOutput = true,
                RedirectStandardError = true,
            };
            using (var p = Process.Start(psi)) {
                var err = p.StandardError.ReadToEndAsync();
                string output = p.StandardOutput.ReadToEnd();
                if (!p.WaitForExit(timeoutMs)) {
                    p.Kill();
                    throw new Exception("child " + name + " did not finish in " + timeoutMs / 1000 + " s");
                }
                string all = output + err.Result;
                if (p.ExitCode == 0)
                    return;
                Match signal = Regex.Match(all, "Got a (SIG[A-Z]+)");
                string said = all.Split('\n').Select(l => l.Trim()).LastOrDefault(l => l.StartsWith("child " + name)) ?? "";
                throw new Exception("child " + name + (signal.Success || all.Contains("Native Crash Reporting")
                    ? " crashed in native code (" + (signal.Success ? signal.Groups[1].Value + ", " : "") + "exit code " + p.ExitCode + ")"
                    : " failed (exit code " + p.ExitCode + "): " + said));
            }
        }
    }
}
