// Raw layer over the public C ABI of locd (include/locd/locd.h).
//
// Everything here is blittable: handles are IntPtr, size_t is UIntPtr,
// buffers are plain pointers, structs mirror the C structs field for field.
// So these functions can be called from Burst-compiled jobs and from IL2CPP
// without marshalling. The safe layer (Engine, Job) is built on top.
//
// Struct layouts are checked by the test suite against offsetof/sizeof printed
// by a C program compiled from the real header (bindings/csharp/tests/layout.c).
using System;
using System.Runtime.InteropServices;

namespace Locd
{
    /// <summary>Status codes of the C API (locd_status).</summary>
    public enum Status : int
    {
        Ok = 0,
        Pending = 1,
        InvalidArgument = -1,
        NullPointer = -2,
        NonFinite = -3,
        InvertedBox = -4,
        NoMemory = -5,
        TooManyObjects = -6,
        BufferTooSmall = -7,
        InvalidHandle = -8,
        Busy = -9,
        Thread = -10,
        Unsupported = -11,
        Worker = -12,
        IO = -13,
        Connection = -14,
        Protocol = -15,
        Timeout = -16,
        Cancelled = -17,
        Auth = -18,
        Shape = -19,
        /// <summary>A scene id was removed or never issued (LocdException.Index: its position in the batch).</summary>
        StaleId = -20,
        /// <summary>A scene id appears twice in one batch (LocdException.Index: its position).</summary>
        DuplicateId = -21,
        Internal = -100,
    }

    /// <summary>Integration levels (LOCD_LEVEL_*).</summary>
    public enum Level : int
    {
        InProcess = 1,
        Workers = 2,
        Service = 3,
    }

    /// <summary>Flags of the find and submit calls (LOCD_FIND_*).</summary>
    [Flags]
    public enum FindFlags : uint
    {
        None = 0,
        /// <summary>Order the pairs by (i, j); costs time.</summary>
        Sorted = 0x1,
    }

    /// <summary>P/Invoke declarations for liblocd, one per exported function.</summary>
    public static unsafe class Native
    {
        // iOS (and WebGL) link native plugins statically into the player:
        // there the library is found in the main executable as "__Internal".
#if (UNITY_IOS || UNITY_WEBGL) && !UNITY_EDITOR
        public const string Library = "__Internal";
#else
        public const string Library = "locd";
#endif

        public const int LOCD_OK = 0;
        public const int LOCD_PENDING = 1;
        public const int LOCD_LEVEL_INPROCESS = 1;
        public const int LOCD_LEVEL_WORKERS = 2;
        public const int LOCD_LEVEL_SERVICE = 3;
        public const uint LOCD_CONFIG_CUBES = 0x1;
        public const uint LOCD_FIND_SORTED = 0x1;
        public const int LOCD_MAX_ENTRIES_PER_BOX = 8;

        /// <summary>locd_allocator: all NULL = malloc/free.</summary>
        [StructLayout(LayoutKind.Sequential)]
        public struct locd_allocator
        {
            public IntPtr alloc; // void *(*)(size_t size, void *user)
            public IntPtr free;  // void (*)(void *ptr, size_t size, void *user)
            public IntPtr user;
        }

        /// <summary>locd_engine_config; initialize with locd_engine_config_init.</summary>
        [StructLayout(LayoutKind.Sequential)]
        public struct locd_engine_config
        {
            public uint size;
            public int level;
            public uint threads;
            public uint max_depth;
            public int cell_bias;
            public uint flags;
            public IntPtr service_address; // const char *
            public IntPtr service_secret;  // const char *
            public IntPtr worker_path;     // const char *
            public locd_allocator allocator;
            public IntPtr log;             // locd_log_fn
            public IntPtr log_user;
        }

