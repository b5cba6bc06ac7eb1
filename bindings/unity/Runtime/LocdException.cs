// Errors of the C library as exceptions: the status code, the detail message
// of the failing call (locd_last_error) and, for bad boxes, the box index.
using System;
using System.Runtime.InteropServices;

namespace Locd
{
    public class LocdException : Exception
    {
        /// <summary>The locd_status the C call returned.</summary>
        public Status Status { get; private set; }

        /// <summary>locd_last_error() of the failing call ("" if none).</summary>
        public string Detail { get; private set; }

        /// <summary>Index of the first bad box (NonFinite, InvertedBox), or -1.</summary>
        public long BoxIndex { get; private set; }

        /// <summary>Position in the batch of the first bad item (a box, a scene id for
        /// StaleId and DuplicateId, or a query of a scene query batch; 0 for a single scene
        /// query), or -1. The same value as BoxIndex.</summary>
        public long Index { get { return BoxIndex; } }

        /// <summary>For BufferTooSmall: the number of pairs found, else -1.</summary>
        public long RequiredPairs { get; internal set; }

        public LocdException(Status status, string detail, long boxIndex)
            : this(status, detail, boxIndex, null)
        {
        }

        // `item` names what Index counts in the message ("query"); null: a box, or an id.
        internal LocdException(Status status, string detail, long boxIndex, string item)
            : base(Compose(status, detail, boxIndex, item))
        {
            Status = status;
            Detail = detail ?? "";
            BoxIndex = boxIndex;
            RequiredPairs = -1;
        }

        static string Compose(Status status, string detail, long boxIndex, string item)
        {
            string s = string.IsNullOrEmpty(detail) ? StatusString(status) : detail;
            if (item == null)
                item = status == Status.StaleId || status == Status.DuplicateId ? "index" : "box";
            if (boxIndex >= 0)
                s += " (" + item + " " + boxIndex + ")";
            return "locd " + status + ": " + s;
        }

        /// <summary>locd_status_string(status).</summary>
        public static string StatusString(Status status)
        {
            return Marshal.PtrToStringAnsi(Native.locd_status_string((int)status));
        }

        /// <summary>Builds the exception for a failed call. Must run on the thread that
        /// made the call, before any other locd call: the detail is thread-local.</summary>
        internal static LocdException FromLastError(int status)
        {
            return FromLastError(status, null);
        }

        /// <summary>The same, the message naming the bad item as `item` ("query 3").</summary>
        internal static LocdException FromLastError(int status, string item)
        {
            string detail = Marshal.PtrToStringAnsi(Native.locd_last_error());
            long index = Native.locd_last_error_index();
            return new LocdException((Status)status, detail, index, item);
        }

        /// <summary>Throws for any negative status; returns the status otherwise
        /// (Ok or Pending).</summary>
        internal static int Check(int status)
        {
            if (status < 0)
                throw FromLastError(status);
            return status;
        }
    }
}
