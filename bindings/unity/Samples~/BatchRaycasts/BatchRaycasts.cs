// Sample: thousands of raycasts per frame against a locd Scene, in one call.
//
// Add this component to an empty GameObject and press Play. It fills a locd Scene with
// `obstacleCount` boxes around itself (stand-ins for your level's colliders), moves a few of them
// every frame, and every frame casts `rayCount` rays from this GameObject in all directions (a
// "lidar" sweep) with ONE call: Scene.RaycastBatch. Hits are drawn with Debug.DrawLine (Scene
// view, or the Game view with Gizmos on).
//
// Why a batch: a single query pays a native call, a lock and a setup per ray; a batch pays them
// once and spreads the rays over the scene's worker threads. The answers are the same whatever
// the thread count.
//
// Per frame this allocates nothing: the rays live in NativeArrays created once (the pointer
// overload of RaycastBatch reads their memory directly), and the answers land in one QueryHits
// buffer reused every frame. Pointers need unsafe code, so the sample has its own assembly
// (BatchRaycasts.asmdef, allowUnsafeCode). Without unsafe code, use the float[] overloads.
using Locd;
using Unity.Collections;
using Unity.Collections.LowLevel.Unsafe;
using UnityEngine;

namespace Locd.Samples
{
    public sealed unsafe class BatchRaycasts : MonoBehaviour
    {
        [Header("Rays")]
        [Tooltip("Rays cast every frame, all in one batch")]
        public int rayCount = 4096;
        [Tooltip("How far each ray looks (world units)")]
        public float rayLength = 60f;
        [Tooltip("Closest: the first box each ray meets. Any: whether it meets one (line of sight, "
                 + "the cheapest). All: every box along the ray, nearest first")]
        public HitMode mode = HitMode.Closest;

        [Header("Obstacles (boxes in a locd Scene)")]
        public int obstacleCount = 3000;
        public float extent = 50f;
        [Tooltip("Obstacles moved every frame (queries always see the scene as it is now)")]
        public int movedPerFrame = 200;

        [Header("Engine")]
        [Tooltip("Worker threads of the scene; 0 = one per core")]
        public int threads = 0;

        [Header("Drawing")]
        public int maxRaysDrawn = 1024;
        public Color hitColor = new Color(1f, 0.35f, 0.1f, 1f);
        public Color missColor = new Color(0.3f, 0.8f, 1f, 0.25f);

        /// <summary>Rays that hit a box in the last frame.</summary>
        public int RaysThatHit { get; private set; }
        /// <summary>Time of the last RaycastBatch call, in milliseconds.</summary>
        public double LastBatchMs { get; private set; }

        Scene scene;
        QueryHits hits;                // the answers of the last batch, reused every frame
        NativeArray<float> origins;    // 3 floats per ray: x, y, z
        NativeArray<float> directions; // 3 floats per ray
        NativeArray<double> maxT;      // 1 per ray: how far along its direction it looks
        ulong[] obstacleIds;           // the scene's id of each obstacle (stable, never reused)
        float[] obstacleBoxes;         // 6 floats per obstacle: min x y z, max x y z
        ulong[] movedIds;              // this frame's moved obstacles (reused)
        float[] movedBoxes;
        int nextToMove;
        readonly System.Diagnostics.Stopwatch watch = new System.Diagnostics.Stopwatch();

        void OnEnable()
        {
            scene = new Scene(threads);
            hits = new QueryHits();

            // The obstacles: random boxes around this GameObject, added in one call. Each user value
            // is the obstacle's index, so a hit's id leads back to it: scene.GetUser(id).
            obstacleBoxes = new float[6 * obstacleCount];
            var indices = new ulong[obstacleCount];
            Vector3 center = transform.position;
            for (int i = 0; i < obstacleCount; i++) {
                Vector3 size = new Vector3(Random.Range(0.5f, 3f), Random.Range(0.5f, 3f), Random.Range(0.5f, 3f));
                Vector3 at = center + new Vector3(Random.Range(-extent, extent), Random.Range(-extent, extent),
                                                  Random.Range(-extent, extent));
                SetBox(obstacleBoxes, i, at, size);
                indices[i] = (ulong)i;
            }
            obstacleIds = scene.Add(obstacleBoxes, new SceneAddOptions { Users = indices });
            movedIds = new ulong[Mathf.Min(movedPerFrame, obstacleCount)];
            movedBoxes = new float[6 * movedIds.Length];

            // The rays' inputs, in native memory for as long as the component is enabled.
            origins = new NativeArray<float>(3 * rayCount, Allocator.Persistent);
            directions = new NativeArray<float>(3 * rayCount, Allocator.Persistent);
            maxT = new NativeArray<double>(rayCount, Allocator.Persistent);
        }

