// Raw layer over the public C ABI of locd: every function exported by the
// library (include/locd/locd.h, service.h, pipeline.h, scene.h) has its
// DllImport here; CI compares the entry points with the library's exports
// (bindings/csharp/tests/native-coverage.sh).
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
        /// <summary>The job exceeds a limit of the service (boxes, pairs, memory, time, jobs in flight); only it failed.</summary>
        Limit = -22,
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

    /// <summary>P/Invoke declarations for liblocd, one per exported function
    /// (checked against the library's export table in CI).</summary>
    public static unsafe class Native
    {
        // iOS (and WebGL) link native plugins statically into the player:
        // there the library is found in the main executable as "__Internal".
#if (UNITY_IOS || UNITY_WEBGL) && !UNITY_EDITOR
        public const string Library = "__Internal";
        public const string NarrowLibrary = "__Internal";
#else
        public const string Library = "locd";
        /// <summary>The functions of locd/pipeline.h (shapes, world, pipeline) live in
        /// liblocd_narrow, beside liblocd (docs/abi.md, "Two libraries"): declare them
        /// with [DllImport(NarrowLibrary)].</summary>
        public const string NarrowLibrary = "locd_narrow";
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
            public long service_timeout_ms; // level 3 job deadline; 0 = default, < 0 = none
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

        /// <summary>locd_service_config (service.h); initialize with locd_service_config_init.</summary>
        [StructLayout(LayoutKind.Sequential)]
        public struct locd_service_config
        {
            public uint size;
            public IntPtr listen;      // const char *
            public IntPtr secret;      // const char *
            public uint threads;
            public uint engine_threads;
            public ulong max_message;
            public uint max_clients;
            public uint max_jobs;
            public IntPtr log;         // locd_log_fn
            public IntPtr log_user;
            // Limits and deadlines (docs/levels.md, "Limits and deadlines"); 0 = the default.
            public uint auth_timeout_ms;
            public uint message_timeout_ms;
            public uint send_timeout_ms;
            public uint max_job_ms;
            public ulong max_job_boxes;
            public ulong max_job_pairs;
            public ulong max_job_memory;
            public ulong max_client_boxes;
            public ulong max_client_pairs;
            public ulong max_client_memory;
        }

        public const int LOCD_SHAPE_SPHERE = 1;
        public const int LOCD_SHAPE_BOX = 2;
        public const int LOCD_SHAPE_CAPSULE = 3;
        public const int LOCD_SHAPE_CONVEX = 4;
        public const int LOCD_SHAPE_MESH = 5;
        public const int LOCD_SHAPE_KINDS = 8;
        public const uint LOCD_STAGE_SHAPE = 0x1;
        public const uint LOCD_STAGE_CONTACT = 0x2;
        public const int LOCD_SWEPT_OFF = 0;
        public const int LOCD_SWEPT_ON = 1;
        public const int LOCD_SWEPT_AUTO = 2;
        public const int LOCD_ROUTE_AUTO = 0;
        public const int LOCD_ROUTE_BOX = 1;
        public const int LOCD_ROUTE_CLOSED = 2;
        public const int LOCD_ROUTE_CCD = 3;
        public const int LOCD_ROUTE_FCL = 4;
        public const int LOCD_CONTACT_EPA = 0;
        public const int LOCD_CONTACT_MPR = 1;

        /// <summary>locd_pipeline_options (pipeline.h); initialize with locd_pipeline_options_init.</summary>
        [StructLayout(LayoutKind.Sequential)]
        public struct locd_pipeline_options
        {
            public uint size;
            public uint stages;
            public int swept;
            public int contact_method;
            public double dt;
            public double swept_threshold;
            public uint find_flags;
            public uint reserved;
            public fixed byte route[LOCD_SHAPE_KINDS * LOCD_SHAPE_KINDS]; // route[a * LOCD_SHAPE_KINDS + b]
        }

        /// <summary>locd_stage_stats (pipeline.h), one per stage of locd_pipeline_stats.</summary>
        [StructLayout(LayoutKind.Sequential)]
        public struct locd_stage_stats
        {
            public ulong calls;
            public ulong pairs_in;
            public ulong pairs_out;
            public ulong tests;
            public double ms;
        }

        /// <summary>locd_pipeline_stats (pipeline.h); initialize with locd_pipeline_stats_init.</summary>
        [StructLayout(LayoutKind.Sequential)]
        public struct locd_pipeline_stats
        {
            public uint size;
            public uint objects;
            public uint swept_objects;
            public uint reserved;
            public locd_stage_stats broad;
            public locd_stage_stats shape;
            public locd_stage_stats swept;
            public locd_stage_stats contact;
            public ulong tests_closed;
            public ulong tests_ccd;
            public ulong tests_fcl;
            public double ms_total;
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
        public static extern int locd_engine_find_pairs_between_f32(IntPtr engine, float* a, UIntPtr na, float* b,
                                                                    UIntPtr nb, uint flags, IntPtr out_pairs);
        [DllImport(Library, CallingConvention = CallingConvention.Cdecl)]
        public static extern int locd_engine_find_pairs_between_f64(IntPtr engine, double* a, UIntPtr na, double* b,
                                                                    UIntPtr nb, uint flags, IntPtr out_pairs);
        [DllImport(Library, CallingConvention = CallingConvention.Cdecl)]
        public static extern int locd_engine_find_pairs_f32_into(IntPtr engine, float* boxes, UIntPtr n, uint flags,
                                                                 uint* pairs, UIntPtr capacity, UIntPtr* count);
        [DllImport(Library, CallingConvention = CallingConvention.Cdecl)]
        public static extern int locd_engine_find_pairs_f64_into(IntPtr engine, double* boxes, UIntPtr n, uint flags,
                                                                 uint* pairs, UIntPtr capacity, UIntPtr* count);
        [DllImport(Library, CallingConvention = CallingConvention.Cdecl)]
        public static extern int locd_engine_last_pairs(IntPtr engine, uint** pairs, UIntPtr* count);
        [DllImport(Library, CallingConvention = CallingConvention.Cdecl)]
        public static extern int locd_engine_get_stats(IntPtr engine, locd_stats* stats);
        // Deprecated: the same as locd_engine_get_stats.
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
        public static extern int locd_job_get_stats(IntPtr job, locd_stats* stats);
        // Deprecated: the same as locd_job_get_stats.
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

        // ---- the level-3 service (service.h); LOCD_ERR_UNSUPPORTED on Windows ----
        [DllImport(Library, CallingConvention = CallingConvention.Cdecl)]
        public static extern void locd_service_config_init(locd_service_config* config);
        [DllImport(Library, CallingConvention = CallingConvention.Cdecl)]
        public static extern int locd_service_create(locd_service_config* config, IntPtr* out_service);
        [DllImport(Library, CallingConvention = CallingConvention.Cdecl)]
        public static extern IntPtr locd_service_address(IntPtr service);
        [DllImport(Library, CallingConvention = CallingConvention.Cdecl)]
        public static extern int locd_service_run(IntPtr service);
        [DllImport(Library, CallingConvention = CallingConvention.Cdecl)]
        public static extern void locd_service_stop(IntPtr service);
        [DllImport(Library, CallingConvention = CallingConvention.Cdecl)]
        public static extern void locd_service_destroy(IntPtr service);

        // ---- narrow phase: shapes (pipeline.h); LOCD_ERR_UNSUPPORTED without libccd/FCL ----
        [DllImport(NarrowLibrary, CallingConvention = CallingConvention.Cdecl)]
        public static extern int locd_shape_sphere(double radius, IntPtr* out_shape);
        [DllImport(NarrowLibrary, CallingConvention = CallingConvention.Cdecl)]
        public static extern int locd_shape_box(double half_x, double half_y, double half_z, IntPtr* out_shape);
        [DllImport(NarrowLibrary, CallingConvention = CallingConvention.Cdecl)]
        public static extern int locd_shape_capsule(double radius, double half_length, IntPtr* out_shape);
        [DllImport(NarrowLibrary, CallingConvention = CallingConvention.Cdecl)]
        public static extern int locd_shape_convex(double* points, UIntPtr count, IntPtr* out_shape);
        [DllImport(NarrowLibrary, CallingConvention = CallingConvention.Cdecl)]
        public static extern int locd_shape_mesh(double* vertices, UIntPtr vertex_count, uint* triangles,
                                                 UIntPtr triangle_count, IntPtr* out_shape);
        [DllImport(NarrowLibrary, CallingConvention = CallingConvention.Cdecl)]
        public static extern void locd_shape_destroy(IntPtr shape);
        [DllImport(NarrowLibrary, CallingConvention = CallingConvention.Cdecl)]
        public static extern int locd_shape_kind(IntPtr shape);
        [DllImport(NarrowLibrary, CallingConvention = CallingConvention.Cdecl)]
        public static extern int locd_shape_aabb(IntPtr shape, double* pose, double* box);
        [DllImport(NarrowLibrary, CallingConvention = CallingConvention.Cdecl)]
        public static extern int locd_shape_collide(IntPtr a, double* pose_a, IntPtr b, double* pose_b, int route,
                                                    int contact_method, int* hit, double* contact);

        // ---- narrow phase: options, statistics, contacts, world (pipeline.h) ----
        [DllImport(NarrowLibrary, CallingConvention = CallingConvention.Cdecl)]
        public static extern void locd_pipeline_options_init(locd_pipeline_options* options);
        [DllImport(NarrowLibrary, CallingConvention = CallingConvention.Cdecl)]
        public static extern int locd_pipeline_options_route(locd_pipeline_options* options, int kind_a, int kind_b, int route);
        [DllImport(NarrowLibrary, CallingConvention = CallingConvention.Cdecl)]
        public static extern void locd_pipeline_stats_init(locd_pipeline_stats* stats);
        [DllImport(NarrowLibrary, CallingConvention = CallingConvention.Cdecl)]
        public static extern int locd_contacts_create(IntPtr* out_contacts);
        [DllImport(NarrowLibrary, CallingConvention = CallingConvention.Cdecl)]
        public static extern void locd_contacts_destroy(IntPtr contacts);
        [DllImport(NarrowLibrary, CallingConvention = CallingConvention.Cdecl)]
        public static extern UIntPtr locd_contacts_count(IntPtr contacts);
        [DllImport(NarrowLibrary, CallingConvention = CallingConvention.Cdecl)]
        public static extern uint* locd_contacts_pairs(IntPtr contacts);
        [DllImport(NarrowLibrary, CallingConvention = CallingConvention.Cdecl)]
        public static extern double* locd_contacts_toi(IntPtr contacts);
        [DllImport(NarrowLibrary, CallingConvention = CallingConvention.Cdecl)]
        public static extern double* locd_contacts_depth(IntPtr contacts);
        [DllImport(NarrowLibrary, CallingConvention = CallingConvention.Cdecl)]
        public static extern double* locd_contacts_normal(IntPtr contacts);
        [DllImport(NarrowLibrary, CallingConvention = CallingConvention.Cdecl)]
        public static extern double* locd_contacts_point(IntPtr contacts);
        [DllImport(NarrowLibrary, CallingConvention = CallingConvention.Cdecl)]
        public static extern int locd_world_create(locd_engine_config* config, IntPtr* out_world);
        [DllImport(NarrowLibrary, CallingConvention = CallingConvention.Cdecl)]
        public static extern void locd_world_destroy(IntPtr world);
        [DllImport(NarrowLibrary, CallingConvention = CallingConvention.Cdecl)]
        public static extern int locd_world_add(IntPtr world, IntPtr shape, double* pose, double* velocity, uint* index);
        [DllImport(NarrowLibrary, CallingConvention = CallingConvention.Cdecl)]
        public static extern UIntPtr locd_world_count(IntPtr world);
        [DllImport(NarrowLibrary, CallingConvention = CallingConvention.Cdecl)]
        public static extern int locd_world_set_pose(IntPtr world, uint index, double* pose);
        [DllImport(NarrowLibrary, CallingConvention = CallingConvention.Cdecl)]
        public static extern int locd_world_set_velocity(IntPtr world, uint index, double* velocity);
        [DllImport(NarrowLibrary, CallingConvention = CallingConvention.Cdecl)]
        public static extern int locd_world_set_poses(IntPtr world, double* poses, UIntPtr count);
        [DllImport(NarrowLibrary, CallingConvention = CallingConvention.Cdecl)]
        public static extern int locd_world_set_velocities(IntPtr world, double* velocities, UIntPtr count);
        [DllImport(NarrowLibrary, CallingConvention = CallingConvention.Cdecl)]
        public static extern int locd_world_get_pose(IntPtr world, uint index, double* pose);
        [DllImport(NarrowLibrary, CallingConvention = CallingConvention.Cdecl)]
        public static extern int locd_world_collide(IntPtr world, locd_pipeline_options* options, IntPtr contacts,
                                                    locd_pipeline_stats* stats);
        [DllImport(NarrowLibrary, CallingConvention = CallingConvention.Cdecl)]
        public static extern int locd_world_remove(IntPtr world, uint index);
        [DllImport(NarrowLibrary, CallingConvention = CallingConvention.Cdecl)]
        public static extern int locd_world_set_filter(IntPtr world, uint index, ulong category, ulong mask, ulong group);
        [DllImport(NarrowLibrary, CallingConvention = CallingConvention.Cdecl)]
        public static extern int locd_world_contact_events(IntPtr world, uint** began, UIntPtr* began_count,
                                                           uint** ended, UIntPtr* ended_count);
        // ================================================================
        // Scene (include/locd/scene.h): a persistent broad phase with stable
        // ids. The safe layer is Locd.Scene (Scene.cs).
        // ================================================================

        public const uint LOCD_OBJECT_STATIC = 0x1;
        public const uint LOCD_SCENE_UPDATE_PAIRS = 0x1;
        public const uint LOCD_SCENE_UPDATE_EVENTS = 0x2;
        /// <summary>locd_scene_config.flags: the scene never builds its near-pair list (docs/scene.md).</summary>
        public const uint LOCD_SCENE_NO_NEAR_LIST = 0x1;
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
            public uint coasted;
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
        public static extern int locd_scene_get_stats(IntPtr scene, locd_scene_stats* stats);
        // Deprecated: the same as locd_scene_get_stats.
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

        // ---- queries with a filter, sphere and cast queries, batches (scene.h) ----
        public const uint LOCD_HIT_ALL = 0;
        public const uint LOCD_HIT_CLOSEST = 1;
        public const uint LOCD_HIT_ANY = 2;

        /// <summary>int (*)(void *user, locd_id id, uint64_t user_value): nonzero rejects the candidate.</summary>
        [UnmanagedFunctionPointer(CallingConvention.Cdecl)]
        public delegate int locd_query_reject_fn(IntPtr user, ulong id, ulong user_value);

        /// <summary>locd_query_filter; initialize with locd_query_filter_init.</summary>
        [StructLayout(LayoutKind.Sequential)]
        public struct locd_query_filter
        {
            public uint size;
            public uint reserved;
            public ulong mask;
            public IntPtr reject; // locd_query_reject_fn, or zero
            public IntPtr user;
        }

        [DllImport(Library, CallingConvention = CallingConvention.Cdecl)]
        public static extern int locd_scene_prepare_queries(IntPtr scene);
        [DllImport(Library, CallingConvention = CallingConvention.Cdecl)]
        public static extern void locd_query_filter_init(locd_query_filter* filter);
        [DllImport(Library, CallingConvention = CallingConvention.Cdecl)]
        public static extern int locd_scene_overlap_box_f32(IntPtr scene, float* box, locd_query_filter* filter,
                                                            ulong* ids_out, UIntPtr capacity, UIntPtr* count);
        [DllImport(Library, CallingConvention = CallingConvention.Cdecl)]
        public static extern int locd_scene_overlap_box_f64(IntPtr scene, double* box, locd_query_filter* filter,
                                                            ulong* ids_out, UIntPtr capacity, UIntPtr* count);
        [DllImport(Library, CallingConvention = CallingConvention.Cdecl)]
        public static extern int locd_scene_overlap_point_f32(IntPtr scene, float* point, locd_query_filter* filter,
                                                              ulong* ids_out, UIntPtr capacity, UIntPtr* count);
        [DllImport(Library, CallingConvention = CallingConvention.Cdecl)]
        public static extern int locd_scene_overlap_point_f64(IntPtr scene, double* point, locd_query_filter* filter,
                                                              ulong* ids_out, UIntPtr capacity, UIntPtr* count);
        [DllImport(Library, CallingConvention = CallingConvention.Cdecl)]
        public static extern int locd_scene_overlap_sphere_f32(IntPtr scene, float* center, double radius,
                                                               locd_query_filter* filter, ulong* ids_out,
                                                               UIntPtr capacity, UIntPtr* count);
        [DllImport(Library, CallingConvention = CallingConvention.Cdecl)]
        public static extern int locd_scene_overlap_sphere_f64(IntPtr scene, double* center, double radius,
                                                               locd_query_filter* filter, ulong* ids_out,
                                                               UIntPtr capacity, UIntPtr* count);
        [DllImport(Library, CallingConvention = CallingConvention.Cdecl)]
        public static extern int locd_scene_cast_ray_f32(IntPtr scene, float* origin, float* direction, double max_t,
                                                         uint mode, locd_query_filter* filter, ulong* ids_out,
                                                         double* t_out, UIntPtr capacity, UIntPtr* count);
        [DllImport(Library, CallingConvention = CallingConvention.Cdecl)]
        public static extern int locd_scene_cast_ray_f64(IntPtr scene, double* origin, double* direction,
                                                         double max_t, uint mode, locd_query_filter* filter,
                                                         ulong* ids_out, double* t_out, UIntPtr capacity,
                                                         UIntPtr* count);
        [DllImport(Library, CallingConvention = CallingConvention.Cdecl)]
        public static extern int locd_scene_cast_box_f32(IntPtr scene, float* box, float* direction, double max_t,
                                                         uint mode, locd_query_filter* filter, ulong* ids_out,
                                                         double* t_out, UIntPtr capacity, UIntPtr* count);
        [DllImport(Library, CallingConvention = CallingConvention.Cdecl)]
        public static extern int locd_scene_cast_box_f64(IntPtr scene, double* box, double* direction, double max_t,
                                                         uint mode, locd_query_filter* filter, ulong* ids_out,
                                                         double* t_out, UIntPtr capacity, UIntPtr* count);
        [DllImport(Library, CallingConvention = CallingConvention.Cdecl)]
        public static extern int locd_hits_create(locd_allocator* allocator, IntPtr* out_hits);
        [DllImport(Library, CallingConvention = CallingConvention.Cdecl)]
        public static extern void locd_hits_destroy(IntPtr hits);
        [DllImport(Library, CallingConvention = CallingConvention.Cdecl)]
        public static extern UIntPtr locd_hits_queries(IntPtr hits);
        [DllImport(Library, CallingConvention = CallingConvention.Cdecl)]
        public static extern UIntPtr locd_hits_count(IntPtr hits);
        [DllImport(Library, CallingConvention = CallingConvention.Cdecl)]
        public static extern ulong* locd_hits_offsets(IntPtr hits);
        [DllImport(Library, CallingConvention = CallingConvention.Cdecl)]
        public static extern ulong* locd_hits_ids(IntPtr hits);
        [DllImport(Library, CallingConvention = CallingConvention.Cdecl)]
        public static extern double* locd_hits_t(IntPtr hits);
        [DllImport(Library, CallingConvention = CallingConvention.Cdecl)]
        public static extern int locd_scene_cast_ray_batch_f32(IntPtr scene, float* origins, float* directions,
                                                               double* max_t, UIntPtr n, uint mode,
                                                               locd_query_filter* filter, IntPtr hits);
        [DllImport(Library, CallingConvention = CallingConvention.Cdecl)]
        public static extern int locd_scene_cast_ray_batch_f64(IntPtr scene, double* origins, double* directions,
                                                               double* max_t, UIntPtr n, uint mode,
                                                               locd_query_filter* filter, IntPtr hits);
        [DllImport(Library, CallingConvention = CallingConvention.Cdecl)]
        public static extern int locd_scene_cast_box_batch_f32(IntPtr scene, float* boxes, float* directions,
                                                               double* max_t, UIntPtr n, uint mode,
                                                               locd_query_filter* filter, IntPtr hits);
        [DllImport(Library, CallingConvention = CallingConvention.Cdecl)]
        public static extern int locd_scene_cast_box_batch_f64(IntPtr scene, double* boxes, double* directions,
                                                               double* max_t, UIntPtr n, uint mode,
                                                               locd_query_filter* filter, IntPtr hits);
        [DllImport(Library, CallingConvention = CallingConvention.Cdecl)]
        public static extern int locd_scene_overlap_box_batch_f32(IntPtr scene, float* boxes, UIntPtr n,
                                                                  locd_query_filter* filter, IntPtr hits);
        [DllImport(Library, CallingConvention = CallingConvention.Cdecl)]
        public static extern int locd_scene_overlap_box_batch_f64(IntPtr scene, double* boxes, UIntPtr n,
                                                                  locd_query_filter* filter, IntPtr hits);
        [DllImport(Library, CallingConvention = CallingConvention.Cdecl)]
        public static extern int locd_scene_overlap_point_batch_f32(IntPtr scene, float* points, UIntPtr n,
                                                                    locd_query_filter* filter, IntPtr hits);
        [DllImport(Library, CallingConvention = CallingConvention.Cdecl)]
        public static extern int locd_scene_overlap_point_batch_f64(IntPtr scene, double* points, UIntPtr n,
                                                                    locd_query_filter* filter, IntPtr hits);
        [DllImport(Library, CallingConvention = CallingConvention.Cdecl)]
        public static extern int locd_scene_overlap_sphere_batch_f32(IntPtr scene, float* centers, double* radii,
                                                                     UIntPtr n, locd_query_filter* filter,
                                                                     IntPtr hits);
        [DllImport(Library, CallingConvention = CallingConvention.Cdecl)]
        public static extern int locd_scene_overlap_sphere_batch_f64(IntPtr scene, double* centers, double* radii,
                                                                     UIntPtr n, locd_query_filter* filter,
                                                                     IntPtr hits);
        // ================================ end of scene ================================
    }
}