        /// <summary>locd_stats; initialize with locd_stats_init.</summary>
        [StructLayout(LayoutKind.Sequential)]
        public struct locd_stats
        {
            public uint size;
            public uint threads;
            public ulong objects;
            public ulong entries;
            public ulong candidates;
            public ulong exact_tests;
            public ulong pairs;
            public uint depth;
            public uint reserved;
            public double ms_total;
            public double ms_bounds;
            public double ms_encode;
            public double ms_sort;
            public double ms_merge;
            public double ms_sweep;
            public double ms_order;
            public double ms_transfer;
        }

        /// <summary>locd_grid, filled by locd_grid_fit_*.</summary>
        [StructLayout(LayoutKind.Sequential)]
        public struct locd_grid
        {
            public uint size;
            public uint depth;
            public int cell_bias;
            public uint index_bits;
            public uint flags;
            public uint reserved;
            public double origin0; // double origin[3]
            public double origin1;
            public double origin2;
            public double scale_a;
            public double scale_b;
        }

        // ---- version and errors ----
        [DllImport(Library, CallingConvention = CallingConvention.Cdecl)]
        public static extern uint locd_version();
        [DllImport(Library, CallingConvention = CallingConvention.Cdecl)]
        public static extern IntPtr locd_version_string();
        [DllImport(Library, CallingConvention = CallingConvention.Cdecl)]
        public static extern IntPtr locd_status_string(int status);
        [DllImport(Library, CallingConvention = CallingConvention.Cdecl)]
        public static extern IntPtr locd_last_error();
        [DllImport(Library, CallingConvention = CallingConvention.Cdecl)]
        public static extern long locd_last_error_index();

        // ---- configuration and statistics ----
        [DllImport(Library, CallingConvention = CallingConvention.Cdecl)]
        public static extern void locd_engine_config_init(locd_engine_config* config);
        [DllImport(Library, CallingConvention = CallingConvention.Cdecl)]
        public static extern void locd_stats_init(locd_stats* stats);

        // ---- pairs buffer ----
        [DllImport(Library, CallingConvention = CallingConvention.Cdecl)]
        public static extern int locd_pairs_create(locd_allocator* allocator, IntPtr* out_pairs);
        [DllImport(Library, CallingConvention = CallingConvention.Cdecl)]
        public static extern void locd_pairs_destroy(IntPtr pairs);
        [DllImport(Library, CallingConvention = CallingConvention.Cdecl)]
        public static extern UIntPtr locd_pairs_count(IntPtr pairs);
        [DllImport(Library, CallingConvention = CallingConvention.Cdecl)]
        public static extern uint* locd_pairs_data(IntPtr pairs);
        [DllImport(Library, CallingConvention = CallingConvention.Cdecl)]
        public static extern int locd_pairs_sort(IntPtr pairs);
        [DllImport(Library, CallingConvention = CallingConvention.Cdecl)]
        public static extern void locd_pairs_clear(IntPtr pairs);

        // ---- engine ----
        [DllImport(Library, CallingConvention = CallingConvention.Cdecl)]
        public static extern int locd_engine_create(locd_engine_config* config, IntPtr* out_engine);
        [DllImport(Library, CallingConvention = CallingConvention.Cdecl)]
        public static extern void locd_engine_destroy(IntPtr engine);
        [DllImport(Library, CallingConvention = CallingConvention.Cdecl)]
        public static extern int locd_engine_level(IntPtr engine);
        [DllImport(Library, CallingConvention = CallingConvention.Cdecl)]
        public static extern uint locd_engine_threads(IntPtr engine);
        [DllImport(Library, CallingConvention = CallingConvention.Cdecl)]
        public static extern int locd_engine_find_pairs_f32(IntPtr engine, float* boxes, UIntPtr n, uint flags, IntPtr out_pairs);
        [DllImport(Library, CallingConvention = CallingConvention.Cdecl)]
        public static extern int locd_engine_find_pairs_f64(IntPtr engine, double* boxes, UIntPtr n, uint flags, IntPtr out_pairs);
        [DllImport(Library, CallingConvention = CallingConvention.Cdecl)]
        public static extern int locd_engine_find_pairs_f32_into(IntPtr engine, float* boxes, UIntPtr n, uint flags,
                                                                 uint* pairs, UIntPtr capacity, UIntPtr* count);
        [DllImport(Library, CallingConvention = CallingConvention.Cdecl)]
        public static extern int locd_engine_find_pairs_f64_into(IntPtr engine, double* boxes, UIntPtr n, uint flags,
                                                                 uint* pairs, UIntPtr capacity, UIntPtr* count);
        [DllImport(Library, CallingConvention = CallingConvention.Cdecl)]
        public static extern int locd_engine_last_pairs(IntPtr engine, uint** pairs, UIntPtr* count);
        [DllImport(Library, CallingConvention = CallingConvention.Cdecl)]
        public static extern int locd_engine_stats(IntPtr engine, locd_stats* stats);

