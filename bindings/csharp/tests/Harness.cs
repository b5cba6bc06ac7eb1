// A minimal test harness: a list of named tests, each passes, fails (any
// exception) or is skipped (SkipException). Prints one line per test and
// "N passed, N failed, N skipped"; writes JUnit XML; exit code 1 on failure.
using System;
using System.Collections.Generic;
using System.Diagnostics;
using System.IO;
using System.Security;
using System.Text;

namespace Locd.Tests
{
    public sealed class SkipException : Exception
    {
        public SkipException(string why) : base(why) { }
    }

    public static class Assert
    {
        public static void True(bool cond, string what)
        {
            if (!cond)
                throw new Exception("assertion failed: " + what);
        }

        public static void Equal<T>(T expected, T actual, string what)
        {
            if (!EqualityComparer<T>.Default.Equals(expected, actual))
                throw new Exception(what + ": expected " + expected + ", got " + actual);
        }

        public static T Throws<T>(Action body, string what) where T : Exception
        {
            try {
                body();
            } catch (T e) {
                return e;
            } catch (Exception e) {
                throw new Exception(what + ": expected " + typeof(T).Name + ", got " + e.GetType().Name + ": " + e.Message);
            }
            throw new Exception(what + ": expected " + typeof(T).Name + ", nothing was thrown");
        }

        /// <summary>Same pairs in the same order (callers sort first when order is free).</summary>
        public static void SamePairs(uint[] expected, uint[] actual, string what)
        {
            if (expected.Length != actual.Length)
                throw new Exception(what + ": expected " + expected.Length / 2 + " pairs, got " + actual.Length / 2
                                    + FirstDifference(expected, actual));
            for (int k = 0; k < expected.Length; k++)
                if (expected[k] != actual[k])
                    throw new Exception(what + ": pairs differ" + FirstDifference(expected, actual));
        }

        static string FirstDifference(uint[] a, uint[] b)
        {
            var sa = new HashSet<ulong>(Scenes.Keys(a));
            var sb = new HashSet<ulong>(Scenes.Keys(b));
            foreach (ulong k in sa)
                if (!sb.Contains(k))
                    return "; missing (" + (k >> 32) + ", " + (uint)k + ")";
            foreach (ulong k in sb)
                if (!sa.Contains(k))
                    return "; extra (" + (k >> 32) + ", " + (uint)k + ")";
            return "; same set, different order or duplicates";
        }
    }

    public sealed class Harness
    {
        sealed class Case
        {
            public string Name;
            public Action Body;
        }

        sealed class Outcome
        {
            public string Name, Status, Message;
            public double Seconds;
        }

        readonly List<Case> cases = new List<Case>();

        public void Add(string name, Action body)
        {
            cases.Add(new Case { Name = name, Body = body });
        }

        public int Run(string junitPath, string filter)
        {
            var outcomes = new List<Outcome>();
            int passed = 0, failed = 0, skipped = 0;
            foreach (var c in cases) {
                if (filter != null && c.Name.IndexOf(filter, StringComparison.Ordinal) < 0)
                    continue;
                var o = new Outcome { Name = c.Name, Message = "" };
                var sw = Stopwatch.StartNew();
                try {
                    c.Body();
                    o.Status = "passed";
                    passed++;
                } catch (SkipException e) {
                    o.Status = "skipped";
                    o.Message = e.Message;
                    skipped++;
                } catch (Exception e) {
                    o.Status = "failed";
                    o.Message = e.ToString();
                    failed++;
                }
                o.Seconds = sw.Elapsed.TotalSeconds;
                outcomes.Add(o);
                Console.WriteLine("{0,-8} {1} ({2:F2}s){3}", o.Status.ToUpperInvariant(), o.Name, o.Seconds,
                                  o.Status == "passed" ? "" : "\n         " + o.Message.Replace("\n", "\n         "));
            }
            Console.WriteLine("{0} passed, {1} failed, {2} skipped", passed, failed, skipped);
            if (junitPath != null)
                WriteJUnit(junitPath, outcomes, failed, skipped);
            return failed == 0 && passed > 0 ? 0 : 1;
        }

        static void WriteJUnit(string path, List<Outcome> outcomes, int failed, int skipped)
        {
            var sb = new StringBuilder();
            sb.Append("<?xml version=\"1.0\" encoding=\"utf-8\"?>\n<testsuites>\n");
            sb.AppendFormat("<testsuite name=\"csharp\" tests=\"{0}\" failures=\"{1}\" skipped=\"{2}\">\n",
                            outcomes.Count, failed, skipped);
            foreach (var o in outcomes) {
                sb.AppendFormat("  <testcase classname=\"csharp\" name=\"{0}\" time=\"{1:F3}\">",
                                SecurityElement.Escape(o.Name), o.Seconds);
                if (o.Status == "failed")
                    sb.AppendFormat("<failure message=\"{0}\">{1}</failure>",
                                    SecurityElement.Escape(FirstLine(o.Message)), SecurityElement.Escape(o.Message));
                else if (o.Status == "skipped")
                    sb.AppendFormat("<skipped message=\"{0}\"/>", SecurityElement.Escape(o.Message));
                sb.Append("</testcase>\n");
            }
            sb.Append("</testsuite>\n</testsuites>\n");
            File.WriteAllText(path, sb.ToString());
        }

        static string FirstLine(string s)
        {
            int k = s.IndexOf('\n');
            return k < 0 ? s : s.Substring(0, k);
        }
    }
}
