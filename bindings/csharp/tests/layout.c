/* Prints the size and field offsets of the public structs as the C compiler
 * lays them out from the real header, one "name value" per line. The C# test
 * runner compares them with Marshal.SizeOf / Marshal.OffsetOf of the structs
 * mirrored in Native.cs. */
#include <locd/locd.h>
#include <locd/pipeline.h>
#include <locd/scene.h>
#include <locd/service.h>

#include <stddef.h>
#include <stdio.h>

#define SIZE(T) printf(#T " %zu\n", sizeof(T))
#define OFF(T, f) printf(#T "." #f " %zu\n", offsetof(T, f))
#define OFFN(T, f, name, extra) printf(#T "." name " %zu\n", offsetof(T, f) + (extra))

int main(void)
{
    SIZE(locd_allocator);
    OFF(locd_allocator, alloc);
    OFF(locd_allocator, free);
    OFF(locd_allocator, user);

    SIZE(locd_engine_config);
    OFF(locd_engine_config, size);
    OFF(locd_engine_config, level);
    OFF(locd_engine_config, threads);
    OFF(locd_engine_config, max_depth);
    OFF(locd_engine_config, cell_bias);
    OFF(locd_engine_config, flags);
    OFF(locd_engine_config, service_address);
    OFF(locd_engine_config, service_secret);
    OFF(locd_engine_config, worker_path);
    OFF(locd_engine_config, allocator);
    OFF(locd_engine_config, log);
    OFF(locd_engine_config, log_user);
    OFF(locd_engine_config, service_timeout_ms);

    SIZE(locd_stats);
    OFF(locd_stats, size);
    OFF(locd_stats, threads);
    OFF(locd_stats, objects);
    OFF(locd_stats, entries);
    OFF(locd_stats, candidates);
    OFF(locd_stats, exact_tests);
    OFF(locd_stats, pairs);
    OFF(locd_stats, depth);
    OFF(locd_stats, reserved);
    OFF(locd_stats, ms_total);
    OFF(locd_stats, ms_bounds);
    OFF(locd_stats, ms_encode);
    OFF(locd_stats, ms_sort);
    OFF(locd_stats, ms_merge);
    OFF(locd_stats, ms_sweep);
    OFF(locd_stats, ms_order);
    OFF(locd_stats, ms_transfer);

    SIZE(locd_grid);
    OFF(locd_grid, size);
    OFF(locd_grid, depth);
    OFF(locd_grid, cell_bias);
    OFF(locd_grid, index_bits);
    OFF(locd_grid, flags);
    OFF(locd_grid, reserved);
    OFFN(locd_grid, origin, "origin0", 0);
    OFFN(locd_grid, origin, "origin1", sizeof(double));
    OFFN(locd_grid, origin, "origin2", 2 * sizeof(double));
    OFF(locd_grid, scale_a);
    OFF(locd_grid, scale_b);

    SIZE(locd_service_config);
    OFF(locd_service_config, size);
    OFF(locd_service_config, listen);
    OFF(locd_service_config, secret);
    OFF(locd_service_config, threads);
    OFF(locd_service_config, engine_threads);
    OFF(locd_service_config, max_message);
    OFF(locd_service_config, max_clients);
    OFF(locd_service_config, max_jobs);
    OFF(locd_service_config, log);
    OFF(locd_service_config, log_user);
    OFF(locd_service_config, auth_timeout_ms);
    OFF(locd_service_config, message_timeout_ms);
    OFF(locd_service_config, send_timeout_ms);
    OFF(locd_service_config, max_job_ms);
    OFF(locd_service_config, max_job_boxes);
    OFF(locd_service_config, max_job_pairs);
    OFF(locd_service_config, max_job_memory);
    OFF(locd_service_config, max_client_boxes);
    OFF(locd_service_config, max_client_pairs);
    OFF(locd_service_config, max_client_memory);

    SIZE(locd_pipeline_options);
    OFF(locd_pipeline_options, size);
    OFF(locd_pipeline_options, stages);
    OFF(locd_pipeline_options, swept);
    OFF(locd_pipeline_options, contact_method);
    OFF(locd_pipeline_options, dt);
    OFF(locd_pipeline_options, swept_threshold);
    OFF(locd_pipeline_options, find_flags);
    OFF(locd_pipeline_options, reserved);
    OFF(locd_pipeline_options, route);

    SIZE(locd_stage_stats);
    OFF(locd_stage_stats, calls);
    OFF(locd_stage_stats, pairs_in);
    OFF(locd_stage_stats, pairs_out);
    OFF(locd_stage_stats, tests);
    OFF(locd_stage_stats, ms);

    SIZE(locd_pipeline_stats);
    OFF(locd_pipeline_stats, size);
    OFF(locd_pipeline_stats, objects);
    OFF(locd_pipeline_stats, swept_objects);
    OFF(locd_pipeline_stats, reserved);
    OFF(locd_pipeline_stats, broad);
    OFF(locd_pipeline_stats, shape);
    OFF(locd_pipeline_stats, swept);
    OFF(locd_pipeline_stats, contact);
    OFF(locd_pipeline_stats, tests_closed);
    OFF(locd_pipeline_stats, tests_ccd);
    OFF(locd_pipeline_stats, tests_fcl);
    OFF(locd_pipeline_stats, ms_total);

    SIZE(locd_scene_config);
    OFF(locd_scene_config, size);
    OFF(locd_scene_config, flags);
    OFF(locd_scene_config, capacity_hint);

    SIZE(locd_scene_add_options);
    OFF(locd_scene_add_options, size);
    OFF(locd_scene_add_options, flags);
    OFF(locd_scene_add_options, category);
    OFF(locd_scene_add_options, mask);
    OFF(locd_scene_add_options, group);
    OFF(locd_scene_add_options, user);
    OFF(locd_scene_add_options, categories);
    OFF(locd_scene_add_options, masks);
    OFF(locd_scene_add_options, groups);
    OFF(locd_scene_add_options, users);

    SIZE(locd_scene_stats);
    OFF(locd_scene_stats, size);
    OFF(locd_scene_stats, threads);
    OFF(locd_scene_stats, objects);
    OFF(locd_scene_stats, static_objects);
    OFF(locd_scene_stats, moved);
    OFF(locd_scene_stats, reencoded);
    OFF(locd_scene_stats, entries);
    OFF(locd_scene_stats, candidates);
    OFF(locd_scene_stats, pairs);
    OFF(locd_scene_stats, created);
    OFF(locd_scene_stats, lost);
    OFF(locd_scene_stats, rebuilt);
    OFF(locd_scene_stats, coasted);
    OFF(locd_scene_stats, ms_total);
    OFF(locd_scene_stats, ms_encode);
    OFF(locd_scene_stats, ms_merge);
    OFF(locd_scene_stats, ms_sweep);
    OFF(locd_scene_stats, ms_events);
    SIZE(locd_query_filter);
    OFF(locd_query_filter, size);
    OFF(locd_query_filter, reserved);
    OFF(locd_query_filter, mask);
    OFF(locd_query_filter, reject);
    OFF(locd_query_filter, user);

    return 0;
}
