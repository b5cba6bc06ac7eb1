// The raw declarations of service.h and pipeline.h called through P/Invoke
// (the safe layer wraps neither yet): signatures that reach the library and
// give the C answers. A build without the narrow phase (the Unity plugin)
// reports the pipeline test as skipped.
using System;
using System.Runtime.InteropServices;
using Locd;

namespace Locd.Tests
{
    static unsafe class NativeRaw
    {
        // Two unit spheres 1.5 apart overlap; a third far away does not.
        public static void PipelineSpheres()
        {
            IntPtr sphere;
            int st = Native.locd_shape_sphere(1.0, &sphere);
            if (st == (int)Status.Unsupported)
                throw new SkipException("this library was built without the narrow phase");
            Assert.Equal(0, st, "locd_shape_sphere");
            Assert.Equal(Native.LOCD_SHAPE_SPHERE, Native.locd_shape_kind(sphere), "locd_shape_kind");
            double[] poses = { 0, 0, 0, 0, 0, 0, 1,   1.5, 0, 0, 0, 0, 0, 1,   10, 0, 0, 0, 0, 0, 1 };
            double* box = stackalloc double[6];
            int hit;
            double* contact = stackalloc double[7];
            fixed (double* p = poses) {
                Assert.Equal(0, Native.locd_shape_aabb(sphere, p + 7, box), "locd_shape_aabb");
                Assert.Equal(0.5, box[0], "aabb min x");
                Assert.Equal(2.5, box[3], "aabb max x");
                Assert.Equal(0, Native.locd_shape_collide(sphere, p, sphere, p + 7, Native.LOCD_ROUTE_AUTO,
                                                          Native.LOCD_CONTACT_EPA, &hit, contact), "locd_shape_collide");
                Assert.Equal(1, hit, "spheres 1.5 apart collide");
                Assert.True(Math.Abs(contact[0] - 0.5) < 1e-6, "depth 0.5, got " + contact[0]);
            }
            IntPtr world, contacts;
            Assert.Equal(0, Native.locd_world_create(null, &world), "locd_world_create");
            Assert.Equal(0, Native.locd_contacts_create(&contacts), "locd_contacts_create");
            try {
                fixed (double* p = poses) {
                    for (int i = 0; i < 3; i++) {
                        uint index;
                        Assert.Equal(0, Native.locd_world_add(world, sphere, p + 7 * i, null, &index), "locd_world_add");
                        Assert.Equal((uint)i, index, "object index");
                    }
                }
                Assert.Equal(3ul, (ulong)Native.locd_world_count(world), "locd_world_count");
                Native.locd_pipeline_options o;
                Native.locd_pipeline_options_init(&o);
                o.stages = Native.LOCD_STAGE_SHAPE | Native.LOCD_STAGE_CONTACT;
                Native.locd_pipeline_stats s;
                Native.locd_pipeline_stats_init(&s);
                Assert.Equal(0, Native.locd_world_collide(world, &o, contacts, &s), "locd_world_collide");
                Assert.Equal(1ul, (ulong)Native.locd_contacts_count(contacts), "one colliding pair");
                uint* pairs = Native.locd_contacts_pairs(contacts);
                Assert.Equal(0u, pairs[0], "pair i");
                Assert.Equal(1u, pairs[1], "pair j");
                Assert.True(Native.locd_contacts_depth(contacts) != null, "contact stage ran");
                Assert.Equal(3u, s.objects, "stats.objects (layout of locd_pipeline_stats)");
            } finally {
                Native.locd_contacts_destroy(contacts);
                Native.locd_world_destroy(world);
                Native.locd_shape_destroy(sphere);
            }
        }

        // A TCP service on a free port: created, its address read, destroyed
        // without running. Where level 3 does not exist (Windows) creation says
        // Unsupported.
        public static void ServiceCreateDestroy()
        {
            Native.locd_service_config c;
            Native.locd_service_config_init(&c);
            IntPtr listen = Marshal.StringToHGlobalAnsi("tcp:127.0.0.1:0");
            IntPtr secret = Marshal.StringToHGlobalAnsi("raw-layer-test");
            try {
                c.listen = listen;
                c.secret = secret;
                c.threads = 1;
                IntPtr service;
                int st = Native.locd_service_create(&c, &service);
                if (st == (int)Status.Unsupported)
                    throw new SkipException("this library has no level 3");
                Assert.Equal(0, st, "locd_service_create: " + Marshal.PtrToStringAnsi(Native.locd_last_error()));
                string address = Marshal.PtrToStringAnsi(Native.locd_service_address(service));
                Assert.True(address.StartsWith("tcp:127.0.0.1:") && !address.EndsWith(":0"), "bound address " + address);
                Native.locd_service_stop(service);
                Native.locd_service_destroy(service);
            } finally {
                Marshal.FreeHGlobal(listen);
                Marshal.FreeHGlobal(secret);
            }
        }
    }
}
