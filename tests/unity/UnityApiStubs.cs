// The part of Unity's scripting API (UnityEngine, UnityEditor; 2021 LTS and
// later, as documented at docs.unity3d.com/ScriptReference) that
// engines/unity/ReefgenImporter.cs calls, with Unity's own names and
// signatures and no behaviour: tests/unity_importer_test.sh compiles the
// importer against it with Debian's C# compiler, so a misspelt member, a
// wrong argument type or a syntax error fails without a Unity install.
using System;

namespace UnityEngine
{
    public class Object
    {
        public string name { get; set; }
        public static void DestroyImmediate(Object obj) { }
    }
    public class Component : Object
    {
        public Transform transform { get { return null; } }
        public T GetComponent<T>() { return default(T); }
    }
    public class Transform : Component
    {
        public Transform parent { get; set; }
        public Vector3 position { get; set; }
    }
    public sealed class GameObject : Object
    {
        public GameObject(string name) { }
        public Transform transform { get { return null; } }
        public T GetComponent<T>() { return default(T); }
    }
    public struct Vector2 { public Vector2(float x, float y) { } }
    public struct Vector3 { public Vector3(float x, float y, float z) { } }
    public struct Color
    {
        public Color(float r, float g, float b) { }
        public static Color grey { get { return new Color(0.5f, 0.5f, 0.5f); } }
    }
    public struct Color32 { public byte r, g, b, a; }
    public enum TextureFormat { RGBA32 = 4 }
    public class Texture : Object
    {
        public virtual int width { get { return 0; } set { } }
        public virtual int height { get { return 0; } set { } }
    }
    public sealed class Texture2D : Texture
    {
        public Texture2D(int width, int height, TextureFormat textureFormat, bool mipChain) { }
        public Color32[] GetPixels32() { return null; }
        public void SetPixel(int x, int y, Color color) { }
        public void Apply() { }
    }
    public static class ImageConversion
    {
        public static bool LoadImage(this Texture2D tex, byte[] data) { return false; }
    }
    public sealed class TerrainLayer : Object
    {
        public Texture2D diffuseTexture { get; set; }
        public Vector2 tileSize { get; set; }
    }
    public sealed class TerrainData : Object
    {
        public int heightmapResolution { get; set; }
        public Vector3 size { get; set; }
        public int alphamapResolution { get; set; }
        public TerrainLayer[] terrainLayers { get; set; }
        public void SetHeights(int xBase, int yBase, float[,] heights) { }
        public void SetAlphamaps(int x, int y, float[,,] map) { }
    }
    public sealed class Terrain : Component
    {
        public bool allowAutoConnect { get; set; }
        public void SetNeighbors(Terrain left, Terrain top, Terrain right, Terrain bottom) { }
        public static GameObject CreateTerrainGameObject(TerrainData assignTerrain) { return null; }
    }
    public static class JsonUtility
    {
        public static T FromJson<T>(string json) { return default(T); }
    }
}

namespace UnityEditor
{
    [AttributeUsage(AttributeTargets.Method, AllowMultiple = true)]
    public sealed class MenuItem : Attribute
    {
        public MenuItem(string itemName) { }
    }
    public sealed class EditorUtility
    {
        public static string OpenFolderPanel(string title, string folder, string defaultName) { return null; }
        public static bool DisplayDialog(string title, string message, string ok) { return true; }
        public static void DisplayProgressBar(string title, string info, float progress) { }
        public static void ClearProgressBar() { }
    }
    public sealed class AssetDatabase
    {
        public static void CreateAsset(UnityEngine.Object asset, string path) { }
        public static void SaveAssets() { }
        public static bool IsValidFolder(string path) { return false; }
        public static string CreateFolder(string parentFolder, string newFolderName) { return ""; }
    }
}