        // ---- asynchronous jobs ----
        [DllImport(Library, CallingConvention = CallingConvention.Cdecl)]
        public static extern int locd_engine_submit_f32(IntPtr engine, float* boxes, UIntPtr n, uint flags, IntPtr* out_job);
        [DllImport(Library, CallingConvention = CallingConvention.Cdecl)]
        public static extern int locd_engine_submit_f64(IntPtr engine, double* boxes, UIntPtr n, uint flags, IntPtr* out_job);
        [DllImport(Library, CallingConvention = CallingConvention.Cdecl)]
        public static extern int locd_job_poll(IntPtr job);
        [DllImport(Library, CallingConvention = CallingConvention.Cdecl)]
        public static extern int locd_job_wait(IntPtr job, long timeout_ms);
        [DllImport(Library, CallingConvention = CallingConvention.Cdecl)]
        public static extern int locd_job_take(IntPtr job, IntPtr out_pairs);
        [DllImport(Library, CallingConvention = CallingConvention.Cdecl)]
        public static extern int locd_job_stats(IntPtr job, locd_stats* stats);
        [DllImport(Library, CallingConvention = CallingConvention.Cdecl)]
        public static extern int locd_job_cancel(IntPtr job);
        [DllImport(Library, CallingConvention = CallingConvention.Cdecl)]
        public static extern void locd_job_release(IntPtr job);

        // ---- building blocks (the paper's four steps) ----
        [DllImport(Library, CallingConvention = CallingConvention.Cdecl)]
        public static extern int locd_grid_fit_f32(float* boxes, UIntPtr n, uint max_depth, int cell_bias, uint flags, locd_grid* grid);
        [DllImport(Library, CallingConvention = CallingConvention.Cdecl)]
        public static extern int locd_grid_fit_f64(double* boxes, UIntPtr n, uint max_depth, int cell_bias, uint flags, locd_grid* grid);
        [DllImport(Library, CallingConvention = CallingConvention.Cdecl)]
        public static extern int locd_encode_f32(locd_grid* grid, float* boxes, UIntPtr first, UIntPtr count,
                                                 ulong* entries, UIntPtr capacity, UIntPtr* written);
        [DllImport(Library, CallingConvention = CallingConvention.Cdecl)]
        public static extern int locd_encode_f64(locd_grid* grid, double* boxes, UIntPtr first, UIntPtr count,
                                                 ulong* entries, UIntPtr capacity, UIntPtr* written);
        [DllImport(Library, CallingConvention = CallingConvention.Cdecl)]
        public static extern int locd_sort_entries(locd_grid* grid, ulong* entries, ulong* scratch, UIntPtr count);
        [DllImport(Library, CallingConvention = CallingConvention.Cdecl)]
        public static extern int locd_merge_entries(ulong** runs, UIntPtr* counts, UIntPtr k, ulong* out_entries);
        [DllImport(Library, CallingConvention = CallingConvention.Cdecl)]
        public static extern int locd_sweep_f32(locd_grid* grid, float* boxes, UIntPtr n, ulong* entries, UIntPtr count,
                                                IntPtr out_pairs, locd_stats* stats);
        [DllImport(Library, CallingConvention = CallingConvention.Cdecl)]
        public static extern int locd_sweep_f64(locd_grid* grid, double* boxes, UIntPtr n, ulong* entries, UIntPtr count,
                                                IntPtr out_pairs, locd_stats* stats);

