// Sample: broad-phase pairs of many colliders with locd, every physics step.
//
// Add this component to an empty GameObject and press Play. With `spawnDemo`
// on, it creates `demoCount` drifting trigger cubes under itself; otherwise it
// uses the colliders listed in `colliders` (or every Collider below it).
// Each FixedUpdate it copies the colliders' world bounds (Collider.bounds, an
// AABB) into a reused float[] and asks locd for the overlapping pairs into a
// reused uint[]: no managed allocation per frame once the buffers are big
// enough. OnDrawGizmos draws each overlapping pair (Scene view, or Game view
// with Gizmos on).
using Locd;
using UnityEngine;

namespace Locd.Samples
{
    public sealed class CollisionPairs : MonoBehaviour
    {
        [Tooltip("Colliders to test; empty = every Collider below this GameObject")]
        public Collider[] colliders;

        [Header("Demo scene")]
        public bool spawnDemo = true;
        public int demoCount = 2000;
        public float demoExtent = 40f;
        public float demoSpeed = 3f;

        [Header("Engine")]
        [Tooltip("Threads of the locd engine; 0 = one per core")]
        public int threads = 0;

        [Header("Gizmos")]
        public Color pairColor = new Color(1f, 0.3f, 0.1f, 1f);
        public Color boxColor = new Color(1f, 0.8f, 0.1f, 0.6f);
        public int maxPairsDrawn = 5000;

        /// <summary>Overlapping pairs found in the last FixedUpdate.</summary>
        public int PairCount { get { return pairCount; } }
        /// <summary>Time spent inside the C library in the last FixedUpdate (ms).</summary>
        public double LastNativeMs { get; private set; }

        Engine engine;
        float[] boxes = new float[0];     // 6 floats per collider, reused
        uint[] pairs = new uint[2 * 1024]; // i, j interleaved, grown by locd when needed
        int pairCount;
        Rigidbody[] demoBodies;

        void Awake()
        {
            if (spawnDemo && (colliders == null || colliders.Length == 0))
                SpawnDemo();
            if (colliders == null || colliders.Length == 0)
                colliders = GetComponentsInChildren<Collider>();
            engine = new Engine(threads);
        }

        void OnDestroy()
        {
            if (engine != null)
                engine.Dispose(); // stops the engine's threads now rather than at finalization
            engine = null;
        }

        void FixedUpdate()
        {
            if (engine == null)
                return;
            if (demoBodies != null)
                KeepDemoInside();
            int n = colliders.Length;
            if (boxes.Length < 6 * n)
                boxes = new float[6 * n]; // only when colliders were added
            for (int i = 0; i < n; i++) {
                Bounds b = colliders[i].bounds;
                Vector3 lo = b.min, hi = b.max;
                int k = 6 * i;
                boxes[k] = lo.x;
                boxes[k + 1] = lo.y;
                boxes[k + 2] = lo.z;
                boxes[k + 3] = hi.x;
                boxes[k + 4] = hi.y;
                boxes[k + 5] = hi.z;
            }
            try {
                pairCount = engine.FindPairs(boxes, n, ref pairs);
                LastNativeMs = engine.Stats.MsTotal;
            } catch (LocdException e) {
                // e.g. a collider with NaN bounds: e.BoxIndex names it.
                pairCount = 0;
                Debug.LogError("locd: " + e.Message + (e.BoxIndex >= 0 ? " (" + colliders[e.BoxIndex].name + ")" : ""));
            }
        }

        void OnDrawGizmos()
        {
            if (engine == null || colliders == null)
                return;
            int drawn = pairCount < maxPairsDrawn ? pairCount : maxPairsDrawn;
            for (int p = 0; p < drawn; p++) {
                Bounds a = colliders[pairs[2 * p]].bounds;
                Bounds b = colliders[pairs[2 * p + 1]].bounds;
                Gizmos.color = boxColor;
                Gizmos.DrawWireCube(a.center, a.size);
                Gizmos.DrawWireCube(b.center, b.size);
                Gizmos.color = pairColor;
                Gizmos.DrawLine(a.center, b.center);
            }
        }

        void SpawnDemo()
        {
            colliders = new Collider[demoCount];
            demoBodies = new Rigidbody[demoCount];
            for (int i = 0; i < demoCount; i++) {
                GameObject go = GameObject.CreatePrimitive(PrimitiveType.Cube);
                go.name = "locd demo " + i;
                go.transform.SetParent(transform, false);
                go.transform.localPosition = Random.insideUnitSphere * demoExtent;
                go.transform.localScale = Vector3.one * Random.Range(0.3f, 2f);
                var c = go.GetComponent<Collider>();
                c.isTrigger = true; // overlaps are reported, not resolved by PhysX
                var body = go.AddComponent<Rigidbody>();
                body.useGravity = false;
                body.velocity = Random.insideUnitSphere * demoSpeed;
                colliders[i] = c;
                demoBodies[i] = body;
            }
        }

        void KeepDemoInside()
        {
            Vector3 center = transform.position;
            for (int i = 0; i < demoBodies.Length; i++) {
                Rigidbody body = demoBodies[i];
                Vector3 d = body.position - center;
                if (d.sqrMagnitude > demoExtent * demoExtent && Vector3.Dot(d, body.velocity) > 0)
                    body.velocity = -body.velocity; // bounce back into the sphere
            }
        }
    }
}
