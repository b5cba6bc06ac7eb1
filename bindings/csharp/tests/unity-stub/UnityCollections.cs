// A compile-only stub of the Unity.Collections types the package samples use (NativeArray and
// the unsafe pointer access), for CI's compile check of Samples~ (no Unity installed).
// Signatures follow the Unity scripting API; bodies do nothing.
using System;

namespace Unity.Collections
{
    public enum Allocator { Invalid = 0, None = 1, Temp = 2, TempJob = 3, Persistent = 4 }
    public enum NativeArrayOptions { UninitializedMemory = 0, ClearMemory = 1 }

    public struct NativeArray<T> : IDisposable where T : struct
    {
        int length;
        bool created;

        public NativeArray(int length, Allocator allocator, NativeArrayOptions options = NativeArrayOptions.ClearMemory)
        {
            this.length = length;
            created = true;
        }

        public int Length { get { return length; } }
        public bool IsCreated { get { return created; } }
        public T this[int index] { get { return default(T); } set { } }
        public void Dispose() { created = false; }
    }
}

namespace Unity.Collections.LowLevel.Unsafe
{
    public static unsafe class NativeArrayUnsafeUtility
    {
        public static void* GetUnsafePtr<T>(this NativeArray<T> nativeArray) where T : struct { return null; }
        public static void* GetUnsafeReadOnlyPtr<T>(this NativeArray<T> nativeArray) where T : struct { return null; }
    }
}