        // ---- reference ----
        [DllImport(Library, CallingConvention = CallingConvention.Cdecl)]
        public static extern int locd_brute_force_f32(float* boxes, UIntPtr n, IntPtr out_pairs);
        [DllImport(Library, CallingConvention = CallingConvention.Cdecl)]
        public static extern int locd_brute_force_f64(double* boxes, UIntPtr n, IntPtr out_pairs);

        // ================================================================
        // Scene (include/locd/scene.h): a persistent broad phase with stable
        // ids. The safe layer is Locd.Scene (Scene.cs).
        // ================================================================

        public const uint LOCD_OBJECT_STATIC = 0x1;
        public const uint LOCD_SCENE_UPDATE_PAIRS = 0x1;
        public const uint LOCD_SCENE_UPDATE_EVENTS = 0x2;
        public const ulong LOCD_ID_NONE = 0;

        /// <summary>locd_scene_config; initialize with locd_scene_config_init.</summary>
        [StructLayout(LayoutKind.Sequential)]
        public struct locd_scene_config
        {
            public uint size;
            public uint flags;
            public ulong capacity_hint;
        }

        /// <summary>locd_scene_add_options; initialize with locd_scene_add_options_init.
        /// Each array pointer (n values) is used when not zero, the scalar otherwise.</summary>
        [StructLayout(LayoutKind.Sequential)]
        public struct locd_scene_add_options
        {
            public uint size;
            public uint flags;       // LOCD_OBJECT_STATIC
            public ulong category;
            public ulong mask;
            public ulong group;
            public ulong user;
            public IntPtr categories; // const uint64_t *
            public IntPtr masks;
            public IntPtr groups;
            public IntPtr users;
        }

        /// <summary>locd_scene_stats; initialize with locd_scene_stats_init.</summary>
        [StructLayout(LayoutKind.Sequential)]
        public struct locd_scene_stats
        {
            public uint size;
            public uint threads;
            public ulong objects;
            public ulong static_objects;
            public ulong moved;
            public ulong reencoded;
            public ulong entries;
            public ulong candidates;
            public ulong pairs;
            public ulong created;
            public ulong lost;
            public uint rebuilt;
            public uint reserved;
            public double ms_total;
            public double ms_encode;
            public double ms_merge;
            public double ms_sweep;
            public double ms_events;
        }

