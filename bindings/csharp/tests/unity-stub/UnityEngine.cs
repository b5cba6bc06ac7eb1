// A compile-only stub of the few UnityEngine types the package samples use, so
// CI can check that Samples~ compiles with mcs at C# 7.2 (no Unity installed).
// Signatures follow the UnityEngine scripting API; bodies do nothing.
using System;

namespace UnityEngine
{
    public class Object { public string name { get; set; } }
    public class Component : Object
    {
        public Transform transform { get { return null; } }
        public GameObject gameObject { get { return null; } }
        public T GetComponent<T>() { return default(T); }
        public T[] GetComponentsInChildren<T>() { return new T[0]; }
    }
    public class Behaviour : Component { public bool enabled { get; set; } }
    public class MonoBehaviour : Behaviour { }
    public class Transform : Component
    {
        public Vector3 position { get; set; }
        public Vector3 localPosition { get; set; }
        public Vector3 localScale { get; set; }
        public void SetParent(Transform parent, bool worldPositionStays) { }
    }
    public enum PrimitiveType { Sphere, Capsule, Cylinder, Cube, Plane, Quad }
    public sealed class GameObject : Object
    {
        public Transform transform { get { return null; } }
        public static GameObject CreatePrimitive(PrimitiveType type) { return new GameObject(); }
        public T GetComponent<T>() { return default(T); }
        public T AddComponent<T>() where T : Component, new() { return new T(); }
    }
    public class Collider : Component
    {
        public Bounds bounds { get { return default(Bounds); } }
        public bool isTrigger { get; set; }
    }
    public class Rigidbody : Component
    {
        public Vector3 velocity { get; set; }
        public Vector3 position { get; set; }
        public bool useGravity { get; set; }
    }
    public struct Vector3
    {
        public float x, y, z;
        public Vector3(float x, float y, float z) { this.x = x; this.y = y; this.z = z; }
        public static Vector3 one { get { return new Vector3(1, 1, 1); } }
        public float sqrMagnitude { get { return x * x + y * y + z * z; } }
        public static float Dot(Vector3 a, Vector3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
        public static Vector3 operator *(Vector3 a, float d) { return new Vector3(a.x * d, a.y * d, a.z * d); }
        public static Vector3 operator -(Vector3 a, Vector3 b) { return new Vector3(a.x - b.x, a.y - b.y, a.z - b.z); }
        public static Vector3 operator -(Vector3 a) { return new Vector3(-a.x, -a.y, -a.z); }
        public static Vector3 operator +(Vector3 a, Vector3 b) { return new Vector3(a.x + b.x, a.y + b.y, a.z + b.z); }
    }
    public struct Bounds
    {
        public Vector3 center { get; set; }
        public Vector3 size { get; set; }
        public Vector3 min { get; set; }
        public Vector3 max { get; set; }
    }
    public struct Color
    {
        public float r, g, b, a;
        public Color(float r, float g, float b, float a) { this.r = r; this.g = g; this.b = b; this.a = a; }
    }
    public static class Gizmos
    {
        public static Color color { get; set; }
        public static void DrawLine(Vector3 from, Vector3 to) { }
        public static void DrawWireCube(Vector3 center, Vector3 size) { }
    }
    public static class Random
    {
        public static Vector3 insideUnitSphere { get { return default(Vector3); } }
        public static float Range(float min, float max) { return min; }
    }
    public static class Debug
    {
        public static void LogError(object message) { }
        public static void DrawLine(Vector3 start, Vector3 end, Color color) { }
    }
    public static class Time
    {
        public static float time { get { return 0f; } }
        public static float deltaTime { get { return 0f; } }
    }
    public struct Mathf
    {
        public static float Sqrt(float f) { return (float)Math.Sqrt(f); }
        public static float Sin(float f) { return (float)Math.Sin(f); }
        public static float Cos(float f) { return (float)Math.Cos(f); }
        public static int Min(int a, int b) { return a < b ? a : b; }
    }
    public class PropertyAttribute : Attribute { }
    public sealed class TooltipAttribute : PropertyAttribute { public TooltipAttribute(string tooltip) { } }
    public sealed class HeaderAttribute : PropertyAttribute { public HeaderAttribute(string header) { } }
}