        void OnDisable()
        {
            // Native memory and the scene's worker threads are not garbage collected: free them now.
            if (origins.IsCreated) origins.Dispose();
            if (directions.IsCreated) directions.Dispose();
            if (maxT.IsCreated) maxT.Dispose();
            if (hits != null) hits.Dispose();
            if (scene != null) scene.Dispose();
            hits = null;
            scene = null;
        }

        void Update()
        {
            if (scene == null)
                return;
            MoveSomeObstacles();
            AimRays();

            // One call for every ray. Only the pointers are passed: nothing is copied or allocated.
            var o = (float*)NativeArrayUnsafeUtility.GetUnsafeReadOnlyPtr(origins);
            var d = (float*)NativeArrayUnsafeUtility.GetUnsafeReadOnlyPtr(directions);
            var t = (double*)NativeArrayUnsafeUtility.GetUnsafeReadOnlyPtr(maxT);
            watch.Reset();
            watch.Start();
            try {
                scene.RaycastBatch(o, d, t, rayCount, mode, hits);
            } catch (LocdException e) {
                // A NaN or infinite origin or direction, or a negative max_t: e.Index is that ray,
                // and hits is empty. (Here it could come from a transform at NaN.)
                Debug.LogError("locd: " + e.Message);
                return;
            }
            watch.Stop();
            LastBatchMs = watch.Elapsed.TotalMilliseconds;
            ReadHits();
        }

        // The answers: ray k's hits are Ids[Offsets[k] .. Offsets[k + 1]), with their distances in T
        // (in units of the direction's length: with unit directions, world units), nearest first.
        // Closest and Any give exactly one entry per ray: id 0 (and T = +infinity) when it hit nothing.
        void ReadHits()
        {
            ulong* offsets = hits.Offsets;
            ulong* ids = hits.Ids;
            double* dist = hits.T;
            int hitCount = 0;
            for (int k = 0; k < rayCount; k++) {
                ulong first = offsets[k], end = offsets[k + 1];
                bool hit = end > first && ids[first] != 0;
                if (hit)
                    hitCount++;
                if (k < maxRaysDrawn) {
                    float reach = hit ? (float)dist[first] : rayLength;
                    Vector3 from = new Vector3(origins[3 * k], origins[3 * k + 1], origins[3 * k + 2]);
                    Vector3 dir = new Vector3(directions[3 * k], directions[3 * k + 1], directions[3 * k + 2]);
                    Debug.DrawLine(from, from + dir * reach, hit ? hitColor : missColor);
                }
                // Which obstacle? (int)scene.GetUser(ids[first]) is its index in obstacleBoxes.
            }
            RaysThatHit = hitCount;
        }

        // Rays from this GameObject spread evenly over the sphere (a Fibonacci lattice), turning slowly.
        void AimRays()
        {
            Vector3 p = transform.position;
            float turn = 0.3f * Time.time;
            for (int k = 0; k < rayCount; k++) {
                float y = 1f - 2f * (k + 0.5f) / rayCount;
                float r = Mathf.Sqrt(1f - y * y);
                float a = 2.3999632f * k + turn; // the golden angle
                origins[3 * k] = p.x;
                origins[3 * k + 1] = p.y;
                origins[3 * k + 2] = p.z;
                directions[3 * k] = r * Mathf.Cos(a);
                directions[3 * k + 1] = y;
                directions[3 * k + 2] = r * Mathf.Sin(a);
                maxT[k] = rayLength;
            }
        }

        // A few obstacles, in turn, bob up or down; one Move call gives the scene their new boxes.
        void MoveSomeObstacles()
        {
            if (movedIds.Length == 0)
                return;
            float step = Mathf.Sin(3f * Time.time) * 2f * Time.deltaTime;
            for (int j = 0; j < movedIds.Length; j++) {
                int i = nextToMove;
                nextToMove = (nextToMove + 1) % obstacleCount;
                obstacleBoxes[6 * i + 1] += step; // min y
                obstacleBoxes[6 * i + 4] += step; // max y
                movedIds[j] = obstacleIds[i];
                for (int v = 0; v < 6; v++)
                    movedBoxes[6 * j + v] = obstacleBoxes[6 * i + v];
            }
            scene.Move(movedIds, movedBoxes);
            // No scene.Update() is needed for queries. Call it when you also want the
            // overlapping pairs (see the CollisionPairs sample).
        }

        static void SetBox(float[] boxes, int i, Vector3 center, Vector3 size)
        {
            Vector3 lo = center - size * 0.5f, hi = center + size * 0.5f;
            boxes[6 * i] = lo.x;
            boxes[6 * i + 1] = lo.y;
            boxes[6 * i + 2] = lo.z;
            boxes[6 * i + 3] = hi.x;
            boxes[6 * i + 4] = hi.y;
            boxes[6 * i + 5] = hi.z;
        }
    }
}