        [DllImport(Library, CallingConvention = CallingConvention.Cdecl)]
        public static extern void locd_scene_config_init(locd_scene_config* config);
        [DllImport(Library, CallingConvention = CallingConvention.Cdecl)]
        public static extern int locd_scene_create(IntPtr engine, locd_scene_config* config, IntPtr* out_scene);
        [DllImport(Library, CallingConvention = CallingConvention.Cdecl)]
        public static extern void locd_scene_destroy(IntPtr scene);
        [DllImport(Library, CallingConvention = CallingConvention.Cdecl)]
        public static extern UIntPtr locd_scene_count(IntPtr scene);
        [DllImport(Library, CallingConvention = CallingConvention.Cdecl)]
        public static extern void locd_scene_add_options_init(locd_scene_add_options* options);
        [DllImport(Library, CallingConvention = CallingConvention.Cdecl)]
        public static extern int locd_scene_add_f32(IntPtr scene, float* boxes, UIntPtr n, locd_scene_add_options* options, ulong* ids_out);
        [DllImport(Library, CallingConvention = CallingConvention.Cdecl)]
        public static extern int locd_scene_add_f64(IntPtr scene, double* boxes, UIntPtr n, locd_scene_add_options* options, ulong* ids_out);
        [DllImport(Library, CallingConvention = CallingConvention.Cdecl)]
        public static extern int locd_scene_move_f32(IntPtr scene, ulong* ids, float* boxes, UIntPtr n);
        [DllImport(Library, CallingConvention = CallingConvention.Cdecl)]
        public static extern int locd_scene_move_f64(IntPtr scene, ulong* ids, double* boxes, UIntPtr n);
        [DllImport(Library, CallingConvention = CallingConvention.Cdecl)]
        public static extern int locd_scene_remove(IntPtr scene, ulong* ids, UIntPtr n);
        [DllImport(Library, CallingConvention = CallingConvention.Cdecl)]
        public static extern int locd_scene_set_filter(IntPtr scene, ulong* ids, UIntPtr n, ulong* categories, ulong* masks, ulong* groups);
        [DllImport(Library, CallingConvention = CallingConvention.Cdecl)]
        public static extern int locd_scene_set_user(IntPtr scene, ulong* ids, UIntPtr n, ulong* users);
        [DllImport(Library, CallingConvention = CallingConvention.Cdecl)]
        public static extern int locd_scene_get_user(IntPtr scene, ulong* ids, UIntPtr n, ulong* users_out);
        [DllImport(Library, CallingConvention = CallingConvention.Cdecl)]
        public static extern int locd_scene_update(IntPtr scene, uint flags);
        [DllImport(Library, CallingConvention = CallingConvention.Cdecl)]
        public static extern int locd_scene_pairs(IntPtr scene, ulong** pairs, UIntPtr* count);
        [DllImport(Library, CallingConvention = CallingConvention.Cdecl)]
        public static extern int locd_scene_created(IntPtr scene, ulong** pairs, UIntPtr* count);
        [DllImport(Library, CallingConvention = CallingConvention.Cdecl)]
        public static extern int locd_scene_lost(IntPtr scene, ulong** pairs, UIntPtr* count);
        [DllImport(Library, CallingConvention = CallingConvention.Cdecl)]
        public static extern void locd_scene_stats_init(locd_scene_stats* stats);
        [DllImport(Library, CallingConvention = CallingConvention.Cdecl)]
        public static extern int locd_scene_stats_get(IntPtr scene, locd_scene_stats* stats);
        [DllImport(Library, CallingConvention = CallingConvention.Cdecl)]
        public static extern int locd_scene_query_box_f32(IntPtr scene, float* box, ulong mask, ulong* ids_out, UIntPtr capacity, UIntPtr* count);
        [DllImport(Library, CallingConvention = CallingConvention.Cdecl)]
        public static extern int locd_scene_query_box_f64(IntPtr scene, double* box, ulong mask, ulong* ids_out, UIntPtr capacity, UIntPtr* count);
        [DllImport(Library, CallingConvention = CallingConvention.Cdecl)]
        public static extern int locd_scene_query_point_f32(IntPtr scene, float* point, ulong mask, ulong* ids_out, UIntPtr capacity, UIntPtr* count);
        [DllImport(Library, CallingConvention = CallingConvention.Cdecl)]
        public static extern int locd_scene_query_point_f64(IntPtr scene, double* point, ulong mask, ulong* ids_out, UIntPtr capacity, UIntPtr* count);
        [DllImport(Library, CallingConvention = CallingConvention.Cdecl)]
        public static extern int locd_scene_raycast_f32(IntPtr scene, float* origin, float* direction, double max_t, ulong mask,
                                                        ulong* ids_out, double* t_out, UIntPtr capacity, UIntPtr* count);
        [DllImport(Library, CallingConvention = CallingConvention.Cdecl)]
        public static extern int locd_scene_raycast_f64(IntPtr scene, double* origin, double* direction, double max_t, ulong mask,
                                                        ulong* ids_out, double* t_out, UIntPtr capacity, UIntPtr* count);
        // ================================ end of scene ================================
    }
}
